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

void EffectCounters::add(const EffectCounters& other)
{
  for (std::size_t k = 0; k < forces.size(); ++k)
    forces[k] += other.forces[k];
  for (std::size_t k = 0; k < constraints.size(); ++k)
    constraints[k] += other.constraints[k];
  for (std::size_t k = 0; k < factorizations.size(); ++k)
    factorizations[k] += other.factorizations[k];
}

void SolveStatistics::merge(const SolveStatistics& other)
{
  if (other.method != SolveMethod::None)
    method = other.method;
  factorizations += other.factorizations;
  singular_count += other.singular_count;
  fallbacks += other.fallbacks;
  singular = singular || other.singular;
  min_pivot_ratio = std::min(min_pivot_ratio, other.min_pivot_ratio);
  regularization = std::max(regularization, other.regularization);
}

void ProjectionStatistics::merge(const ProjectionStatistics& other)
{
  projections += other.projections;
  iterations += other.iterations;
  max_iterations = std::max(max_iterations, other.max_iterations);
  converged = converged && other.converged;
  max_position_error = worseError(max_position_error, other.max_position_error);
  max_velocity_change = std::max(max_velocity_change, other.max_velocity_change);
  singular = singular || other.singular;
}

void StepStatistics::merge(const StepStatistics& later)
{
  steps += later.steps;
  solve.merge(later.solve);
  projection.merge(later.projection);
  internal_steps += later.internal_steps;
  rejected_internal_steps += later.rejected_internal_steps;
  forced_internal_steps += later.forced_internal_steps;
  effects.add(later.effects);
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
