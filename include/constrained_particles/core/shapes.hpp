/// @file shapes.hpp
/// @brief Obstacle shapes a particle cannot enter: plane, sphere, box, capsule and cylinder, each
/// a closed-form signed distance with its gradient and Hessian (the contact row's J and Jdot v are
/// read from them, exactly), and a closed triangle mesh (triangle_mesh.hpp: exact too, from its
/// nearest feature). Conventions are URDF's and FCL's: a shape sits at `position`, turned
/// by roll-pitch-yaw `rpy`; a box's `size` is its full sides, a cylinder's and a capsule's axis is
/// their local z with `length` the straight part, centred. docs/physics.md, "Obstacles".
///
/// Why closed forms and not FCL: these five shapes' distances are exact in a few lines and their
/// Hessians (which the row's Jdot v needs) are not something FCL gives. A mesh's nearest triangle
/// is found by FCL's bounding-volume tree (src/scenes/mesh_file.cpp), where a library earns its
/// keep; its distance from that triangle's feature is closed-form here.
#pragma once

#include "constrained_particles/core/triangle_mesh.hpp"
#include "constrained_particles/core/types.hpp"

#include <Eigen/Geometry>

#include <memory>
#include <string>
#include <vector>

namespace constrained_particles
{
/// Kinds of obstacle.
enum class ShapeType
{
  Plane,     ///< the half-space below the local x-y plane (its normal is the local z)
  Sphere,    ///< radius
  Box,       ///< size: full side lengths along the local x, y, z
  Capsule,   ///< radius, length: a segment of `length` along the local z, thickened by radius
  Cylinder,  ///< radius, length: along the local z, flat ends
  Mesh,      ///< mesh: a closed triangle mesh in the local frame (triangle_mesh.hpp)
};

/// One obstacle: fixed in the world frame, or carried by a holder outside the core (a tf frame,
/// a PoseStamped topic) whose path is a track (Data::carriers), its pose then in the holder's.
struct Shape
{
  std::string name;  ///< for messages and markers (its key under `shapes` in a scene file)
  ShapeType type = ShapeType::Sphere;
  Vec3 position = Vec3::Zero();  ///< its origin (centre; a plane: a point on it) [m]
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< world (or holder) from local [1]
  double radius = 0.5;                                     ///< sphere, capsule, cylinder [m]
  double length = 1.0;       ///< capsule's segment, cylinder's height [m]
  Vec3 size = Vec3::Ones();  ///< box's full sides [m]
  /// A mesh's triangles (shared, const; null for the other types)
  std::shared_ptr<const TriangleMesh> mesh;
  /// The tf frame that carries it (position and rotation are then in that frame), or empty
  std::string frame;
  /// A geometry_msgs/PoseStamped topic that carries it instead, or empty
  std::string topic;

  /// True if a holder outside the core moves it.
  bool carried() const
  {
    return !frame.empty() || !topic.empty();
  }
};

/// Whether carried shapes `a` and `b` are one obstacle on one holder: the same name, frame and
/// topic (another holder's track is not this one's: its shape starts at its pose as written).
inline bool sameCarrier(const Shape& a, const Shape& b)
{
  return a.name == b.name && a.frame == b.frame && a.topic == b.topic;
}

/// A carried shape's holder by name: the tf frame, or the pose topic (as a frame anchor's).
inline const std::string& holderOf(const Shape& shape)
{
  return shape.frame.empty() ? shape.topic : shape.frame;
}

/// Where a shape is at a time and how its body moves there: its pose (world from local) and the
/// velocity field of a rigid body, v(p) = velocity + angular_velocity x (p - origin), with the
/// angular velocity constant over the instant (a holder's track turns at a constant rate between
/// its samples, AnchorTrack::angularVelocity). A fixed shape: its own pose, at rest.
struct ShapePose
{
  Vec3 origin = Vec3::Zero();                              ///< [m]
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< world from local [1]
  Vec3 velocity = Vec3::Zero();                            ///< of the origin [m/s]
  Vec3 acceleration = Vec3::Zero();                        ///< of the origin [m/s^2]
  Vec3 angular_velocity = Vec3::Zero();                    ///< [rad/s], world frame
  bool moving = false;                                     ///< any of the three non-zero

  /// The velocity of the body's point at p [m/s].
  Vec3 velocityAt(const Vec3& p) const
  {
    return velocity + angular_velocity.cross(p - origin);
  }
};

/// A fixed shape's pose: its own.
ShapePose fixedPose(const Shape& shape);

/// The signed distance from a point to a shape's surface and its derivatives, in the world frame.
struct ShapeSample
{
  double distance = 0.0;                              ///< > 0 outside, < 0 inside [m]
  Vec3 normal = Vec3::UnitZ();                        ///< its gradient: unit, outward [1]
  Eigen::Matrix3d hessian = Eigen::Matrix3d::Zero();  ///< its second derivatives [1/m]
};

/// Least radius of curvature a Hessian is taken with [m]: a box's edges and corners and a
/// cylinder's rim are sharp (curvature 1 / distance, unbounded on them), so within this distance
/// of one the Hessian is that of an edge rounded this much.
constexpr double MIN_CURVATURE_RADIUS = 1e-6;

/// The signed distance of point `p` [m] (world) from `shape`, with its gradient and Hessian.
/// Outside, the distance is C1 (its Hessian jumps between a face and an edge); inside, it is the
/// nearest face's (a box, a cylinder: their pieces meet at edges). Where the gradient is undefined
/// the normal is taken as the local +z (a sphere's or a capsule's centre, a point on a box's
/// surface) or the local +x (a cylinder's axis, its side nearest). A mesh: the distance from its
/// nearest triangle's nearest feature (a face: flat; an edge or a vertex: round, rounded by
/// MIN_CURVATURE_RADIUS as a box's), signed by that feature's pseudonormal; on the surface, the
/// face's normal. Stateless; no allocation.
ShapeSample evaluateShape(const Shape& shape, const Vec3& p);
/// The same with the shape at `pose` (its own position and rotation ignored).
ShapeSample evaluateShape(const Shape& shape, const ShapePose& pose, const Vec3& p);

/// The point of a segment nearest a shape: least signed distance along it.
struct SegmentSample
{
  double fraction = 0.0;  ///< s: the point is a + s (b - a) [1]
  ShapeSample sample;     ///< the shape's distance and its derivatives there
  /// The minimum is at a bound (low or high), where d/ds points inwards or is 0: s stays there
  bool at_bound = true;
  /// s minimises the distance between the bounds (d/ds = 0 there), not at one, and the distance
  /// curves along the segment there ((b - a)^T H (b - a) > 1e-6 |b - a|: not flat, as along a
  /// face, a capsule's side, or inside a box, where the nearest face's distance is linear): s
  /// moves with the segment
  bool between = false;
};

/// The point of segment a-b [m] (world) nearest `shape` at `pose`, s within [low, high] (0 <=
/// low < high <= 1): a shape's signed distance is convex (each is convex, but a mesh, which
/// segment contacts refuse: segment_contact.hpp), so along the segment
/// it has one minimum, found where d/ds = n . (b - a) changes sign, by Newton's steps on
/// d2/ds2 = (b - a)^T H (b - a) kept inside a bracket (bisection where they leave it), to
/// rounding. Stateless; no allocation.
SegmentSample nearestOnSegment(const Shape& shape, const ShapePose& pose, const Vec3& a,
                               const Vec3& b, double low, double high);

/// World from local for roll, pitch, yaw [rad] (URDF: about fixed x, then y, then z).
Eigen::Matrix3d rotationFromRpy(const Vec3& rpy);

/// "plane", "sphere", ...
const char* shapeTypeName(ShapeType type);
/// Every type's name, in enum order.
std::vector<std::string> shapeTypeNames();
/// @throws InvalidInput naming `field` and the valid names
ShapeType parseShapeType(const std::string& name, const std::string& field);

/// Throws InvalidInput naming `field`.<member> unless every size is in limits::SHAPE_SIZE, the
/// position in limits::COORDINATE, the rotation orthonormal, and at most one of frame and topic
/// is set (a frame without a leading '/').
void validateShape(const Shape& shape, const std::string& field);

}  // namespace constrained_particles
