#include "constrained_particles/core/forces.hpp"

#include <string>

namespace constrained_particles
{
void accumulateForce(const GravityForce& force, const std::vector<double>& masses,
                     const Points& /*positions*/, const Points& /*velocities*/, Points& forces)
{
  for (int i = 0; i < forces.cols(); ++i)
    forces.col(i) += masses[i] * force.acceleration;
}

void accumulateForce(const LinearDampingForce& force, const std::vector<double>& /*masses*/,
                     const Points& /*positions*/, const Points& velocities, Points& forces)
{
  forces -= force.coefficient * velocities;
}

void accumulateForce(const ExternalForce& force, const std::vector<double>& /*masses*/,
                     const Points& /*positions*/, const Points& /*velocities*/, Points& forces)
{
  forces.col(force.particle) += force.force;
}

void accumulateForce(const QuadraticDragForce& force, const std::vector<double>& /*masses*/,
                     const Points& /*positions*/, const Points& velocities, Points& forces)
{
  for (int i = 0; i < forces.cols(); ++i)
    forces.col(i) -= force.coefficient * velocities.col(i).norm() * velocities.col(i);
}

void accumulateForce(const SpringForce& force, const std::vector<double>& /*masses*/,
                     const Points& positions, const Points& /*velocities*/, Points& forces)
{
  const Vec3 d = positions.col(force.first) - positions.col(force.second);
  const double length = d.norm();
  if (!(length > 0.0))
    return;
  const Vec3 f = (-force.stiffness * (length - force.rest_length) / length) * d;
  forces.col(force.first) += f;
  forces.col(force.second) -= f;
}

double potentialEnergy(const Force& force, const std::vector<double>& masses,
                       const Points& positions)
{
  if (const auto* spring = std::get_if<SpringForce>(&force))
  {
    const double stretch =
        (positions.col(spring->first) - positions.col(spring->second)).norm() - spring->rest_length;
    return 0.5 * spring->stiffness * stretch * stretch;
  }
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
  else if (const auto* drag = std::get_if<QuadraticDragForce>(&force))
  {
    requireNonNegative(field + ".coefficient", drag->coefficient, "[kg/m]");
  }
  else if (const auto* spring = std::get_if<SpringForce>(&force))
  {
    for (const auto& [name, index] : { std::pair<const char*, int>{ ".first", spring->first },
                                       std::pair<const char*, int>{ ".second", spring->second } })
      if (index < 0 || index >= num_particles)
        throw InvalidInput(field + name, "= " + std::to_string(index) + ", must be in [0, " +
                                             std::to_string(num_particles - 1) + "]");
    if (spring->first == spring->second)
      throw InvalidInput(field + ".second",
                         "= " + std::to_string(spring->second) + ", must differ from first");
    requireNonNegative(field + ".stiffness", spring->stiffness, "[N/m]");
    requireNonNegative(field + ".rest_length", spring->rest_length, "[m]");
  }
}

}  // namespace constrained_particles
