/// @file collinear_constraint.hpp
/// @brief Three particles held on one straight line: two rows touching three particles. With
/// links i-j and j-k it makes a stiff (straight) rod, which one angle row cannot hold.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/dual.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace constrained_particles
{
/// Particle k held on the line through particles i and j: with a = p_j - p_i, d = p_k - p_j,
///   C = (e_1.d, e_2.d) [m],  e_1 = (a x r) / |a x r|,  e_2 = u x e_1,  u = a / |a|,
/// the offset of k from the line, across it; r is the coordinate axis least aligned with a, so
/// |a x r| >= sqrt(2/3) |a| (the pair turns about u when that axis changes; C keeps its size).
/// With w_1 = (I - e_1 e_1^T) d and w_2 = (I - e_1 e_1^T)(d x u), the gradients along a are
///   g_1 = r x w_1 / |a x r|,  g_2 = (I - u u^T)(e_1 x d) / |a| + r x w_2 / |a x r|,
/// so J_r = -g_r at i, g_r - e_r at j, e_r at k, and Jdot v = gdot_r.(v_j - v_i) +
/// edot_r.(v_k - v_j), the rates taken along v with dual numbers (dual.hpp), exact to round-off.
/// k behind j on the line (folded) also gives C = 0; with links, k cannot get there without
/// leaving the line. The metric error of both rows is |C| = hypot(C_1, C_2) [m], k's distance
/// from the line, whatever the pair. With context.frame_positions set (SHAKE's trial rows), r
/// is picked at those positions so C stays in the frame of the reference Jacobian. Where i and
/// j all but coincide (|a| <= 1e-12 |d|) there is no line: zero rows, reported singular.
struct CollinearConstraint
{
  std::array<int, 3> particles{ { 0, 1, 2 } };  ///< i, j, k: k on the line through i and j

  static constexpr const char* KIND = "collinear";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT =
      true;                            ///< between its particles only (Model::isolated())
  static constexpr int ROWS = 2;       ///< the two directions across the line
  static constexpr int PARTICLES = 3;  ///< each touching i, j and k
  static constexpr auto fields()
  {
    return std::make_tuple(field("particles", &CollinearConstraint::particles, FieldKind::Particles,
                                 nullptr, "i, j, k: k held on the line through i and j"));
  }
};

/// Particles the rows touch: i, j, k.
inline std::array<int, 3> rowParticles(const CollinearConstraint& constraint)
{
  return constraint.particles;
}

/// C, J, Jdot v and |C_r| at positions p [m], velocities v [m/s]. Stateless.
inline void evaluateRows(const CollinearConstraint& constraint, const EffectContext& context,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  using dual::Dual;
  using dual::Dual3;
  const int i = constraint.particles[0], j = constraint.particles[1], k = constraint.particles[2];
  const Vec3 a_value = positions.col(j) - positions.col(i);
  const Vec3 va = velocities.col(j) - velocities.col(i);
  const Vec3 vd = velocities.col(k) - velocities.col(j);
  const Dual3 a = dual::moving(a_value, va);
  const Dual3 d = dual::moving(positions.col(k) - positions.col(j), vd);
  const Dual a_norm = norm(a);
  // i and j (all but) coincide: no line; past these the gradients lose their digits or overflow
  if (!(a_norm.value > 1e-12 * norm(d).value) || !(a_norm.value > 1e-150))
  {
    for (int r = 0; r < 2; ++r)
    {
      out.value[r] = out.jdot_v[r] = 0.0;
      out.violation[r] = 0.0;
      out.jacobian[3 * r] = out.jacobian[3 * r + 1] = out.jacobian[3 * r + 2] = Vec3::Zero();
    }
    return;
  }
  // the frame's axis, picked where the caller's reference Jacobian was (SHAKE), else here
  const Vec3 a_frame = context.frame_positions
                           ? Vec3(context.frame_positions->col(j) - context.frame_positions->col(i))
                           : a_value;
  int least = 0;
  for (int axis = 1; axis < 3; ++axis)
    if (std::abs(a_frame[axis]) < std::abs(a_frame[least]))
      least = axis;
  const Dual3 r = dual::constant(Vec3::Unit(least));
  const Dual3 n = cross(a, r);
  const Dual n_norm = norm(n);
  const Dual one{ 1.0, 0.0 };
  const Dual3 u = (one / a_norm) * a;
  const Dual3 e1 = (one / n_norm) * n;
  const Dual3 e2 = cross(u, e1);
  // (I - e_1 e_1^T) x and (I - u u^T) x
  auto acrossE1 = [&](const Dual3& x) { return x - dot(e1, x) * e1; };
  auto acrossU = [&](const Dual3& x) { return x - dot(u, x) * u; };
  const std::array<Dual3, 2> e = { { e1, e2 } };
  const std::array<Dual3, 2> g = { { (one / n_norm) * cross(r, acrossE1(d)),
                                     (one / a_norm) * acrossU(cross(e1, d)) +
                                         (one / n_norm) * cross(r, acrossE1(cross(d, u))) } };
  for (int row = 0; row < 2; ++row)
    out.value[row] = dot(e[row], d).value;
  // k's distance from the line, the same whichever pair of directions measures it
  const double distance = std::hypot(out.value[0], out.value[1]);
  for (int row = 0; row < 2; ++row)
  {
    const Vec3 e_value = dual::valueOf(e[row]), g_value = dual::valueOf(g[row]);
    out.violation[row] = distance;
    out.jacobian[3 * row] = -g_value;
    out.jacobian[3 * row + 1] = g_value - e_value;
    out.jacobian[3 * row + 2] = e_value;
    out.jdot_v[row] = dual::rateOf(g[row]).dot(va) + dual::rateOf(e[row]).dot(vd);
  }
}

/// Geometric stiffness (stability.hpp), a rough bound: C = e_r.d turns with a = p_j - p_i, so its
/// Hessian is of order 1 / |a| + |d| / |a|^2; twice that times |lambda_1| + |lambda_2| is added
/// at each of i, j, k [N/m].
inline void addGeometricStiffness(const CollinearConstraint& constraint,
                                  const EffectContext& /*context*/, const Points& positions,
                                  const double* multipliers, double* stiffness)
{
  const auto [i, j, k] = constraint.particles;
  const double a = std::max((positions.col(j) - positions.col(i)).norm(), 1e-300);
  const double d = (positions.col(k) - positions.col(j)).norm();
  const double bound =
      2.0 * (std::abs(multipliers[0]) + std::abs(multipliers[1])) * (1.0 / a) * (1.0 + d / a);
  for (int particle : constraint.particles)
    stiffness[particle] += bound;
}

/// hypot(J_1 v, J_2 v) for both rows [m/s]: how fast k leaves the line, whatever the pair.
inline void violationRates(const CollinearConstraint& constraint, const EffectContext& context,
                           const Points& positions, const Points& velocities, double* rates)
{
  double value[2], jdot_v[2], violation[2];
  Vec3 jacobian[6];
  evaluateRows(constraint, context, positions, velocities,
               RowBlock{ value, jdot_v, violation, jacobian });
  double rate[2] = { 0.0, 0.0 };
  for (int row = 0; row < 2; ++row)
    for (int p = 0; p < 3; ++p)
      rate[row] += jacobian[3 * row + p].dot(velocities.col(constraint.particles[p]));
  rates[0] = rates[1] = std::hypot(rate[0], rate[1]);
}

/// @throws InvalidInput naming the bad field
inline void validate(const CollinearConstraint& constraint, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(constraint, num_particles, num_surfaces, prefix, allow_unset);
}

}  // namespace constrained_particles
