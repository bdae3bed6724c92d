/// @file forces.hpp
/// @brief Applied forces: small records and stateless evaluation functions.
#pragma once

#include "constrained_particles/core/types.hpp"

#include <variant>
#include <vector>

namespace constrained_particles
{
/// Uniform gravity: f_i = m_i g. Potential energy -m_i g.p_i.
struct GravityForce
{
  Vec3 acceleration{ 0.0, 0.0, -9.81 };  ///< g [m/s^2]
};

/// Linear (viscous) damping on every particle: f_i = -c v_i.
struct LinearDampingForce
{
  double coefficient = 0.0;  ///< c [N s/m], >= 0
};

/// Constant force on one particle.
struct ExternalForce
{
  int particle = 0;             ///< particle index
  Vec3 force{ 0.0, 0.0, 0.0 };  ///< [N]
};

/// One applied force of a scene.
using Force = std::variant<GravityForce, LinearDampingForce, ExternalForce>;

/// Adds the force to the per-particle accumulator. Stateless.
/// @param masses particle masses [kg]
/// @param velocities particle velocities [m/s]
/// @param forces accumulator [N], one column per particle
void accumulateForce(const GravityForce& force, const std::vector<double>& masses,
                     const Points& velocities, Points& forces);
/// @copydoc accumulateForce(const GravityForce&, const std::vector<double>&, const Points&,
/// Points&)
void accumulateForce(const LinearDampingForce& force, const std::vector<double>& masses,
                     const Points& velocities, Points& forces);
/// @copydoc accumulateForce(const GravityForce&, const std::vector<double>&, const Points&,
/// Points&)
void accumulateForce(const ExternalForce& force, const std::vector<double>& masses,
                     const Points& velocities, Points& forces);

/// Potential energy [J] of a conservative force at the given positions; 0 for the others.
double potentialEnergy(const Force& force, const std::vector<double>& masses,
                       const Points& positions);

/// Throws InvalidInput if the record is malformed for a scene of num_particles particles.
/// @param field name of the record in messages, e.g. "forces[2]"
void validateForce(const Force& force, int num_particles, const std::string& field);

}  // namespace constrained_particles
