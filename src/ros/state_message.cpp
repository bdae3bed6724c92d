#include "constrained_particles/ros/state_message.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace constrained_particles
{
namespace
{
// A figure ~state and /diagnostics both carry: its SimState field, its /diagnostics key (with
// the unit) and where it comes from. Adding a figure is one row here and one in SimState.msg.
template <typename Source>
struct RealField
{
  double SimState::*member;
  const char* key;
  double (*value)(const Source&);
};
struct CountField
{
  std::uint32_t SimState::*member;
  const char* key;
  long (*value)(const StepStatistics&);
};

const RealField<Snapshot> SNAPSHOT_FIELDS[] = {
  { &SimState::sim_time, "sim_time [s]", [](const Snapshot& s) { return s.state.time; } },
  { &SimState::max_position_error, "max_position_error [m]",
    [](const Snapshot& s) { return s.diagnostics.max_position_error; } },
  { &SimState::max_velocity_error, "max_velocity_error [m/s]",
    [](const Snapshot& s) { return s.diagnostics.max_velocity_error; } },
  { &SimState::kinetic_energy, "kinetic_energy [J]",
    [](const Snapshot& s) { return s.diagnostics.kinetic_energy; } },
  { &SimState::potential_energy, "potential_energy [J]",
    [](const Snapshot& s) { return s.diagnostics.potential_energy; } },
  { &SimState::total_energy, "total_energy [J]",
    [](const Snapshot& s) { return s.diagnostics.totalEnergy(); } },
  { &SimState::energy_t0, "energy ledger since t [s]",
    [](const Snapshot& s) { return s.ledger.t0; } },
  { &SimState::energy_scale, "energy scale [J]", [](const Snapshot& s) { return s.ledger.scale; } },
  { &SimState::energy_work_in, "energy work in [J]",
    [](const Snapshot& s) { return s.ledger.work_in; } },
  { &SimState::energy_dissipated, "energy dissipated [J]",
    [](const Snapshot& s) { return s.ledger.dissipated; } },
  { &SimState::energy_residual, "energy residual [J]",
    [](const Snapshot& s) { return s.ledger.residual(); } },
  { &SimState::step_time, "step_time [s]", [](const Snapshot& s) { return s.step_time; } },
  { &SimState::real_time_factor, "real_time_factor achieved",
    [](const Snapshot& s) { return s.real_time_factor; } },
};

const CountField COUNT_FIELDS[] = {
  { &SimState::interval_steps, "steps in the last second",
    [](const StepStatistics& s) -> long { return s.steps; } },
  { &SimState::factorizations, "factorizations",
    [](const StepStatistics& s) -> long { return s.solve.factorizations; } },
  { &SimState::reused_factorizations, "reused factorizations",
    [](const StepStatistics& s) -> long { return s.solve.reused_factorizations; } },
  { &SimState::singular_solves, "singular solves",
    [](const StepStatistics& s) -> long { return s.solve.singular_count; } },
  { &SimState::solve_fallbacks, "solve fallbacks",
    [](const StepStatistics& s) -> long { return s.solve.fallbacks; } },
  { &SimState::projections, "projections",
    [](const StepStatistics& s) -> long { return s.projection.projections; } },
  { &SimState::projection_iterations, "projection iterations",
    [](const StepStatistics& s) -> long { return s.projection.iterations; } },
  { &SimState::max_projection_iterations, "most projection iterations",
    [](const StepStatistics& s) -> long { return s.projection.max_iterations; } },
  { &SimState::internal_steps, "internal steps",
    [](const StepStatistics& s) -> long { return s.internal_steps; } },
  { &SimState::rejected_internal_steps, "rejected internal steps",
    [](const StepStatistics& s) -> long { return s.rejected_internal_steps; } },
  { &SimState::forced_internal_steps, "forced internal steps",
    [](const StepStatistics& s) -> long { return s.forced_internal_steps; } },
  { &SimState::substeps, "sub-steps", [](const StepStatistics& s) -> long { return s.substeps; } },
  { &SimState::max_substeps_per_step, "most sub-steps per step",
    [](const StepStatistics& s) -> long { return s.max_substeps; } },
  { &SimState::rejected_steps, "steps retaken",
    [](const StepStatistics& s) -> long { return s.rejected_steps; } },
  { &SimState::stiff_steps, "steps taken by fast_projection (stiff fallback)",
    [](const StepStatistics& s) -> long { return s.stiff_steps; } },
  { &SimState::unconverged_friction, "friction fixed points unconverged",
    [](const StepStatistics& s) -> long { return s.unconverged_friction; } },
};

const RealField<StepStatistics> STATISTICS_FIELDS[] = {
  { &SimState::min_pivot_ratio, "min pivot ratio",
    [](const StepStatistics& s) { return s.solve.min_pivot_ratio; } },
  // an estimate overflows only in degenerate geometry: shown as the largest double, not inf
  { &SimState::max_frequency, "max_frequency estimate [rad/s]",
    [](const StepStatistics& s) {
      return std::isfinite(s.max_frequency) ? s.max_frequency : std::numeric_limits<double>::max();
    } },
};

// A count as SimState carries it (uint32: saturated rather than wrapped).
std::uint32_t toCount(long value)
{
  return static_cast<std::uint32_t>(
      std::clamp<long>(value, 0, std::numeric_limits<std::uint32_t>::max()));
}
}  // namespace

void fillSnapshotFields(const Snapshot& snap, SimState& msg)
{
  for (const auto& field : SNAPSHOT_FIELDS)
    msg.*field.member = field.value(snap);
}

void addSnapshotFields(const Snapshot& snap, const AddKeyValue& add)
{
  for (const auto& field : SNAPSHOT_FIELDS)
    add(field.key, formatValue(field.value(snap)));
}

void fillStatistics(const StepStatistics& statistics, SimState& msg)
{
  for (const CountField& field : COUNT_FIELDS)
    msg.*field.member = toCount(field.value(statistics));
  for (const auto& field : STATISTICS_FIELDS)
    msg.*field.member = field.value(statistics);
  msg.projections_converged = statistics.projection.converged;
  for (int k = 0; k < NUM_STEP_CHECKS; ++k)
    if (statistics.rejections[k] > 0)
    {
      msg.rejection_checks.push_back(stepCheckName(static_cast<StepCheck>(k)));
      msg.rejection_counts.push_back(toCount(statistics.rejections[k]));
    }
  forEachEffectCount(statistics.effects,
                     [&msg](const char* name, std::uint64_t count)
                     {
                       msg.effect_names.push_back(name);
                       msg.effect_counts.push_back(count);
                     });
}

void addStatistics(const StepStatistics& statistics, const AddKeyValue& add)
{
  for (const CountField& field : COUNT_FIELDS)
    add(field.key, std::to_string(field.value(statistics)));
  for (const auto& field : STATISTICS_FIELDS)
    add(field.key, formatValue(field.value(statistics)));
  add("projections converged", statistics.projection.converged ? "yes" : "no");
  std::string rejections;
  for (int k = 0; k < NUM_STEP_CHECKS; ++k)
    if (statistics.rejections[k] > 0)
      rejections += (rejections.empty() ? "" : " ") +
                    std::string(stepCheckName(static_cast<StepCheck>(k))) + ":" +
                    std::to_string(statistics.rejections[k]);
  add("steps retaken, by check", rejections.empty() ? "-" : rejections);
  std::string effects;
  forEachEffectCount(statistics.effects,
                     [&effects](const char* name, std::uint64_t count) {
                       effects += (effects.empty() ? "" : " ") + std::string(name) + ":" +
                                  std::to_string(count);
                     });
  add("effect evaluations", effects.empty() ? "-" : effects);
}

std::string statusText(const Snapshot& snap)
{
  if (snap.faulted)
    return snap.fault_reason;
  if (snap.stepping)
    return "paused, running a ~step";
  if (snap.paused)
    return "paused";
  if (snap.behind)
    return "behind: cannot keep up with the real-time factor; sim time slowed";
  return "";
}

}  // namespace constrained_particles
