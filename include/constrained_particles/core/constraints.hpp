/// @file constraints.hpp
/// @brief Holonomic constraints C(p) = 0: small records and stateless evaluation functions.
///
/// Each scalar constraint becomes one row of the Jacobian J = dC/dp, touching at most two
/// particles. Pins are not rows: a pinned particle gets inverse mass 0 (physics.md), which keeps
/// chains tridiagonal; its reaction is computed after the solve.
#pragma once

#include "constrained_particles/core/surface.hpp"
#include "constrained_particles/core/types.hpp"

#include <array>
#include <variant>

namespace constrained_particles
{
/// Particle i on the height field z = Z(x, y):  C = Z(x_i, y_i) - z_i  [m].
/// J = (Z_x, Z_y, -1) at i;  Jdot v = Z_xx vx^2 + 2 Z_xy vx vy + Z_yy vy^2.
struct SurfaceConstraint
{
  int particle = 0;  ///< particle index
  int surface = 0;   ///< index into Scene::surfaces
};

/// Link of fixed length between particles i and j:  C = (|p_i - p_j|^2 - l^2) / 2  [m^2]
/// (seed problem 3's halved form; the force J^T lambda does not depend on the scaling).
/// J = (p_i - p_j) at i, (p_j - p_i) at j;  Jdot v = |v_i - v_j|^2.
struct LinkConstraint
{
  int first = 0;      ///< particle i
  int second = 1;     ///< particle j, != i
  double length = 1;  ///< l [m], > 0
};

/// Particle i held at a fixed point:  C = p_i - a  [m] (3 rows), J = identity, Jdot v = 0.
/// Solved by elimination (inverse mass 0), not as rows.
struct PinConstraint
{
  int particle = 0;              ///< particle index
  Vec3 anchor{ 0.0, 0.0, 0.0 };  ///< a [m]
};

/// One constraint of a scene.
using Constraint = std::variant<SurfaceConstraint, LinkConstraint, PinConstraint>;

/// One scalar row of C, J and Jdot v, evaluated at a state.
struct ConstraintRow
{
  std::array<int, 2> particle{ { -1, -1 } };  ///< particles touched; -1 = unused slot
  /// dC/dp of the first particle. Every two-particle constraint here depends on p_i - p_j, so
  /// the second particle's block is -gradient: storing one block halves the row's traffic.
  Vec3 gradient = Vec3::Zero();
  double value = 0;   ///< C
  double jdot_v = 0;  ///< Jdot v
  double metric_error = 0;

  /// dC/dp of the particle in `slot` (0 or 1).
  Vec3 gradientOf(int slot) const
  {
    return slot == 0 ? gradient : Vec3(-gradient);
  }  ///< position error [m] (|Z - z|, ||d| - l|)
};

/// Evaluates a surface constraint's row at positions p and velocities v into `row`. Stateless.
void evaluateRow(const SurfaceConstraint& constraint, const Surface& surface,
                 const Points& positions, const Points& velocities, ConstraintRow& row);

/// Evaluates a link constraint's row at positions p and velocities v into `row`. Stateless.
void evaluateRow(const LinkConstraint& constraint, const Points& positions,
                 const Points& velocities, ConstraintRow& row);

/// |dC/dt| of an evaluated row in metric units [m/s]: |Cdot| for a surface, the rate of change
/// of the distance |d.dv|/|d| for a link (the relative speed if the particles coincide).
double metricRate(const SurfaceConstraint& constraint, const ConstraintRow& row,
                  const Points& velocities);
/// @copydoc metricRate(const SurfaceConstraint&, const ConstraintRow&, const Points&)
double metricRate(const LinkConstraint& constraint, const ConstraintRow& row,
                  const Points& velocities);

/// The row of any row-producing constraint, returned by value (tests, one-off uses).
template <typename RowConstraint, typename... Context>
ConstraintRow evaluateRow(const RowConstraint& constraint, const Context&... context)
{
  ConstraintRow row;
  evaluateRow(constraint, context..., row);
  return row;
}

/// Value of the scalar constraint C alone (no derivatives), for finite-difference checks.
double constraintValue(const SurfaceConstraint& constraint, const Surface& surface,
                       const Points& positions);
/// @copydoc constraintValue(const SurfaceConstraint&, const Surface&, const Points&)
double constraintValue(const LinkConstraint& constraint, const Points& positions);

}  // namespace constrained_particles
