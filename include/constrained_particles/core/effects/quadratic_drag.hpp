/// @file quadratic_drag.hpp
/// @brief Air drag, quadratic in speed.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"

#include <cmath>
#include <vector>

namespace constrained_particles
{
/// Quadratic (air) drag on every particle: f_i = -c |v_i| v_i. Not conservative.
struct QuadraticDragForce
{
  double coefficient = 0.0;  ///< c [N s^2/m^2] = [kg/m], >= 0

  static constexpr const char* KIND = "quadratic_drag";
  static constexpr bool CONSERVATIVE = false;  ///< not counted in the potential energy
  static constexpr bool DISSIPATIVE = true;    ///< the energy ledger books its power as dissipated
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr auto fields()
  {
    return std::make_tuple(field("coefficient", &QuadraticDragForce::coefficient, FieldKind::Number,
                                 &limits::DRAG, "c in f = -c |v| v"));
  }
};

/// Adds f_i = -c |v_i| v_i [N]. Stateless.
inline void accumulateForce(const QuadraticDragForce& force, const std::vector<double>& /*masses*/,
                            const Points& /*positions*/, const Points& velocities, Points& forces)
{
  for (int i = 0; i < forces.cols(); ++i)
    forces.col(i) -= force.coefficient * velocities.col(i).norm() * velocities.col(i);
}

/// The power it delivers, -c sum |v_i|^3 [W] (<= 0: the energy ledger's dissipation).
inline double power(const QuadraticDragForce& force, const std::vector<double>& /*masses*/,
                    const Points& /*positions*/, const Points& velocities)
{
  double sum = 0.0;
  for (int i = 0; i < velocities.cols(); ++i)
    sum += std::pow(velocities.col(i).norm(), 3);
  return -force.coefficient * sum;
}

/// Not conservative: 0 [J].
inline double potentialEnergy(const QuadraticDragForce&, const std::vector<double>&, const Points&)
{
  return 0.0;
}

/// @throws InvalidInput naming the bad field
inline void validate(const QuadraticDragForce& force, int num_particles, const std::string& prefix)
{
  validateFields(force, num_particles, 0, prefix);
}

}  // namespace constrained_particles
