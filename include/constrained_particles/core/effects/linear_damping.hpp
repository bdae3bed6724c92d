/// @file linear_damping.hpp
/// @brief Viscous damping, an applied force.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"

#include <vector>

namespace constrained_particles
{
/// Linear (viscous) damping on every particle: f_i = -c v_i. Not conservative.
struct LinearDampingForce
{
  double coefficient = 0.0;  ///< c [N s/m], >= 0

  static constexpr const char* KIND = "linear_damping";
  static constexpr bool CONSERVATIVE = false;  ///< not counted in the potential energy
  static constexpr bool DISSIPATIVE = true;    ///< the energy ledger books its power as dissipated
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr auto fields()
  {
    return std::make_tuple(field("coefficient", &LinearDampingForce::coefficient, FieldKind::Number,
                                 &limits::DAMPING, "c in f = -c v"));
  }
};

/// Adds f_i = -c v_i [N]. Stateless.
inline void accumulateForce(const LinearDampingForce& force, const std::vector<double>& /*masses*/,
                            const Points& /*positions*/, const Points& velocities, Points& forces)
{
  forces -= force.coefficient * velocities;
}

/// The power it delivers, -c sum |v_i|^2 [W] (<= 0: the energy ledger's dissipation).
inline double power(const LinearDampingForce& force, const std::vector<double>& /*masses*/,
                    const Points& /*positions*/, const Points& velocities)
{
  return -force.coefficient * velocities.squaredNorm();
}

/// Not conservative: 0 [J].
inline double potentialEnergy(const LinearDampingForce&, const std::vector<double>&, const Points&)
{
  return 0.0;
}

/// @throws InvalidInput naming the bad field
inline void validate(const LinearDampingForce& force, int num_particles, const std::string& prefix)
{
  validateFields(force, num_particles, 0, prefix);
}

}  // namespace constrained_particles
