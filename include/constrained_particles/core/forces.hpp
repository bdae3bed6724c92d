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

/// Quadratic (air) drag on every particle: f_i = -c |v_i| v_i.
struct QuadraticDragForce
{
  double coefficient = 0.0;  ///< c [N s^2/m^2] = [kg/m], >= 0
};

/// Spring between particles i and j: f_i = -k (|p_i - p_j| - L) (p_i - p_j) / |p_i - p_j|,
/// f_j = -f_i; potential k (|p_i - p_j| - L)^2 / 2. Coincident particles get no force (no
/// direction); with L > 0 the force flips direction through that point, so motion through it is
/// not smooth (L = 0 gives f = -k (p_i - p_j), smooth everywhere).
struct SpringForce
{
  int first = 0;             ///< particle i
  int second = 1;            ///< particle j, != i
  double stiffness = 1.0;    ///< k [N/m], >= 0
  double rest_length = 0.0;  ///< L [m], >= 0
};

/// One applied force of a scene.
using Force =
    std::variant<GravityForce, LinearDampingForce, ExternalForce, QuadraticDragForce, SpringForce>;

/// Adds the force to the per-particle accumulator. Stateless.
/// @param masses particle masses [kg]
/// @param positions particle positions [m]
/// @param velocities particle velocities [m/s]
/// @param forces accumulator [N], one column per particle
void accumulateForce(const GravityForce& force, const std::vector<double>& masses,
                     const Points& positions, const Points& velocities, Points& forces);
/// @copydoc accumulateForce(const GravityForce&, const std::vector<double>&, const Points&,
/// Points&)
void accumulateForce(const LinearDampingForce& force, const std::vector<double>& masses,
                     const Points& positions, const Points& velocities, Points& forces);
/// @copydoc accumulateForce(const GravityForce&, const std::vector<double>&, const Points&,
/// Points&)
void accumulateForce(const ExternalForce& force, const std::vector<double>& masses,
                     const Points& positions, const Points& velocities, Points& forces);

/// @copydoc accumulateForce(const GravityForce&, const std::vector<double>&, const Points&, const
/// Points&, Points&)
void accumulateForce(const QuadraticDragForce& force, const std::vector<double>& masses,
                     const Points& positions, const Points& velocities, Points& forces);
/// @copydoc accumulateForce(const GravityForce&, const std::vector<double>&, const Points&, const
/// Points&, Points&)
void accumulateForce(const SpringForce& force, const std::vector<double>& masses,
                     const Points& positions, const Points& velocities, Points& forces);

/// Potential energy [J] of a conservative force at the given positions; 0 for the others.
double potentialEnergy(const Force& force, const std::vector<double>& masses,
                       const Points& positions);

/// Throws InvalidInput if the record is malformed for a scene of num_particles particles.
/// @param field name of the record in messages, e.g. "forces[2]"
void validateForce(const Force& force, int num_particles, const std::string& field);

}  // namespace constrained_particles
