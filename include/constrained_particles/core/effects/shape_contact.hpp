/// @file shape_contact.hpp
/// @brief A particle of radius r that cannot enter an obstacle (shapes.hpp): a unilateral contact
/// with Coulomb friction, one row that the contact stage (src/core/contact.hpp) switches on and
/// off exactly as a surface contact's. docs/physics.md, "Obstacles".
#pragma once

#include "constrained_particles/core/anchor_track.hpp"
#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"
#include "constrained_particles/core/effects/surface_contact.hpp"
#include "constrained_particles/core/shapes.hpp"

#include <array>
#include <cmath>
#include <vector>

namespace constrained_particles
{
/// Particle i (a ball of radius r) outside shape S:  C = d_S(p_i) - r >= 0 [m], d_S the shape's
/// signed distance, with multiplier lambda_n >= 0 and lambda_n C = 0: one row, J = grad d_S (unit,
/// so lambda_n is the normal force [N]), Jdot v = v^T (Hessian of d_S) v. Friction and impacts as
/// a surface contact's (surface_contact.hpp).
///
/// A carried shape (Shape::carried(): on a tf frame or a pose topic) moves as its track
/// (Data::carriers[carrier]) says: origin o(t), rotation R(t), turning at omega (constant between
/// samples). With w = v - v_o - omega x (p - o) the particle's velocity relative to the body's
/// point under it, Cdot = n . w (so dC/dt = -n . (v_o + omega x (p - o))) and
/// Cddot = n . a - n . (a_o + omega x (v - v_o) + omega x w) + w^T H w: the row's "Jdot v" is
/// the terms after n . a (derived from q = R^T (p - o), d = d_local(q); with omega = 0,
/// Cddot = n . (a - a_o) + w^T H w).
struct ShapeContact
{
  int particle = 0;          ///< particle i
  Shape shape;               ///< the obstacle, in the world frame
  double radius = 0.0;       ///< r [m]: the particle's, or the rope's, thickness / 2
  double friction = 0.0;     ///< Coulomb coefficient mu [1]; 0: frictionless
  double restitution = 0.0;  ///< Newton's coefficient e [1]
  /// Its carried shape's index in Model::carriers() and Data::carriers (Model::compile numbers
  /// them by name); -1: the shape is fixed. Not a scene field.
  int carrier = -1;

  static constexpr const char* KIND = "shape_contact";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr bool UNILATERAL = true;           ///< rows switch on and off (contact.hpp)
  static constexpr bool PARTICLE_CONTACT = true;     ///< one particle against the world
  static constexpr int ROWS = 1;
  static constexpr int PARTICLES = 1;
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &ShapeContact::particle, FieldKind::Particle, nullptr, "particle i"),
        field("shape", &ShapeContact::shape, FieldKind::Shape, nullptr,
              "the obstacle it stays out of (a name under `shapes` in scene files)"),
        field("radius", &ShapeContact::radius, FieldKind::Number, &limits::PARTICLE_RADIUS,
              "r: the particle's radius against the shape"),
        field("friction", &ShapeContact::friction, FieldKind::Number, &limits::FRICTION,
              "Coulomb's mu: sticks while |f_t| <= mu |f_n| (0: frictionless)"),
        field("restitution", &ShapeContact::restitution, FieldKind::Number, &limits::RESTITUTION,
              "Newton's e: normal speed after an impact over before"));
  }
};

/// Particles the row touches.
inline std::array<int, 1> rowParticles(const ShapeContact& contact)
{
  return { { contact.particle } };
}

/// Where `shape` is at context.time and how it moves: its own pose at rest if fixed (`carrier`
/// -1, or no tracks are given); else track `carrier`'s frame (origin, orientation, angular
/// velocity) times the shape's pose in that frame.
inline ShapePose shapePose(const Shape& shape, int carrier, const EffectContext& context)
{
  if (carrier < 0 || !context.carriers ||
      static_cast<std::size_t>(carrier) >= context.carriers->size())
    return fixedPose(shape);
  const AnchorTrack& track = (*context.carriers)[static_cast<std::size_t>(carrier)];
  const ImposedMotion frame = track.motion(context.time);
  const Eigen::Matrix3d turn = track.orientation(context.time).toRotationMatrix();
  const Vec3 omega = track.angularVelocity(context.time);
  const Vec3 arm = turn * shape.position;  // the frame's origin to the shape's
  ShapePose pose;
  pose.origin = frame.position + arm;
  pose.rotation = turn * shape.rotation;
  pose.angular_velocity = omega;
  pose.velocity = frame.velocity + omega.cross(arm);
  pose.acceleration = frame.acceleration + omega.cross(omega.cross(arm));
  pose.moving = !(pose.velocity.isZero(0.0) && pose.acceleration.isZero(0.0) && omega.isZero(0.0));
  return pose;
}

/// Where the contact's shape is at context.time and how it moves.
inline ShapePose shapePose(const ShapeContact& contact, const EffectContext& context)
{
  return shapePose(contact.shape, contact.carrier, context);
}

/// The contact's frame at positions p [m], velocities v [m/s]: J = the shape's unit normal,
/// C = distance - r, and Cddot - J a (v^T H v on a fixed shape; the moving terms above on a
/// carried one). Stateless.
inline ContactFrame contactFrame(const ShapeContact& contact, const EffectContext& context,
                                 const Points& positions, const Points& velocities)
{
  const Vec3 v = velocities.col(contact.particle);
  const Vec3 p = positions.col(contact.particle);
  const ShapePose pose = shapePose(contact, context);
  const ShapeSample s = evaluateShape(contact.shape, pose, p);
  ContactFrame f;
  f.normal = s.normal;
  f.gap = s.distance - contact.radius;
  if (!pose.moving)
  {
    f.curvature_term = v.dot(s.hessian * v);
    return f;
  }
  f.surface_velocity = pose.velocityAt(p);
  const Vec3 w = v - f.surface_velocity;
  const Vec3& omega = pose.angular_velocity;
  f.surface_acceleration = pose.acceleration + omega.cross(v - pose.velocity) + omega.cross(w);
  f.curvature_term = w.dot(s.hessian * w) - s.normal.dot(f.surface_acceleration);
  return f;
}

/// The row at (p, v) as if active (the contact stage zeroes it when off). Stateless.
inline void evaluateRows(const ShapeContact& contact, const EffectContext& context,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  evaluateContactRow(contact, context, positions, velocities, out);
}

/// Geometric stiffness (stability.hpp): |lambda| times the row Hessian's largest row sum
/// (its infinity norm) [N/m], added to the particle's entry as the other kinds add theirs.
inline void addGeometricStiffness(const ShapeContact& contact, const EffectContext& context,
                                  const Points& positions, const double* multipliers,
                                  double* stiffness)
{
  const ShapeSample s =
      evaluateShape(contact.shape, shapePose(contact, context), positions.col(contact.particle));
  stiffness[contact.particle] +=
      std::abs(multipliers[0]) * s.hessian.cwiseAbs().rowwise().sum().maxCoeff();
}

/// On or inside the shape, the approach speed max(0, -Cdot) [m/s]; outside, 0 (it may leave).
inline void violationRates(const ShapeContact& contact, const EffectContext& context,
                           const Points& positions, const Points& velocities, double* rates)
{
  contactViolationRate(contact, context, positions, velocities, rates);
}

/// How deep inside the shape the particle's ball is, max(0, -C) [m].
inline double penetration(const ShapeContact& contact, const EffectContext& context,
                          const Points& positions)
{
  return std::max(0.0, contact.radius - evaluateShape(contact.shape, shapePose(contact, context),
                                                      positions.col(contact.particle))
                                            .distance);
}

/// A point (radius 0) against a box, a cylinder or a mesh is refused: their edges and rim are
/// sharp, and a point's contact normal turns through 90 degrees on one, within a step (it launched
/// a particle through the box); a ball of radius r rolls over them, its centre on a surface rounded
/// by r.
/// @throws InvalidInput naming `field`
inline void requireRoundedEdges(const Shape& shape, double radius, const std::string& field)
{
  if ((shape.type == ShapeType::Box || shape.type == ShapeType::Cylinder ||
       shape.type == ShapeType::Mesh) &&
      !(radius > 0.0))
    throw InvalidInput(field, "= " + formatValue(radius) + " against " + shapeTypeName(shape.type) +
                                  " '" + shape.name + "', must be > 0 (in (0, " +
                                  formatValue(limits::PARTICLE_RADIUS.high) +
                                  "] m): its edges are sharp, and a point's contact normal turns "
                                  "through 90 degrees on one; a ball of radius r rolls over them");
}

/// @throws InvalidInput naming the bad field
inline void validate(const ShapeContact& contact, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(contact, num_particles, num_surfaces, prefix, allow_unset);
  requireRoundedEdges(contact.shape, contact.radius, prefix + ".radius");
}

}  // namespace constrained_particles
