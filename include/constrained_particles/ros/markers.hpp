/// @file markers.hpp
/// @brief rviz markers: constraint-force arrows and the scene (particles, links, surface mesh).
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/limits.hpp"

#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

namespace constrained_particles
{
/// Namespace of the constraint-force arrows; marker id = particle index.
constexpr const char* CONSTRAINT_FORCE_NAMESPACE = "constraint_forces";
/// rviz namespace of the surface contacts' normal and friction force arrows.
constexpr const char* CONTACT_FORCE_NAMESPACE = "contact_forces";
/// With ~force_scale 0 the largest arrow is this share of the region's radius [1].
constexpr double FORCE_ARROW_FRACTION = 0.15;

/// The diameter particles are drawn with [m]: the rope's (twice its shape_contact radius) if it
/// has one, else 0.3 of the shortest link (0.15 m without links).
double particleSize(const Model& model);

/// With ~force_scale 0, forces below this share of the scene's weight (total mass x 9.81 m/s^2)
/// are not blown up to full-length arrows: round-off in a scene at rest stays invisible [1].
constexpr double ARROW_FORCE_FLOOR = 1e-3;

/// Arrow length per newton [m/N]: `force_scale` if > 0, else FORCE_ARROW_FRACTION of
/// `region_radius` [m] over the largest force, or over `force_floor` [N] if that is larger (0
/// when both are 0).
double arrowScale(double force_scale, const Points& forces, double region_radius,
                  double force_floor);

/// ARROW_FORCE_FLOOR of the model's weight [N].
double arrowForceFloor(const Model& model);

/// One ARROW per particle from its position [m] along its constraint force [N], `scale` [m/N]
/// per newton (arrowScale), coloured by |f| / the largest |f| now: blue at 0 to red at 1. Arrows
/// with ids in [positions.cols(), previous_count) are deleted.
visualization_msgs::MarkerArray constraintForceMarkers(const std_msgs::Header& header,
                                                       const Points& positions,
                                                       const Points& forces, double scale,
                                                       int previous_count);

/// Two ARROWs per surface contact (ids 2k, 2k + 1; ns CONTACT_FORCE_NAMESPACE), from its particle
/// along its normal force (green) and its friction (orange) [N], `scale` [m/N]; a contact that does
/// not act, or a non-finite force, is a DELETE of its arrows; so are ids in [2 contacts,
/// previous_count) (a scene with fewer contacts than the last). A link's capsule against an
/// obstacle (segment_contact) is one green ARROW (id 2k) from its point nearest it, and a rope's
/// link pair (link_pair_contact) one from link a's point nearest link b: the push on link a.
/// Carried obstacles are where `carriers` (Data::carriers) puts them at `time` [s].
visualization_msgs::MarkerArray contactForceMarkers(
    const std_msgs::Header& header, const Model& model, const Points& positions,
    const std::vector<ContactState>& contacts, double scale, int previous_count,
    const std::vector<AnchorTrack>* carriers = nullptr, double time = 0.0);

/// The scene's surfaces as one TRIANGLE_LIST mesh (ns "surface", id 0) over the region's x-y
/// extent, `cells` cells per side (2 triangles each; cells where a formula is undefined left out),
/// or a DELETE of it when the scene has no surface. Made once per scene (~surface, latched).
visualization_msgs::MarkerArray surfaceMarkers(const std_msgs::Header& header, const Model& model,
                                               const Vec3& region_low, const Vec3& region_high,
                                               int cells);

/// The scene's obstacles (shape_contact records' shapes, each once by name), ns "obstacles", one
/// marker per shape (a capsule: a CYLINDER and two SPHEREs), posed as the shapes are; a plane as
/// a thin CUBE over the region's extent. DELETEALL first, so a scene change leaves none of the
/// last scene's. Made once per scene (~obstacles, latched): a shape carried by a tf frame is
/// drawn in that frame (header.frame_id its frame, its pose there), so rviz moves it with tf; one
/// carried by a pose topic is drawn in header's frame where its track (`carriers`, one per
/// Model::carriers()) puts it at `time` [s], or not at all without them (the node publishes
/// again at each publish tick while a scene has such shapes: topicCarriedShapes()).
/// `topic_carried_only`: those shapes' markers alone (ids as in the whole set), after the
/// DELETEALL.
visualization_msgs::MarkerArray obstacleMarkers(const std_msgs::Header& header, const Model& model,
                                                const Vec3& region_low, const Vec3& region_high,
                                                const std::vector<AnchorTrack>* carriers = nullptr,
                                                double time = 0.0, bool topic_carried_only = false);

/// Whether the model has a shape carried by a pose topic (drawn where its track puts it, so
/// ~obstacles goes out again with each state).
bool topicCarriedShapes(const Model& model);

/// Scene markers: particles (SPHERE_LIST, ns "particles") and links and slack links (LINE_LIST,
/// ns "links"; a DELETE when there are none), each coloured by its tension under `multipliers`
/// (Data::multipliers' layout) over the largest |tension| now: grey at none, red at the largest
/// pull, blue at the largest push (all grey where the multipliers are short or not finite).
visualization_msgs::MarkerArray sceneMarkers(const std_msgs::Header& header, const Model& model,
                                             const Points& positions,
                                             const Eigen::VectorXd& multipliers);

/// A link's colour at `tension` [N] against the `largest` |tension| now [N] (sceneMarkers).
std_msgs::ColorRGBA tensionColor(double tension, double largest);

/// Namespaces of the live accuracy's ghosts: the shadow reference's particles and the segments
/// from each live particle to its reference (their length is the error).
constexpr const char* REFERENCE_NAMESPACE = "reference";
constexpr const char* REFERENCE_ERROR_NAMESPACE = "reference_error";

/// The shadow reference as faint ghost spheres (SPHERE_LIST, ns "reference") and a line from each
/// live particle to its ghost (LINE_LIST, ns "reference_error"), both at the same sim time;
/// `lifetime` [s] lets them fade when the live accuracy is turned off.
visualization_msgs::MarkerArray referenceMarkers(const std_msgs::Header& header, const Model& model,
                                                 const Points& live, const Points& reference,
                                                 double lifetime);

}  // namespace constrained_particles
