#include "constrained_particles/core/statistics.hpp"

#include <algorithm>

namespace constrained_particles
{
EffectCounters EffectCounters::since(const EffectCounters& earlier) const
{
  EffectCounters delta;
  for (std::size_t k = 0; k < forces.size(); ++k)
    delta.forces[k] = forces[k] - earlier.forces[k];
  for (std::size_t k = 0; k < constraints.size(); ++k)
    delta.constraints[k] = constraints[k] - earlier.constraints[k];
  for (std::size_t k = 0; k < factorizations.size(); ++k)
    delta.factorizations[k] = factorizations[k] - earlier.factorizations[k];
  return delta;
}

void ProjectionStatistics::merge(const ProjectionReport& report)
{
  ++projections;
  iterations += report.iterations;
  max_iterations = std::max(max_iterations, report.iterations);
  converged = converged && report.converged;
  max_position_error = worseError(max_position_error, report.max_position_error);
  max_velocity_change = std::max(max_velocity_change, report.max_velocity_change);
  singular = singular || report.singular;
}

}  // namespace constrained_particles
