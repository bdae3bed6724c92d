/// @file angle_constraint.hpp
/// @brief The angle at a particle between the segments to two others held fixed: one row,
/// three particles (a stiff bend or a fixed zig-zag in a chain).
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/dual.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <algorithm>
#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <vector>

namespace constrained_particles
{
/// Angle theta at vertex j between a = p_i - p_j and b = p_k - p_j held at theta_0:
///   C = theta - theta_0 [rad],  theta = atan2(|a x b|, a.b).
/// J = -b_perp / (|a| |b_perp|) at i,  -a_perp / (|b| |a_perp|) at k,  minus their sum at j,
/// with b_perp = b - (b.a / a.a) a and a_perp = a - (a.b / b.b) b (the derivative of theta along
/// each segment's normal in their plane). Jdot v = sum_k (d/dt J_k) . v_k, differentiated along v
/// with dual numbers (dual.hpp), exact to round-off.
/// At theta = 0 or pi the angle has no gradient; such holds are refused (limits::ANGLE) and a
/// joint that reaches them has a zero Jacobian row, which the solve reports as singular.
/// The metric error is |theta - theta_0| times the shorter segment [m].
struct AngleConstraint
{
  std::array<int, 3> particles{ { 0, 1, 2 } };  ///< i, j (the vertex), k
  double angle = NAN;                           ///< theta_0 [rad]; unset: the starting angle

  static constexpr const char* KIND = "angle";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT =
      true;                            ///< between its particles only (Model::isolated())
  static constexpr int ROWS = 1;       ///< one row of J
  static constexpr int PARTICLES = 3;  ///< touching i, j and k
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particles", &AngleConstraint::particles, FieldKind::Particles, nullptr,
              "i, j, k: the angle at j between the segments to i and to k"),
        field("angle", &AngleConstraint::angle, FieldKind::Number, &limits::ANGLE,
              "theta_0 (default: the angle it starts with)", true));
  }
};

/// Particles the row touches: i, j, k.
inline std::array<int, 3> rowParticles(const AngleConstraint& constraint)
{
  return constraint.particles;
}

namespace detail
{
/// The angle at j [rad] and the lengths of the two segments [m].
inline double jointAngle(const Vec3& a, const Vec3& b)
{
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

}  // namespace detail

/// C, J, Jdot v and the metric error at positions p [m], velocities v [m/s]. Stateless.
inline void evaluateRows(const AngleConstraint& constraint, const EffectContext& /*context*/,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  const int i = constraint.particles[0], j = constraint.particles[1], k = constraint.particles[2];
  const Vec3 a = positions.col(i) - positions.col(j), b = positions.col(k) - positions.col(j);
  const Vec3 va = velocities.col(i) - velocities.col(j);
  const Vec3 vb = velocities.col(k) - velocities.col(j);
  const double theta = detail::jointAngle(a, b);
  out.value[0] = theta - constraint.angle;
  out.violation[0] = std::abs(out.value[0]) * std::min(a.norm(), b.norm());
  // the gradient on dual numbers: value parts are J, derivative parts d/dt J along v
  const dual::Dual3 da = dual::moving(a, va), db = dual::moving(b, vb);
  const dual::Dual aa = dot(da, da), bb = dot(db, db), ab = dot(da, db);
  const dual::Dual3 b_perp = db - (ab / aa) * da;
  const dual::Dual3 a_perp = da - (ab / bb) * db;
  const dual::Dual b_perp_norm = sqrt(dot(b_perp, b_perp)), a_perp_norm = sqrt(dot(a_perp, a_perp));
  // straight or folded (or a segment of zero length): no direction to act along
  if (!(b_perp_norm.value > 1e-12 * std::sqrt(bb.value)) ||
      !(a_perp_norm.value > 1e-12 * std::sqrt(aa.value)))
  {
    out.jacobian[0] = out.jacobian[1] = out.jacobian[2] = Vec3::Zero();
    out.jdot_v[0] = 0.0;
    return;
  }
  const dual::Dual3 gi = (-dual::Dual{ 1.0, 0.0 } / (sqrt(aa) * b_perp_norm)) * b_perp;
  const dual::Dual3 gk = (-dual::Dual{ 1.0, 0.0 } / (sqrt(bb) * a_perp_norm)) * a_perp;
  const Vec3 ji = dual::valueOf(gi), jk = dual::valueOf(gk);
  const Vec3 ri = dual::rateOf(gi), rk = dual::rateOf(gk);
  out.jacobian[0] = ji;
  out.jacobian[1] = -(ji + jk);
  out.jacobian[2] = jk;
  // J_j = -(J_i + J_k): its rate is minus theirs, so Jdot v = ri.(v_i - v_j) + rk.(v_k - v_j)
  out.jdot_v[0] = ri.dot(va) + rk.dot(vb);
}

/// Geometric stiffness (stability.hpp), a rough bound: theta's Hessian is of order
/// 1 / (|a| |b| sin theta) and smaller; 4 |lambda| / (min(|a|, |b|)^2 max(sin theta, 1e-3)) is
/// added at each of i, j, k [N/m].
inline void addGeometricStiffness(const AngleConstraint& constraint,
                                  const EffectContext& /*context*/, const Points& positions,
                                  const double* multipliers, double* stiffness)
{
  const auto [i, j, k] = constraint.particles;
  const Vec3 a = positions.col(i) - positions.col(j), b = positions.col(k) - positions.col(j);
  const double shorter = std::min(a.norm(), b.norm());
  const double sine = a.cross(b).norm() / std::max(a.norm() * b.norm(), 1e-300);
  const double bound =
      4.0 * std::abs(multipliers[0]) / std::max(shorter * shorter * std::max(sine, 1e-3), 1e-300);
  for (int particle : constraint.particles)
    stiffness[particle] += bound;
}

/// |dtheta/dt| times the shorter segment [m/s].
inline void violationRates(const AngleConstraint& constraint, const EffectContext& context,
                           const Points& positions, const Points& velocities, double* rates)
{
  double value = 0, jdot_v = 0, violation = 0;
  Vec3 jacobian[3];
  evaluateRows(constraint, context, positions, velocities,
               RowBlock{ &value, &jdot_v, &violation, jacobian });
  double rate = 0.0;
  for (int k = 0; k < 3; ++k)
    rate += jacobian[k].dot(velocities.col(constraint.particles[k]));
  const int j = constraint.particles[1];
  rates[0] =
      std::abs(rate) * std::min((positions.col(constraint.particles[0]) - positions.col(j)).norm(),
                                (positions.col(constraint.particles[2]) - positions.col(j)).norm());
}

/// An unset angle is the one the particles start with.
/// @throws InvalidInput when a segment starts with zero length: it has no direction, no angle
inline void fillFromStart(AngleConstraint& constraint, const std::vector<Surface>& /*surfaces*/,
                          Points& positions, Points& /*velocities*/)
{
  if (isUnset(constraint.angle))
  {
    const int j = constraint.particles[1];
    const Vec3 a = positions.col(constraint.particles[0]) - positions.col(j);
    const Vec3 b = positions.col(constraint.particles[2]) - positions.col(j);
    // (non-finite starts are refused by the caller's range check, with their own reason)
    if (a.allFinite() && b.allFinite() && (a.norm() == 0.0 || b.norm() == 0.0))
      throw InvalidInput(
          "angle", "of the angle on particles [" + std::to_string(constraint.particles[0]) + ", " +
                       std::to_string(j) + ", " + std::to_string(constraint.particles[2]) +
                       "] cannot be taken from the start: two of them coincide, "
                       "so a segment has no direction; move them apart or give "
                       "the angle");
    constraint.angle = detail::jointAngle(a, b);
  }
}

/// @throws InvalidInput naming the bad field
inline void validate(const AngleConstraint& constraint, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  const double angle = constraint.angle;
  // straight or folded (often an unset angle taken from a straight start): say why it is refused
  if (std::isfinite(angle) && angle >= 0.0 && angle <= M_PI + 1e-9 &&
      !limits::ANGLE.contains(angle))
    throw InvalidInput(
        prefix.empty() ? "angle" : prefix + ".angle",
        "= " + formatValue(angle) + ", must be in " + limits::ANGLE.text() +
            ": a straight (pi) or folded (0) joint has no angle gradient, and one angle row "
            "holds one bending direction where a straight joint has two. An unset angle is the "
            "one the particles start with: start the joint bent, or hold a straight joint with "
            "a collinear record instead");
  validateFields(constraint, num_particles, num_surfaces, prefix, allow_unset);
}

}  // namespace constrained_particles
