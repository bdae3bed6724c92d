/// @file pin_constraint.hpp
/// @brief A particle held at a fixed point, solved by elimination rather than as rows.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <vector>

namespace constrained_particles
{
/// Particle i held at a fixed point:  C = p_i - a  [m] (3 rows), J = identity, Jdot v = 0.
/// Eliminated: the particle gets inverse mass 0 (physics.md), which keeps chains tridiagonal;
/// its reaction is computed after the solve.
struct PinConstraint
{
  int particle = 0;              ///< particle index
  Vec3 anchor{ NAN, NAN, NAN };  ///< a [m]; unset in a scene file: where the particle starts

  static constexpr const char* KIND = "pin";
  static constexpr bool ELIMINATED = true;           ///< no rows: inverse mass 0
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &PinConstraint::particle, FieldKind::Particle, nullptr, "particle i"),
        field("anchor", &PinConstraint::anchor, FieldKind::Vector, &limits::COORDINATE,
              "a, where it is held (default: where it starts)", true));
  }
};

/// The particle it holds.
inline int eliminatedParticle(const PinConstraint& pin)
{
  return pin.particle;
}

/// At a, at rest, at every time.
inline ImposedMotion imposedMotion(const PinConstraint& pin, double /*time*/)
{
  return { pin.anchor, Vec3::Zero(), Vec3::Zero() };
}

/// An unset anchor is where the particle starts.
inline void fillFromStart(PinConstraint& pin, const std::vector<Surface>& /*surfaces*/,
                          Points& positions, Points& /*velocities*/)
{
  if (isUnset(pin.anchor))
    pin.anchor = positions.col(pin.particle);
}

/// @throws InvalidInput naming the bad field
inline void validate(const PinConstraint& pin, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(pin, num_particles, num_surfaces, prefix, allow_unset);
}

}  // namespace constrained_particles
