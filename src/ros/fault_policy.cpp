/// @file fault_policy.cpp
/// @brief faultOf and the fault's and fallback's wording.
#include "constrained_particles/ros/fault_policy.hpp"

#include "constrained_particles/core/integrators.hpp"

namespace constrained_particles
{
namespace
{
// The checks of the state itself (finite, within ~max_constraint_error): why not, or ''
std::string stateFault(const Simulator& simulator, const NodeParameters& parameters,
                       const State& state, const StepStatistics& chunk, const State& last_good)
{
  if (!isFinite(state))
    return "the state became non-finite between t = " + formatValue(last_good.time) +
           " s and t = " + formatValue(state.time) + " s";
  // the step's own measure where its projection took one: no rows evaluated again per chunk
  const double error = chunk.end_position_error >= 0.0 ? chunk.end_position_error
                                                       : simulator.diagnostics().max_position_error;
  if (!(error <= parameters.max_constraint_error))
    return "the constraint error reached " + formatValue(error) +
           " m at t = " + formatValue(state.time) +
           " s, over ~max_constraint_error = " + formatValue(parameters.max_constraint_error) +
           " m";
  return "";
}

// The failed step check's wording ('' for none)
std::string checkFault(const Simulator& simulator, const NodeParameters& parameters,
                       const State& state, const StepStatistics& chunk)
{
  const StepSettings& step = parameters.step;
  const std::string split =
      step.max_substeps > 1
          ? " even in ~max_substeps = " + std::to_string(step.max_substeps) + " sub-steps"
          : " (~max_substeps = 1: no sub-steps)";
  const std::string when = " at t = " + formatValue(state.time) + " s";
  switch (chunk.failed_check)
  {
    case StepCheck::AdaptiveGuard:
      return "dopri5 could not meet ~adaptive_tolerance = " + formatValue(step.adaptive_tolerance) +
             " within " + formatValue(step.dt) + " s" + when + " (over " +
             std::to_string(DOPRI5_MAX_INTERNAL_STEPS) + " internal steps, or one under " +
             formatValue(DOPRI5_MIN_INTERNAL_STEP) + " dt): loosen the tolerance or shorten ~dt" +
             (step.max_substeps > 1 ? std::string()
                                    : ", or raise ~max_substeps above 1 (the stiff fallback "
                                      "then takes such steps)");
    case StepCheck::NonFinite:
      return "step check non_finite failed" + split + when +
             ": the state became non-finite; shorten ~dt, raise ~max_substeps or use "
             "~integrator fast_projection";
    case StepCheck::Projection:
      return "step check projection failed" + split + when + ": a projection did not reach " +
             "~projection_tolerance = " + formatValue(step.projection_tolerance) + " m in " +
             "~projection_max_iterations = " + std::to_string(step.projection_max_iterations);
    case StepCheck::EnergyRise:
      return "step check energy_rise failed" + split + when +
             ": the total energy of this conservative scene rose by more than " +
             formatValue(Simulator::ENERGY_RISE_TOLERANCE) + " of its scale in one sub-step; " +
             "shorten ~dt, raise ~max_substeps or change ~integrator";
    case StepCheck::EnergyBudget:
    {
      const EnergyLedger& ledger = simulator.energyLedger();
      const StepControl& control = simulator.data().control;
      const double scale = control.budget_failure_scale;
      // each method is judged by its own gain, from when it took the run
      std::string since = formatValue(control.budget_base_time) + " s";
      if (control.budget_fallback)
        since += std::string(", when ") + Simulator::STIFF_FALLBACK + " took the run over";
      else if (control.budget_base_time > ledger.t0)
        since += ", when these step settings took the run";
      return "step check energy_budget failed" + when + ": energy budget exceeded, residual " +
             formatValue(control.budget_failure_residual) + " J > " +
             formatValue(step.energy_budget * scale) + " J (~energy_budget " +
             formatValue(step.energy_budget) + " of scale " + formatValue(scale) +
             " J, since t = " + since + "): the run gained energy" +
             (step.max_substeps > 1 ? std::string(" even in steps of ") +
                                          Simulator::STIFF_FALLBACK + ", the stiff-safe method"
                                    : std::string(" (~max_substeps = 1: no fallback to ") +
                                          Simulator::STIFF_FALLBACK + ")") +
             "; use rk4 or velocity_verlet, shorten ~dt, or set ~energy_budget 0 to run "
             "unchecked";
    }
    default:
      return "";
  }
}
}  // namespace

std::string faultOf(const Simulator& simulator, const NodeParameters& parameters,
                    const State& state, const StepStatistics& chunk, const State& last_good)
{
  // the wording only where a check failed: this runs after every chunk
  std::string reason = checkFault(simulator, parameters, state, chunk);
  if (reason.empty())
    reason = stateFault(simulator, parameters, state, chunk, last_good);
  // the fault ends the fallback (the state is restored, the ledger opened again): say it was on
  if (const StepControl& control = simulator.data().control;
      !reason.empty() && control.budget_fallback)
    reason += "; the run had been taken by " + std::string(Simulator::STIFF_FALLBACK) +
              " since t = " + formatValue(control.budget_fallback_time) + " s, after " +
              control.budget_handed_by + " overdrew ~energy_budget";
  return reason;
}

std::string energyFallbackText(const Simulator& simulator, const NodeParameters& parameters)
{
  const StepControl& control = simulator.data().control;
  if (!control.budget_fallback)
    return "";
  return "energy budget overdrawn at t = " + formatValue(control.budget_fallback_time) + " s by " +
         control.budget_handed_by + " (residual " + formatValue(control.budget_failure_residual) +
         " J > " + formatValue(parameters.step.energy_budget * control.budget_failure_scale) +
         " J, ~energy_budget " + formatValue(parameters.step.energy_budget) + " of " +
         formatValue(control.budget_failure_scale) + " J): " + Simulator::STIFF_FALLBACK +
         " takes the steps until a reset, ~set_state or a settings change; use rk4 or "
         "velocity_verlet, or shorten ~dt";
}

std::string faultMessage(const std::string& reason, std::size_t applied, std::size_t dragged,
                         std::size_t commanded, double good_time)
{
  // a push the scene cannot follow faults it as an unstable method would: say that one acted
  const std::string pushed =
      applied + dragged + commanded == 0
          ? std::string()
          : "; forces from outside acted (" + std::to_string(applied) + " ~apply_force, " +
                std::to_string(dragged) + " drags, " + std::to_string(commanded) +
                " ~wrench_command): one too large for the scene faults it as a method would";
  return reason + pushed +
         "; stepping stopped at the last good state (t = " + formatValue(good_time) +
         " s); call ~reset";
}

}  // namespace constrained_particles
