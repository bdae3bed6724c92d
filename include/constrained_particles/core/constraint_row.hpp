/// @file constraint_row.hpp
/// @brief One scalar row of C, J and Jdot v, as every row-producing constraint fills it.
#pragma once

#include "constrained_particles/core/surface.hpp"
#include "constrained_particles/core/types.hpp"

#include <array>
#include <vector>

namespace constrained_particles
{
/// One scalar row of C, J and Jdot v, evaluated at a state.
struct ConstraintRow
{
  std::array<int, 2> particle{ { -1, -1 } };  ///< particles touched; -1 = unused slot
  /// dC/dp of the first particle. Every two-particle constraint here depends on p_i - p_j, so
  /// the second particle's block is -gradient: storing one block halves the row's traffic.
  Vec3 gradient = Vec3::Zero();
  double value = 0;         ///< C
  double jdot_v = 0;        ///< Jdot v
  double metric_error = 0;  ///< position error [m] (|Z - z|, ||d| - l|)

  /// dC/dp of the particle in `slot` (0 or 1).
  Vec3 gradientOf(int slot) const
  {
    return slot == 0 ? gradient : Vec3(-gradient);
  }
};

/// What row evaluation may read besides the state: the scene's surfaces.
using Surfaces = std::vector<Surface>;

}  // namespace constrained_particles
