/// @file link_constraint.hpp
/// @brief A rigid link between two particles, one constraint row.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <array>
#include <cmath>

namespace constrained_particles
{
/// Link of fixed length between particles i and j:  C = (|p_i - p_j|^2 - l^2) / 2  [m^2]
/// (seed problem 3's halved form; the force J^T lambda does not depend on the scaling).
/// J = (p_i - p_j) at i, (p_j - p_i) at j;  Jdot v = |v_i - v_j|^2.
struct LinkConstraint
{
  int first = 0;      ///< particle i
  int second = 1;     ///< particle j, != i
  double length = 1;  ///< l [m]

  static constexpr const char* KIND = "link";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT =
      true;                            ///< between its particles only (Model::isolated())
  static constexpr int ROWS = 1;       ///< one row of J
  static constexpr int PARTICLES = 2;  ///< touching i and j
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("first", &LinkConstraint::first, FieldKind::Particle, nullptr, "particle i"),
        field("second", &LinkConstraint::second, FieldKind::Particle, nullptr, "particle j, != i"),
        field("length", &LinkConstraint::length, FieldKind::Number, &limits::LINK_LENGTH, "l"));
  }
};

/// Particles the row touches, in block order.
inline std::array<int, 2> rowParticles(const LinkConstraint& constraint)
{
  return { { constraint.first, constraint.second } };
}

/// The link's scalar formulas, one copy: evaluateRows below and the fused sweeps
/// (chain_stages.cpp, tree_stages.cpp) all call these, so a change to the link's C, J or Jdot v
/// is made here only. Raw pointers to a particle's 3 coordinates, as the sweeps hold them.
struct LinkDelta
{
  double x, y, z;  ///< d = p_i - p_j [m]: J's block on i (and -d on j)
  double squared;  ///< |d|^2 [m^2], summed (x x + y y) + z z as Eigen's squaredNorm sums it
};
inline LinkDelta linkDelta(const double* pi, const double* pj)
{
  const double dx = pi[0] - pj[0], dy = pi[1] - pj[1], dz = pi[2] - pj[2];
  return { dx, dy, dz, dx * dx + dy * dy + dz * dz };
}
/// C = (|d|^2 - l^2) / 2 [m^2] from |d|^2 [m^2] and l [m].
inline double linkValue(double squared, double length)
{
  return 0.5 * (squared - length * length);
}
/// Jdot v = |v_i - v_j|^2 [m^2/s^2].
inline double linkJdotV(const double* vi, const double* vj)
{
  const double ux = vi[0] - vj[0], uy = vi[1] - vj[1], uz = vi[2] - vj[2];
  return ux * ux + uy * uy + uz * uz;
}
/// The violation ||d| - l| [m].
inline double linkViolation(double squared, double length)
{
  return std::abs(std::sqrt(squared) - length);
}
/// The link's diagonal entry of J W J^T, w_i |d|^2 + w_j |-d|^2 [m^2/kg] (|-d|^2 is |d|^2 exactly).
inline double linkDiagonal(double w_first, double w_second, double squared)
{
  return w_first * squared + w_second * squared;
}

/// C, J, Jdot v and |(|p_i - p_j| - l)| [m] at positions p [m], velocities v [m/s]. Stateless.
inline void evaluateRows(const LinkConstraint& constraint, const EffectContext& /*context*/,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  const int i = constraint.first, j = constraint.second;
  const LinkDelta d = linkDelta(positions.data() + 3 * i, positions.data() + 3 * j);
  out.jacobian[0] = Vec3(d.x, d.y, d.z);
  out.jacobian[1] = Vec3(-d.x, -d.y, -d.z);
  out.value[0] = linkValue(d.squared, constraint.length);
  out.jdot_v[0] = linkJdotV(velocities.data() + 3 * i, velocities.data() + 3 * j);
  out.violation[0] = linkViolation(d.squared, constraint.length);
}

/// Geometric stiffness (stability.hpp): lambda times the Hessian of C, [[I, -I], [-I, I]], has
/// row sums 2 |lambda| at i and at j [N/m] (|lambda| = T / l, T the tension).
inline void addGeometricStiffness(const LinkConstraint& constraint,
                                  const EffectContext& /*context*/, const Points& /*positions*/,
                                  const double* multipliers, double* stiffness)
{
  stiffness[constraint.first] += 2.0 * std::abs(multipliers[0]);
  stiffness[constraint.second] += 2.0 * std::abs(multipliers[0]);
}

/// Rate of change of the distance |d.dv|/|d| [m/s] (the relative speed if the particles
/// coincide, which have no defined direction).
inline void violationRates(const LinkConstraint& constraint, const EffectContext& /*context*/,
                           const Points& positions, const Points& velocities, double* rates)
{
  const Vec3 d = positions.col(constraint.first) - positions.col(constraint.second);
  const Vec3 relative = velocities.col(constraint.first) - velocities.col(constraint.second);
  const double distance = d.norm();
  rates[0] = distance > 0.0 ? std::abs(d.dot(relative)) / distance : relative.norm();
}

/// @throws InvalidInput naming the bad field
inline void validate(const LinkConstraint& constraint, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(constraint, num_particles, num_surfaces, prefix, allow_unset);
  requireDistinctParticles(constraint.first, constraint.second, prefix);
}

}  // namespace constrained_particles
