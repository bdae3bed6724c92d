#include "constrained_particles/core/forces.hpp"

#include <string>

namespace constrained_particles
{
void accumulateForce(const GravityForce& force, const std::vector<double>& masses,
                     const Points& /*velocities*/, Points& forces)
{
  for (int i = 0; i < forces.cols(); ++i)
    forces.col(i) += masses[i] * force.acceleration;
}

void accumulateForce(const LinearDampingForce& force, const std::vector<double>& /*masses*/,
                     const Points& velocities, Points& forces)
{
  forces -= force.coefficient * velocities;
}

void accumulateForce(const ExternalForce& force, const std::vector<double>& /*masses*/,
                     const Points& /*velocities*/, Points& forces)
{
  forces.col(force.particle) += force.force;
}

double potentialEnergy(const Force& force, const std::vector<double>& masses,
                       const Points& positions)
{
  const auto* gravity = std::get_if<GravityForce>(&force);
  if (!gravity)
    return 0.0;
  double energy = 0.0;
  for (int i = 0; i < positions.cols(); ++i)
    energy -= masses[i] * gravity->acceleration.dot(positions.col(i));
  return energy;
}

void validateForce(const Force& force, int num_particles, const std::string& field)
{
  if (const auto* gravity = std::get_if<GravityForce>(&force))
  {
    requireFinite(field + ".gravity", gravity->acceleration, "[m/s^2]");
  }
  else if (const auto* damping = std::get_if<LinearDampingForce>(&force))
  {
    requireNonNegative(field + ".damping", damping->coefficient, "[N s/m]");
  }
  else if (const auto* external = std::get_if<ExternalForce>(&force))
  {
    if (external->particle < 0 || external->particle >= num_particles)
    {
      throw InvalidInput(field + ".particle", "= " + std::to_string(external->particle) +
                                                  ", must be in [0, " +
                                                  std::to_string(num_particles - 1) + "]");
    }
    requireFinite(field + ".force", external->force, "[N]");
  }
}

}  // namespace constrained_particles
