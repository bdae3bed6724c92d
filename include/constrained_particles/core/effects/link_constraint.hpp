/// @file link_constraint.hpp
/// @brief A rigid link between two particles, one constraint row.
#pragma once

#include "constrained_particles/core/constraint_row.hpp"
#include "constrained_particles/core/effect_fields.hpp"

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
  double length = 1;  ///< l [m], > 0

  static constexpr const char* KIND = "link";
  static constexpr bool ELIMINATED = false;  ///< one row of J
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("first", &LinkConstraint::first, FieldKind::Particle, "", "particle i"),
        field("second", &LinkConstraint::second, FieldKind::Particle, "", "particle j, != i"),
        field("length", &LinkConstraint::length, FieldKind::Positive, "m", "l"));
  }
};

/// Particles the row touches.
inline std::array<int, 2> rowParticles(const LinkConstraint& constraint)
{
  return { { constraint.first, constraint.second } };
}

/// Evaluates C, J and Jdot v at positions p [m] and velocities v [m/s] into `row`. Stateless.
inline void evaluateRow(const LinkConstraint& constraint, const Surfaces& /*surfaces*/,
                        const Points& positions, const Points& velocities, ConstraintRow& row)
{
  const int i = constraint.first, j = constraint.second;
  const double* pi = positions.data() + 3 * i;
  const double* pj = positions.data() + 3 * j;
  const double* vi = velocities.data() + 3 * i;
  const double* vj = velocities.data() + 3 * j;
  const double dx = pi[0] - pj[0], dy = pi[1] - pj[1], dz = pi[2] - pj[2];
  const double ux = vi[0] - vj[0], uy = vi[1] - vj[1], uz = vi[2] - vj[2];
  const double squared = dx * dx + dy * dy + dz * dz;
  row.particle = { { i, j } };
  row.gradient = Vec3(dx, dy, dz);
  row.value = 0.5 * (squared - constraint.length * constraint.length);
  row.jdot_v = ux * ux + uy * uy + uz * uz;
  row.metric_error = std::abs(std::sqrt(squared) - constraint.length);
}

/// C alone [m^2], for finite-difference checks.
inline double constraintValue(const LinkConstraint& constraint, const Surfaces& /*surfaces*/,
                              const Points& positions)
{
  const Vec3 d = positions.col(constraint.first) - positions.col(constraint.second);
  return 0.5 * (d.squaredNorm() - constraint.length * constraint.length);
}

/// Rate of change of the distance |d.dv|/|d| [m/s] (the relative speed if the particles
/// coincide, which have no defined direction).
inline double metricRate(const LinkConstraint& constraint, const ConstraintRow& row,
                         const Points& velocities)
{
  const Vec3 relative = velocities.col(constraint.first) - velocities.col(constraint.second);
  const double distance = row.gradient.norm();
  return distance > 0.0 ? std::abs(row.gradient.dot(relative)) / distance : relative.norm();
}

/// @throws InvalidInput naming the bad field
inline void validate(const LinkConstraint& constraint, int num_particles, int num_surfaces,
                     const std::string& prefix)
{
  validateFields(constraint, num_particles, num_surfaces, prefix);
  requireDistinctParticles(constraint.first, constraint.second, prefix);
}

}  // namespace constrained_particles
