#include "constrained_particles/core/statistics.hpp"

#include <algorithm>
#include <ctime>

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
  reused_factorizations += other.reused_factorizations;
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
  substeps += later.substeps;
  max_substeps = std::max(max_substeps, later.max_substeps);
  rejected_steps += later.rejected_steps;
  stiff_steps += later.stiff_steps;
  unconverged_friction += later.unconverged_friction;
  for (int k = 0; k < NUM_STEP_CHECKS; ++k)
    rejections[k] += later.rejections[k];
  if (failed_check == StepCheck::None && later.failed_check != StepCheck::None)
  {
    failed_check = later.failed_check;
    hold = later.hold;
    hold_force = later.hold_force;
    hold_failure = later.hold_failure;
  }
  max_frequency = std::max(max_frequency, later.max_frequency);
  effects.add(later.effects);
  if (later.steps > 0)  // the later batch's end is the merged one's
    end_position_error = later.end_position_error;
}

const char* stepCheckName(StepCheck check)
{
  static const char* const NAMES[NUM_STEP_CHECKS] = { "none",           "non_finite",
                                                      "projection",     "energy_rise",
                                                      "singular_solve", "adaptive_guard",
                                                      "energy_budget",  "hold_force" };
  const int index = static_cast<int>(check);
  return index >= 0 && index < NUM_STEP_CHECKS ? NAMES[index] : "(invalid)";
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

double threadCpuSeconds()
{
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace constrained_particles
