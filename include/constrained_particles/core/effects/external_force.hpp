/// @file external_force.hpp
/// @brief A constant force on one particle.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"

#include <vector>

namespace constrained_particles
{
/// Constant force on one particle: f_i = F. Potential -F.p_i.
struct ExternalForce
{
  int particle = 0;             ///< particle index
  Vec3 force{ 0.0, 0.0, 0.0 };  ///< F [N]

  static constexpr const char* KIND = "external";
  static constexpr bool CONSERVATIVE = false;  ///< not counted in the potential energy
  static constexpr bool DISSIPATIVE = false;   ///< the energy ledger books its power as work in
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &ExternalForce::particle, FieldKind::Particle, nullptr,
              "particle pushed"),
        field("force", &ExternalForce::force, FieldKind::Vector, &limits::FORCE, "F, constant"));
  }
};

/// Adds F to particle i [N]. Stateless.
inline void accumulateForce(const ExternalForce& force, const std::vector<double>& /*masses*/,
                            const Points& /*positions*/, const Points& /*velocities*/,
                            Points& forces)
{
  forces.col(force.particle) += force.force;
}

/// The power it delivers, F . v_i [W] (the energy ledger's work in).
inline double power(const ExternalForce& force, const std::vector<double>& /*masses*/,
                    const Points& /*positions*/, const Points& velocities)
{
  return force.force.dot(velocities.col(force.particle));
}

/// Not counted in the energy diagnostics (it is work done on the system from outside): 0 [J].
inline double potentialEnergy(const ExternalForce&, const std::vector<double>&, const Points&)
{
  return 0.0;
}

/// @throws InvalidInput naming the bad field
inline void validate(const ExternalForce& force, int num_particles, const std::string& prefix)
{
  validateFields(force, num_particles, 0, prefix);
}

}  // namespace constrained_particles
