/// @file pin_constraint.hpp
/// @brief A particle held at a fixed point, solved by elimination rather than as rows.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"

namespace constrained_particles
{
/// Particle i held at a fixed point:  C = p_i - a  [m] (3 rows), J = identity, Jdot v = 0.
/// Eliminated: the particle gets inverse mass 0 (physics.md), which keeps chains tridiagonal;
/// its reaction is computed after the solve.
struct PinConstraint
{
  int particle = 0;              ///< particle index
  Vec3 anchor{ 0.0, 0.0, 0.0 };  ///< a [m]

  static constexpr const char* KIND = "pin";
  static constexpr bool ELIMINATED = true;  ///< no rows: inverse mass 0
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &PinConstraint::particle, FieldKind::Particle, "", "particle i"),
        field("anchor", &PinConstraint::anchor, FieldKind::Vector, "m", "a, where it is held"));
  }
};

/// @throws InvalidInput naming the bad field
inline void validate(const PinConstraint& pin, int num_particles, int num_surfaces,
                     const std::string& prefix)
{
  validateFields(pin, num_particles, num_surfaces, prefix);
}

}  // namespace constrained_particles
