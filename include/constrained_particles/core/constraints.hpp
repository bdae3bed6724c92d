/// @file constraints.hpp
/// @brief The registry of constraint kinds, and dispatch over them.
///
/// Each kind lives in its own file under effects/. A row kind (ELIMINATED = false) gives one
/// scalar row of the Jacobian J = dC/dp touching at most two particles, through rowParticles,
/// evaluateRow, constraintValue, metricRate and validate. Pins are eliminated instead: a pinned
/// particle gets inverse mass 0 (physics.md), which keeps chains tridiagonal. Adding a row kind
/// means writing its file and adding the record to `Constraint` below.
#pragma once

#include "constrained_particles/core/effects/link_constraint.hpp"
#include "constrained_particles/core/effects/pin_constraint.hpp"
#include "constrained_particles/core/effects/surface_constraint.hpp"

#include <variant>

namespace constrained_particles
{
/// One constraint of a scene: the registry of constraint kinds.
using Constraint = std::variant<SurfaceConstraint, LinkConstraint, PinConstraint>;

/// Number of constraint kinds.
constexpr int NUM_CONSTRAINT_KINDS = static_cast<int>(std::variant_size_v<Constraint>);

/// True for kinds solved by elimination (pins), false for row kinds.
inline bool isEliminated(const Constraint& constraint)
{
  return std::visit([](const auto& c) { return std::decay_t<decltype(c)>::ELIMINATED; },
                    constraint);
}

/// Particles a row constraint touches (-1 = unused slot; both -1 for eliminated kinds).
inline std::array<int, 2> rowParticles(const Constraint& constraint)
{
  return std::visit(
      [](const auto& c) -> std::array<int, 2>
      {
        if constexpr (std::decay_t<decltype(c)>::ELIMINATED)
          return { { -1, -1 } };
        else
          return rowParticles(c);
      },
      constraint);
}

/// Evaluates a row constraint at (p, v) into `row`. Stateless. Eliminated kinds leave it as is.
inline void evaluateRow(const Constraint& constraint, const Surfaces& surfaces,
                        const Points& positions, const Points& velocities, ConstraintRow& row)
{
  std::visit(
      [&](const auto& c)
      {
        if constexpr (!std::decay_t<decltype(c)>::ELIMINATED)
          evaluateRow(c, surfaces, positions, velocities, row);
      },
      constraint);
}

/// |dC/dt| of an evaluated row in metric units [m/s]; 0 for eliminated kinds.
inline double metricRate(const Constraint& constraint, const ConstraintRow& row,
                         const Points& velocities)
{
  return std::visit(
      [&](const auto& c)
      {
        if constexpr (std::decay_t<decltype(c)>::ELIMINATED)
          return 0.0;
        else
          return metricRate(c, row, velocities);
      },
      constraint);
}

/// Throws InvalidInput if the record is malformed for the scene's particles and surfaces.
/// @param field name of the record in messages, e.g. "constraints[2]"
inline void validateConstraint(const Constraint& constraint, int num_particles, int num_surfaces,
                               const std::string& field)
{
  std::visit([&](const auto& c) { validate(c, num_particles, num_surfaces, field); }, constraint);
}

/// The row of one row constraint, returned by value (tests, one-off uses).
template <typename RowConstraint>
ConstraintRow evaluateRow(const RowConstraint& constraint, const Surfaces& surfaces,
                          const Points& positions, const Points& velocities)
{
  ConstraintRow row;
  evaluateRow(constraint, surfaces, positions, velocities, row);
  return row;
}

}  // namespace constrained_particles
