/// @file markers.hpp
/// @brief rviz markers: constraint-force arrows and the scene (particles, links, surface mesh).
#pragma once

#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/limits.hpp"

#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

namespace constrained_particles
{
/// Namespace of the constraint-force arrows; marker id = particle index.
constexpr const char* CONSTRAINT_FORCE_NAMESPACE = "constraint_forces";

/// One ARROW per particle from its position [m] along its constraint force [N], length
/// force_scale [m/N] per newton, coloured blue (smallest) to red (largest magnitude). Arrows with
/// ids in [positions.cols(), previous_count) are deleted.
visualization_msgs::MarkerArray constraintForceMarkers(const std_msgs::Header& header,
                                                       const Points& positions,
                                                       const Points& forces, double force_scale,
                                                       int previous_count);

/// Triangle mesh of a surface over an x-y region, cached until the particles leave it.
class SurfaceMeshCache
{
public:
  /// @param cells cells per side of the mesh, in limits::MESH_CELLS (2 triangles per cell)
  explicit SurfaceMeshCache(int cells = 40) : cells_(cells)
  {
  }

  /// The mesh of every surface of the model around the given particles, rebuilt when the scene
  /// changed (`scene_changed`) or a particle left the meshed region.
  const visualization_msgs::Marker& mesh(const std_msgs::Header& header, const Model& model,
                                         const Points& positions, bool scene_changed);

private:
  int cells_;
  visualization_msgs::Marker marker_;
  double min_x_ = 0, max_x_ = -1, min_y_ = 0, max_y_ = -1;  // meshed region [m]
};

/// Scene markers: particles (SPHERE_LIST, ns "particles"), links (LINE_LIST, ns "links"), and
/// the surface mesh (TRIANGLE_LIST, ns "surface"); an absent kind is sent as DELETE.
visualization_msgs::MarkerArray sceneMarkers(const std_msgs::Header& header, const Model& model,
                                             const Points& positions, SurfaceMeshCache& mesh_cache,
                                             bool scene_changed);

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
