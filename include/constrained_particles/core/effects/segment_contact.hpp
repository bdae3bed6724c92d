/// @file segment_contact.hpp
/// @brief A rope's link as a capsule (its segment thickened by the rope's radius) that cannot
/// enter an obstacle: the segment between two particles keeps out of a shape where a particle
/// contact (shape_contact.hpp) keeps only the particles out, so no link cuts through a box's edge
/// or a thin post between its particles. One row that the contact stage (src/core/contact.hpp)
/// switches on and off. docs/physics.md, "Links as capsules".
#pragma once

#include "constrained_particles/core/effects/shape_contact.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace constrained_particles
{
/// How near either end of the segment its nearest point may lie [1, a fraction of the link]: the
/// row's point stays within [SEGMENT_END_FRACTION, 1 - SEGMENT_END_FRACTION], since at an end its
/// row would be the end particle's own contact row (J W J^T singular); the particle's ball keeps
/// that end out. A segment whose nearest point is pressed there is inside by at most
/// (SEGMENT_END_FRACTION |b - a|)^2 / (2 rho), rho the shape's radius of curvature.
constexpr double SEGMENT_END_FRACTION = 1e-3;

/// The segment from particle i to particle j (a link), thickened by r, outside shape S:
/// C = min_s d_S(x(s)) - r >= 0 [m], x(s) = (1 - s) p_i + s p_j, s in [SEGMENT_END_FRACTION,
/// 1 - SEGMENT_END_FRACTION], with multiplier lambda_n >= 0 (the normal force [N], since n is
/// unit) and lambda_n C = 0. At the minimiser s* (d/ds d_S = n . e = 0, e = p_j - p_i) the
/// envelope theorem gives J = ((1 - s*) n, s* n); s* moves with the state (ds*/dt = -(dn/dt . e
/// + n . de/dt) / (e^T H e)), so
///   Jdot v = w^T H w - (e^T H w + n . (v_j - v_i) + (omega x n) . e)^2 / (e^T H e)
///            - n . a_s,
/// w = (1 - s*) v_i + s* v_j - v_s the point's velocity relative to the shape's point there
/// (v_s, a_s and omega the shape's, 0 on a fixed one; a_s as in shape_contact.hpp); at a bound s*
/// is fixed and the fraction term is absent. Derived as shape_contact.hpp's row, from G(s, t) =
/// d(x(s, t)) with G_s = 0: Cddot = G_tt - G_st^2 / G_ss. The row may act only where s* lies
/// strictly between the bounds and the distance curves along the segment (SegmentSample::between);
/// a link lying flat on a face or along a capsule's side is held by its particles' contacts.
/// Inside a box or a cylinder the distance is the nearest face's, and its least along a segment
/// lies where two faces' distances meet: C has kinks there (J is one face's normal, no fraction
/// term). A segment whose centre line went inside (a step's travel over r) is met in time where
/// it is 2 projection tolerances in (contact.hpp, impactFraction), its centre line still outside
/// and curved; one found inside at a step's start is projected out along one face at a time
/// (resolveImpacts: only a nearest point at a bound is left to the particle's contact).
/// Frictionless (friction acts at the particles); restitution as a particle contact's.
struct SegmentContact
{
  int first = 0;             ///< particle i
  int second = 1;            ///< particle j, != i
  Shape shape;               ///< the obstacle, in the world frame (or its holder's)
  double radius = 0.0;       ///< r [m]: the rope's thickness / 2
  double restitution = 0.0;  ///< Newton's coefficient e [1]
  /// Its carried shape's index in Model::carriers() (numbered by Model::compile); -1: fixed.
  int carrier = -1;

  static constexpr const char* KIND = "segment_contact";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr bool UNILATERAL = true;           ///< rows switch on and off (contact.hpp)
  static constexpr int ROWS = 1;
  static constexpr int PARTICLES = 2;
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("first", &SegmentContact::first, FieldKind::Particle, nullptr, "particle i"),
        field("second", &SegmentContact::second, FieldKind::Particle, nullptr,
              "particle j, != i: the segment i-j keeps out"),
        field("shape", &SegmentContact::shape, FieldKind::Shape, nullptr,
              "the obstacle it stays out of (a name under `shapes` in scene files)"),
        field("radius", &SegmentContact::radius, FieldKind::Number, &limits::PARTICLE_RADIUS,
              "r: the segment's radius (the rope's thickness / 2)"),
        field("restitution", &SegmentContact::restitution, FieldKind::Number, &limits::RESTITUTION,
              "Newton's e: normal speed after an impact over before"));
  }
};

/// Particles the row touches, in block order.
inline std::array<int, 2> rowParticles(const SegmentContact& contact)
{
  return { { contact.first, contact.second } };
}

/// The segment's contact at one state: where along it, whether the row may act, and its frame
/// there (normal unit, gap C [m], curvature_term Cddot - J a [m/s^2], the shape's point's motion).
struct SegmentFrame
{
  double fraction = 0.0;  ///< s*: the contact point is (1 - s*) p_i + s* p_j
  bool at_bound = true;   ///< s* at a bound: that end is its particle's contact's
  bool between = false;   ///< s* strictly inside and the distance curved there: the row may act
  ContactFrame frame;

  /// The contact point's value of a per-particle quantity (position [m], velocity [m/s],
  /// acceleration [m/s^2]) given its particles': (1 - s*) first + s* second
  Vec3 pointAt(const Vec3& first, const Vec3& second) const
  {
    return (1.0 - fraction) * first + fraction * second;
  }
};

/// The point of the segment nearest the contact's shape (where `context` puts it), s* within the
/// bounds [SEGMENT_END_FRACTION, 1 - SEGMENT_END_FRACTION]. Stateless.
inline SegmentSample nearestPoint(const SegmentContact& contact, const ShapePose& pose,
                                  const Points& positions)
{
  return nearestOnSegment(contact.shape, pose, positions.col(contact.first),
                          positions.col(contact.second), SEGMENT_END_FRACTION,
                          1.0 - SEGMENT_END_FRACTION);
}
inline SegmentSample nearestPoint(const SegmentContact& contact, const EffectContext& context,
                                  const Points& positions)
{
  return nearestPoint(contact, shapePose(contact.shape, contact.carrier, context), positions);
}

/// The frame of `contact` at positions [m] and velocities [m/s]. Stateless.
inline SegmentFrame segmentFrame(const SegmentContact& contact, const EffectContext& context,
                                 const Points& positions, const Points& velocities)
{
  const Vec3 a = positions.col(contact.first), b = positions.col(contact.second);
  const Vec3 v_a = velocities.col(contact.first), v_b = velocities.col(contact.second);
  const ShapePose pose = shapePose(contact.shape, contact.carrier, context);
  const SegmentSample near = nearestPoint(contact, pose, positions);
  SegmentFrame out;
  out.fraction = near.fraction;
  out.at_bound = near.at_bound;
  out.between = near.between;
  ContactFrame& f = out.frame;
  const double s = near.fraction;
  const Vec3 e = b - a;
  const Vec3& n = near.sample.normal;
  const Eigen::Matrix3d& hessian = near.sample.hessian;
  f.normal = n;
  f.gap = near.sample.distance - contact.radius;
  const Vec3 v = out.pointAt(v_a, v_b);
  Vec3 w = v;
  double turning = 0.0;  // (omega x n) . e: the shape's turn tilting n against the segment
  if (pose.moving)
  {
    const Vec3 x = (1.0 - s) * a + s * b;
    const Vec3& omega = pose.angular_velocity;
    f.surface_velocity = pose.velocityAt(x);
    w = v - f.surface_velocity;
    f.surface_acceleration = pose.acceleration + omega.cross(v - pose.velocity) + omega.cross(w);
    turning = omega.cross(n).dot(e);
  }
  f.curvature_term = w.dot(hessian * w) - n.dot(f.surface_acceleration);
  if (near.between)  // s* moves with the state: d/ds of the rate, squared, over d2/ds2
  {
    const double rate = e.dot(hessian * w) + n.dot(v_b - v_a) + turning;
    f.curvature_term -= rate * rate / e.dot(hessian * e);
  }
  return out;
}

/// The row at (p, v) as if active (the contact stage zeroes it when off). Stateless.
inline void evaluateRows(const SegmentContact& contact, const EffectContext& context,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  const SegmentFrame s = segmentFrame(contact, context, positions, velocities);
  out.jacobian[0] = (1.0 - s.fraction) * s.frame.normal;
  out.jacobian[1] = s.fraction * s.frame.normal;
  out.value[0] = s.frame.gap;
  out.jdot_v[0] = s.frame.curvature_term;
  out.violation[0] = std::abs(s.frame.gap);
  if (out.time_rate)
    out.time_rate[0] = s.frame.timeRate();
}

/// Geometric stiffness (stability.hpp): |lambda| times the row Hessian's largest row sum on each
/// particle ((1 - s*)^2 H and s*^2 H; the fraction's own term only lowers it) [N/m].
inline void addGeometricStiffness(const SegmentContact& contact, const EffectContext& context,
                                  const Points& positions, const double* multipliers,
                                  double* stiffness)
{
  const SegmentSample near = nearestPoint(contact, context, positions);
  const double size =
      std::abs(multipliers[0]) * near.sample.hessian.cwiseAbs().rowwise().sum().maxCoeff();
  const double s = near.fraction;
  stiffness[contact.first] += (1.0 - s) * (1.0 - s) * size;
  stiffness[contact.second] += s * s * size;
}

/// On or inside the shape, the approach speed max(0, -Cdot) [m/s]; outside, 0 (it may leave).
inline void violationRates(const SegmentContact& contact, const EffectContext& context,
                           const Points& positions, const Points& velocities, double* rates)
{
  const SegmentFrame s = segmentFrame(contact, context, positions, velocities);
  const Vec3 v = s.pointAt(velocities.col(contact.first), velocities.col(contact.second));
  rates[0] = s.frame.gap > 0.0 ? 0.0 : std::max(0.0, -s.frame.normal.dot(s.frame.relative(v)));
}

/// How deep inside the shape the capsule is, max(0, -C) [m], where its row can act on it: 0
/// where the nearest point is at a bound (that end's ball is its particle contact's, and the
/// capsule beside it may be in by at most the bound's (SEGMENT_END_FRACTION |e|)^2 / (2 rho)).
inline double penetration(const SegmentContact& contact, const EffectContext& context,
                          const Points& positions)
{
  const SegmentSample near = nearestPoint(contact, context, positions);
  return near.at_bound ? 0.0 : std::max(0.0, contact.radius - near.sample.distance);
}

/// @throws InvalidInput naming the bad field
inline void validate(const SegmentContact& contact, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(contact, num_particles, num_surfaces, prefix, allow_unset);
  requireDistinctParticles(contact.first, contact.second, prefix);
  requireRoundedEdges(contact.shape, contact.radius, prefix + ".radius");
  if (contact.shape.type == ShapeType::Plane)
    throw InvalidInput(prefix + ".shape",
                       "= '" + contact.shape.name +
                           "', a plane: a segment's nearest point to a plane is always an end, "
                           "which its particle's shape_contact holds; name a sphere, box, capsule "
                           "or cylinder");
  if (contact.shape.type == ShapeType::Mesh)
    throw InvalidInput(prefix + ".shape",
                       "= '" + contact.shape.name +
                           "', a mesh: a segment's nearest point is found on a convex shape's "
                           "distance (one minimum along it), and a mesh's has several; its "
                           "particles' shape_contacts keep them out of it (a chain's capsules: "
                           "false)");
}

}  // namespace constrained_particles
