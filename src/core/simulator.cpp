#include "constrained_particles/core/simulator.hpp"

#include "contact.hpp"
#include "simulator_support.hpp"
#include "stabilization.hpp"
#include "stages.hpp"

#include "constrained_particles/core/constraints.hpp"
#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/forces.hpp"
#include "constrained_particles/core/stability.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

namespace constrained_particles
{
namespace
{
// Only conservative forces among the scene's.
bool forcesConservative(const Scene& scene)
{
  for (const Force& force : scene.forces)
    if (!std::visit([](const auto& f) { return std::decay_t<decltype(f)>::CONSERVATIVE; }, force))
      return false;
  return true;
}

// Calls `visit` on every force acting: the scene's, then those applied from outside.
template <typename Visit>
void forEachForce(const Model& model, const std::vector<Force>& perturbations, Visit&& visit)
{
  for (const std::vector<Force>* forces : { &model.scene().forces, &perturbations })
    for (const Force& force : *forces)
      visit(force);
}

// Rows or springs (the model's or applied from outside): something the stability estimate sees.
bool hasStiffness(const Model& model, const std::vector<Force>& perturbations)
{
  bool stiff = model.numRows() > 0;
  forEachForce(model, perturbations,
               [&](const Force& force) { stiff |= forceHasStiffness(force); });
  return stiff;
}

// sum |f_i| of the applied forces where it is known without a sweep (gravity alone, kept from
// stage to stage), else null
const double* appliedForceSum(const Data& data)
{
  return data.applied_forces_are_gravity ? &data.gravity_force_sum : nullptr;
}

// The power the driven anchors put in through their reactions [W]: sum_k r_k . v_k, r_k = m a -
// f - (J^T lambda)_k, with the reactions and imposed velocities of the last forward stage
// (addEliminatedReactions); a pin, at rest, puts in none
double drivePower(const Model& model, const Data& data)
{
  double power = 0.0;
  for (std::size_t k = 0; k < data.imposed.size(); ++k)
    power += model.eliminatedReaction(data.multipliers, static_cast<int>(k))
                 .dot(data.imposed[k].velocity);
  return power;
}

// A rejected attempt into `total`: its work is counted (solves, projections, internal steps),
// its outcome is not.
void countRejected(const StepStatistics& attempt, StepCheck failed, StepStatistics& total)
{
  ++total.rejected_steps;
  ++total.rejections[static_cast<int>(failed)];
  total.solve.factorizations += attempt.solve.factorizations;
  total.solve.reused_factorizations += attempt.solve.reused_factorizations;
  total.solve.singular_count += attempt.solve.singular_count;
  total.projection.projections += attempt.projection.projections;
  total.projection.iterations += attempt.projection.iterations;
  total.rejected_internal_steps += attempt.internal_steps + attempt.rejected_internal_steps;
}

}  // namespace

// ---- shared with scene_changes.cpp (simulator_support.hpp) ----

// The powers of the non-conservative forces at `x` [W] (the model's and the perturbations'):
// `in` of external forces and drags, `dissipated` (>= 0) of damping and drag, `friction` (>= 0)
void ledgerPowers(const Model& model, const Data& data, const State& x, double& in,
                  double& dissipated, double& friction)
{
  in = dissipated = friction = 0.0;
  const std::vector<double>& masses = model.scene().masses;
  forEachForce(model, data.perturbations,
               [&](const Force& force)
               {
                 const double p = power(force, masses, x.positions, x.velocities);
                 if (forceDissipates(force))
                   dissipated -= p;
                 else
                   in += p;
               });
  addContactPowers(model, data, x, in, friction);
}

// energyScale() at the current state with the forces acting now, the model's and the
// perturbations' (between steps data.applied_forces may be older)
double ledgerScale(const Model& model, const Data& data)
{
  const State& x = data.state;
  Points forces = Points::Zero(3, model.numParticles());
  forEachForce(model, data.perturbations,
               [&](const Force& force) {
                 accumulateForce(force, model.scene().masses, x.positions, x.velocities, forces);
               });
  return energyScale(model, x, forces);
}

// Forgets what the checks learnt of the previous state (reset, teleport, new scene).
void forgetControl(Data& data)
{
  data.control.rejection_substeps = 1;
  data.control.accepted_since_rejection = 0;
  data.control.singular = false;
  data.control.multipliers_current = false;
  data.control.end_energies_current = false;
  data.control.unconverged_friction = 0;
}

// Every tracked record (a frame anchor) at rest where its particle is in `positions`, no knot.
void restartTracks(const Model& model, Data& data, const Points& positions)
{
  for (std::size_t k = 0; k < data.tracks.size(); ++k)
    data.tracks[k].restart(
        positions.col(eliminatedParticle(model.scene().constraints[model.tracked()[k]])));
}

void carryCarriers(const Model& from_model, const Data& from, const Model& to_model, Data& to,
                   bool rest)
{
  for (std::size_t k = 0; k < to_model.carriers().size(); ++k)
    for (std::size_t old = 0; old < from_model.carriers().size(); ++old)
      if (sameCarrier(from_model.carriers()[old], to_model.carriers()[k]))
      {
        if (rest)
          to.carriers[k].restAt(from.carriers[old], from.state.time);
        else
          to.carriers[k] = from.carriers[old];
      }
}

// Projects `state` (positions, then velocities) onto `model`'s constraints at its time.
// @throws InvalidInput naming `field`, saying `what` failed; `state` is then half projected
ProjectionReport projectState(const Model& model, Data& data, const StepSettings& settings,
                              State& state, const std::string& field, const std::string& what)
{
  ProjectionReport report =
      projectPositions(model, data, state.time, state.positions, settings.projection_tolerance,
                       settings.projection_max_iterations);
  if (!report.converged)
    throw InvalidInput(field, what + ": error " + formatValue(report.max_position_error) +
                                  " m after " + std::to_string(report.iterations) +
                                  " Newton iterations; nothing changed");
  report.max_velocity_change =
      projectVelocities(model, data, state.time, state.positions, state.velocities, false, true);
  if (!isFinite(state))
    throw InvalidInput(field, "projection produced a non-finite state; nothing changed");
  return report;
}

StepCheck Simulator::attemptStep(const IntegratorInfo& method, int substeps, bool accept_singular)
{
  const Model& model = *model_;
  Data& data = *data_;
  State& x = data.state;
  const State& start = data.control.start;
  StepSettings& sub = substep_settings_;  // a member: copying the integrator's name allocates
  const double h = settings_.dt / substeps;
  // the start's energies, taken once per step: a rejected attempt's forces may be anything
  double kinetic = data.control.start_kinetic, potential = data.control.start_potential;
  double scale = data.control.start_scale;
  // the stages merge into it sub-step after sub-step (merging is associative); each check below
  // reads a count or flag that only grows, and the first sub-step to fail one ends the attempt
  data.statistics = StepStatistics{};
  data.statistics.solve.method = model.solveMethod();
  const StepStatistics& taken = data.statistics;
  restoreStartContacts(model, data);  // every attempt starts from the step start's modes
  // one piece of a sub-step: `length` from the state, ending at `end`
  auto takePiece = [&](double length, double end)
  {
    sub.dt = length;
    // an integrator holding the constraints itself moves x.positions outside the fused stages
    if (method.holds_constraints)
      data.noteStateChange();
    method.step(model, data, sub);
    if (!method.holds_constraints && settings_.stabilization == Stabilization::Projection)
    {
      // projectStep imposes the eliminated motion at `end` on both, before it reads either
      data.control.end_position_error =
          projectStep(model, data, constrained_particles::forwardPath(model, settings_), end,
                      x.positions, x.velocities, settings_.projection_tolerance,
                      settings_.projection_max_iterations)
              .max_position_error;
    }
    else
    {
      imposeEliminated(model, data, end, &x.positions, &x.velocities);
      data.control.end_position_error = -1.0;
    }
    x.time = end;
    sub.dt = h;  // resolveImpacts reads the sub-step's length
  };
  for (int j = 1; j <= substeps; ++j)
  {
    // each sub-step takes h exactly (dt / 2^k is exact; (t + dt) - t is not, and its round-off
    // would jitter every step's length), and the last ends where one step of dt would
    const double end = j == substeps ? start.time + settings_.dt : start.time + j * h;
    // its impacts and releases met at their time (contact.hpp); without contacts, one piece
    takeContactSubstep(model, data, start, j == 1 && settings_.max_substeps > 1, h, end, sub,
                       settings_.projection_tolerance, takePiece);
    // one sweep for the finiteness and energy checks (the same values as three)
    const StepCheckSums sums =
        conservative_ ? stepCheckSums(model, x, data.applied_forces, appliedForceSum(data))
                      : StepCheckSums{ isFinite(x) };
    if (!sums.finite)
      return StepCheck::NonFinite;
    if (taken.forced_internal_steps > 0)
      return StepCheck::AdaptiveGuard;
    if (!taken.projection.converged)
      return StepCheck::Projection;
    if (conservative_)
    {
      const double kinetic_now = sums.kinetic;
      const double potential_now = potentialEnergy(model, x);
      // the scale includes the energy the sub-step exchanged (a particle alone has no extent),
      // and is at least ENERGY_SCALE_FLOOR: a particle alone at rest has neither, and rounding
      // alone would fail it
      const double exchanged =
          std::abs(kinetic_now - kinetic) + std::abs(potential_now - potential);
      const double rise = (kinetic_now + potential_now) - (kinetic + potential);
      // not `<=`: a NaN energy fails too
      if (!(rise <= ENERGY_RISE_TOLERANCE * std::max(scale + exchanged, ENERGY_SCALE_FLOOR)))
        return StepCheck::EnergyRise;
      kinetic = kinetic_now;
      potential = potential_now;
      scale = sums.scale;
    }
    if ((taken.solve.singular || taken.projection.singular) && !data.control.singular &&
        !accept_singular)
      return StepCheck::SingularSolve;
  }
  data.control.end_kinetic = kinetic;
  data.control.end_potential = potential;
  data.control.end_scale = scale;
  return StepCheck::None;
}

void Simulator::openLedger()
{
  const Model& model = *model_;
  Data& data = *data_;
  const State& x = data.state;
  EnergyLedger& ledger = data.ledger;
  ledger = EnergyLedger{};
  data.control.budget_fallback = false;  // a new account: the integrator may take it again
  data.control.budget_base_residual = 0.0;
  data.control.budget_base_time = x.time;
  ledger.t0 = x.time;
  ledger.kinetic = kineticEnergy(model, x);
  ledger.potential = potentialEnergy(model, x);
  ledger.initial_energy = ledger.kinetic + ledger.potential;
  ledger.initial_kinetic = ledger.kinetic;
  ledger.scale = ledgerScale(model, data);
  ledgerPowers(model, data, x, ledger.power_in, ledger.power_dissipated, ledger.power_friction);
  ledger.power_in += drivenPower();
}

double Simulator::drivenPower()
{
  if (!driven_)
    return 0.0;
  // the reactions at the current state with the forces acting now; what the evaluation solved
  // is no step's
  forwardUncounted();
  return drivePower(*model_, *data_);
}

void Simulator::forwardUncounted(bool settle)
{
  Data& data = *data_;
  const StepStatistics kept = data.statistics;
  const long friction = data.control.unconverged_friction;
  forwardAtState(settle);
  data.statistics = kept;
  data.control.unconverged_friction = friction;
}

void Simulator::bookStep(double dt, bool end_energies)
{
  const Model& model = *model_;
  Data& data = *data_;
  const State& x = data.state;
  EnergyLedger& ledger = data.ledger;
  ledger.kinetic = end_energies ? data.control.end_kinetic : kineticEnergy(model, x);
  ledger.potential = end_energies ? data.control.end_potential : potentialEnergy(model, x);
  const double initial_potential = ledger.initial_energy - ledger.initial_kinetic;
  ledger.exchanged = std::max(ledger.exchanged, std::abs(ledger.kinetic - ledger.initial_kinetic) +
                                                    std::abs(ledger.potential - initial_potential));
  double in = 0.0, dissipated = 0.0, friction = 0.0;
  ledgerPowers(model, data, x, in, dissipated, friction);
  if (driven_)
    in += drivePower(model, data);  // step() evaluated the reactions at the step's end
  // trapezoidal rule over the step: the forces acting during it are those at both ends
  ledger.work_in += 0.5 * dt * (ledger.power_in + in);
  ledger.work_in_moved += 0.5 * dt * (std::abs(ledger.power_in) + std::abs(in));
  ledger.dissipated += 0.5 * dt * (ledger.power_dissipated + dissipated);
  // friction as the step applied it: a kick held over the step (velocity Verlet, fast
  // projection) booked its own loss, exactly, where the trapezoid would be first order against
  // it (velocity Verlet on rope_on_table reached 0.12 of the budget at dt 20 ms that way:
  // EnergyLedger.KickedFrictionIsBookedAsTheKickTakesIt); the stages' friction by the trapezoid
  StepControl& control = data.control;
  ledger.dissipated += control.friction_kicked ? control.friction_kick_loss
                                               : 0.5 * dt * (ledger.power_friction + friction);
  ledger.dissipated += control.contact_loss;  // the step's impacts (resolveImpacts)
  control.contact_loss = control.friction_kick_loss = 0.0;
  control.friction_kicked = false;
  ledger.power_in = in;
  ledger.power_dissipated = dissipated;
  ledger.power_friction = friction;
}

void Simulator::readSceneKind()
{
  driven_ = model_->hasCarriers();  // a carried obstacle moves in time, as a driven anchor
  for (const Constraint& constraint : model_->scene().constraints)
    driven_ = driven_ || isDriven(constraint);
  // a driven anchor (a time-dependent kind) or a force from outside does work on the system:
  // its energy is not kept
  // contacts only take energy out (impacts, met at their time: attemptStep; friction), so a
  // sub-step whose energy rises is the integrator's error there too (a slide into a steep face
  // faster than the step resolves it): the rise check holds in scenes with contacts
  conservative_ = !driven_ && forcesConservative(model_->scene()) && data_->perturbations.empty();
  has_stiffness_ = hasStiffness(*model_, data_->perturbations);
  budget_judges_ =
      model_->tracked().empty() && !model_->hasCarriers() &&
      std::none_of(model_->unilateral().begin(), model_->unilateral().end(),
                   [](const UnilateralRecord& record) { return record.friction > 0.0; });
  hold_limits_.clear();
  const Model& model = *model_;
  for (std::size_t k = 0; k < model.tracked().size(); ++k)
    if (const auto* anchor =
            std::get_if<FrameAnchorConstraint>(&model.scene().constraints[model.tracked()[k]]);
        anchor && anchor->max_force > 0.0)
    {
      const auto e =
          std::find(model.eliminated().begin(), model.eliminated().end(), model.tracked()[k]) -
          model.eliminated().begin();
      hold_limits_.push_back({ static_cast<int>(k), static_cast<int>(e), anchor->max_force });
    }
  hold_loads_.assign(hold_limits_.size(), 0.0);
}

void Simulator::checkHolds(StepOutcome& outcome, StepStatistics& total)
{
  // only the constraints' own failures can be the holds' doing: a projection that cannot meet
  // them, or a solve gone singular; a diverging method or state is not a hold's to answer for
  const bool impossible =
      outcome.failed == StepCheck::Projection || outcome.failed == StepCheck::SingularSolve;
  if (hold_limits_.empty() || (outcome.failed != StepCheck::None && !impossible))
    return;
  const Model& model = *model_;
  // the hold most loaded against its limit: now (a passed step), or at the last accepted step
  // (a step no split could take: what the holds asked of the scene was impossible)
  int worst = -1;
  double worst_ratio = -1.0, worst_force = 0.0;
  for (std::size_t k = 0; k < hold_limits_.size(); ++k)
  {
    const double force =
        outcome.failed == StepCheck::None
            ? model.eliminatedReaction(data_->multipliers, hold_limits_[k].eliminated).norm()
            : hold_loads_[k];
    // not `>`: a NaN force is over too
    const double ratio = std::isnan(force) ? INFINITY : force / hold_limits_[k].max_force;
    if (ratio > worst_ratio)
    {
      worst = static_cast<int>(k);
      worst_ratio = ratio;
      worst_force = force;
    }
  }
  if (outcome.failed == StepCheck::None && worst_ratio <= 1.0)
  {
    for (std::size_t k = 0; k < hold_limits_.size(); ++k)
      hold_loads_[k] =
          model.eliminatedReaction(data_->multipliers, hold_limits_[k].eliminated).norm();
    return;
  }
  total.hold = hold_limits_[worst].tracked;
  total.hold_force = outcome.failed == StepCheck::None ? worst_force : INFINITY;
  total.hold_failure = outcome.failed;
  outcome.failed = StepCheck::HoldForce;
}

void Simulator::forwardAtState(bool settle)
{
  Data& data = *data_;
  data.control.end_energies_current = false;  // the applied forces are evaluated anew
  if (settle)
  {
    // complementary forces: a row an impact at a step's end switched on beside one it takes the
    // load from (a lever's end on its face) would pull until the next step chose the modes
    // again. Without contacts this is the one forward stage below
    SolveReport solved;
    settleActiveSet(*model_, data, settings_, solved);
    return;
  }
  // on copies: forward() imposes the eliminated motion on the positions it is given
  data.stages.p_stage = data.state.positions;
  data.stages.v_stage = data.state.velocities;
  forward(*model_, data, settings_, data.state.time, data.stages.p_stage, data.stages.v_stage,
          data.accelerations);
}

void Simulator::evaluateCurrentState(StepStatistics& total)
{
  data_->statistics = StepStatistics{};
  forwardAtState();
  total.solve.merge(data_->statistics.solve);
}

Simulator::StepPlan Simulator::planStep(StepStatistics& total)
{
  const Model& model = *model_;
  Data& data = *data_;
  StepControl& control = data.control;
  const State& x = data.state;
  const int max_substeps = settings_.max_substeps;
  // after the integrator overdrew the energy budget, the stiff-safe method takes every step
  StepPlan plan{ control.budget_fallback ? stiff_ : integrator_,
                 control.budget_fallback ? 1 : std::min(control.rejection_substeps, max_substeps) };
  const bool estimate = !control.budget_fallback &&
                        integrator_->stability_limit < UNBOUNDED_STABILITY && max_substeps > 1 &&
                        has_stiffness_;
  // the estimate reads the multipliers of the last step's last stage and the energy check its
  // applied forces; after a reset or teleport, or where the integrator solves for no
  // multipliers (velocity Verlet's SHAKE), they are evaluated here (fast projection, with no
  // estimate, keeps the applied forces of its own last stage for the energy check)
  const bool own_forces = plan.method->holds_constraints;
  if ((!control.multipliers_current && (estimate || (conservative_ && !own_forces))) ||
      (estimate && own_forces))
  {
    evaluateCurrentState(total);
  }
  if (estimate)
  {
    const double omega =
        estimateMaxFrequency(model, data.multipliers, x.positions, x.time, control.stiffness,
                             data.perturbations, &data.carriers);
    total.max_frequency = std::max(total.max_frequency, omega);
    const int wanted = stabilitySubsteps(omega, settings_.dt, integrator_->stability_limit,
                                         MAX_STABILITY_SUBSTEPS);
    // more than max_substeps cannot be stable: straight to the stiff-safe method
    if (wanted > max_substeps)
      plan = { stiff_, 1 };
    else
      plan.substeps = std::max(plan.substeps, wanted);
  }
  return plan;
}

void Simulator::markStart()
{
  const Model& model = *model_;
  Data& data = *data_;
  StepControl& control = data.control;
  const State& x = data.state;
  // the start is put back only where a step may be retaken (max_substeps > 1); otherwise its
  // time is all the sub-steps read (at 10^5 particles the copy moves 4.8 MB a step)
  if (settings_.max_substeps > 1)
    control.start = x;
  else
    control.start.time = x.time;
  control.start_contacts = data.contacts;
  if (conservative_ && control.end_energies_current)
  {
    // the last step ended here with these forces, and its checks measured them
    control.start_kinetic = control.end_kinetic;
    control.start_potential = control.end_potential;
    control.start_scale = control.end_scale;
  }
  else if (conservative_)
  {
    const StepCheckSums sums = stepCheckSums(model, x, data.applied_forces, appliedForceSum(data));
    control.start_kinetic = sums.kinetic;
    control.start_potential = potentialEnergy(model, x);
    control.start_scale = sums.scale;
  }
  control.end_energies_current = false;
}

StepCheck Simulator::attemptUntilPassed(StepPlan& plan, StepStatistics& total)
{
  Data& data = *data_;
  StepControl& control = data.control;
  const int max_substeps = settings_.max_substeps;
  const StepStatistics& attempt = data.statistics;  // the last attempt's (attemptStep)
  for (;;)
  {
    // at the finest split a new singular solve is accepted (regularised) and the step finished
    const StepCheck failed =
        attemptStep(*plan.method, plan.substeps, plan.substeps >= max_substeps);
    // dopri5's guard: sub-steps would only repeat its own internal steps
    const bool guard = failed == StepCheck::AdaptiveGuard;
    const bool finest = plan.substeps >= max_substeps || guard;
    if (failed == StepCheck::None)
      return failed;
    // the finest split of the chosen method failed: the stiff-safe one takes the step (at dopri5's
    // guard too: an ill-conditioned solve, as of a rope folded flat onto itself, leaves rounding
    // noise in the accelerations above the tolerance, which no internal step passes)
    const bool fall_back = finest && max_substeps > 1 && plan.method != stiff_;
    if (finest && !fall_back)
      return failed;
    countRejected(attempt, failed, total);
    data.setState(control.start);
    if (fall_back)
    {
      plan = { stiff_, 1 };
      continue;
    }
    plan.substeps = std::min(2 * plan.substeps, max_substeps);
    if (plan.method == integrator_)  // the fallback's own retakes leave the integrator's memory
    {
      control.rejection_substeps = plan.substeps;
      control.accepted_since_rejection = 0;
    }
  }
}

Simulator::StepOutcome Simulator::takeStep(StepPlan& plan, StepStatistics& total)
{
  Data& data = *data_;
  StepControl& control = data.control;
  const StepStatistics& attempt = data.statistics;  // the last attempt's (attemptStep)
  StepOutcome outcome;
  for (;;)  // once; twice where the energy budget's fallback retakes the step
  {
    outcome.failed = attemptUntilPassed(plan, total);
    outcome.singular = attempt.solve.singular || attempt.projection.singular;
    // merged once the budget has passed the step; a driven anchor's power is its reaction's at
    // the step's end, from every stage there, which leaves data.statistics to the evaluation
    // (the attempt's kept aside first: a copy only in driven scenes, into a member, as a local
    // optional of this size cost every step its construction)
    if (driven_)
    {
      driven_attempt_ = attempt;
      evaluateCurrentState(total);
    }
    const StepStatistics& taken = driven_ ? driven_attempt_ : attempt;
    checkHolds(outcome, total);
    outcome.end_energies = conservative_ && outcome.failed == StepCheck::None;
    outcome.ledger_before = data.ledger;
    bookStep(settings_.dt, outcome.end_energies);
    const EnergyLedger& ledger = data.ledger;
    // a NaN residual fails `<=`: it overdraws (a sampled path is not judged: budgetJudges)
    if (outcome.failed != StepCheck::None || settings_.energy_budget <= 0.0 || !budgetJudges() ||
        budgetResidual() <= settings_.energy_budget * ledger.budgetScale(ENERGY_SCALE_FLOOR))
    {
      total.merge(taken);
      return outcome;
    }
    // over the run, not the step: no split of this step undoes what earlier ones gained; the
    // stiff-safe method, whose projection only takes energy out, retakes it and the rest of the
    // run (until the ledger opens again or the settings change)
    control.budget_failure_residual = budgetResidual();
    control.budget_failure_scale = ledger.budgetScale(ENERGY_SCALE_FLOOR);
    // a fault only where the stiff-safe method overdrew a budget of its own: as the fallback,
    // or as the user's method; a stiff step the stability estimate chose hands over like any
    if (settings_.max_substeps <= 1 ||
        (plan.method == stiff_ && (control.budget_fallback || integrator_ == stiff_)))
    {
      total.merge(taken);
      outcome.failed = StepCheck::EnergyBudget;
      return outcome;
    }
    // retaken: its work is counted, its outcome (singular solves, projections' state) is not
    control.budget_fallback_time = control.start.time;
    control.budget_handed_by = plan.method->name;
    countRejected(taken, StepCheck::EnergyBudget, total);
    data.setState(control.start);
    data.ledger = outcome.ledger_before;
    control.budget_fallback = true;
    // from what the run had gained before this step: the fallback's own gain is judged, a whole
    // budget (it takes over at the budget's edge, where its first-order quadrature of damping
    // would overdraw what is left: sled_on_ramp with semi-implicit Euler at dt 10 ms faulted
    // 3.7 s in, EnergyLedger.TheFallbackIsJudgedByItsOwnGain)
    control.budget_base_residual = data.ledger.residual();
    control.budget_base_time = control.start.time;
    plan = { stiff_, 1 };
  }
}

void Simulator::putBack(const EnergyLedger& ledger_before)
{
  Data& data = *data_;
  data.setState(data.control.start);  // the state stays the last accepted one
  data.ledger = ledger_before;
  data.control.multipliers_current = false;
  restoreStartContacts(*model_, data);  // and the contacts' modes the step started with
}

void Simulator::acceptStep(const StepPlan& plan, const StepOutcome& outcome, StepStatistics& total)
{
  StepControl& control = data_->control;
  ++data_->state.steps;
  ++total.steps;
  total.end_position_error = control.end_position_error;
  total.substeps += plan.substeps;
  total.max_substeps = std::max(total.max_substeps, plan.substeps);
  control.singular = outcome.singular;
  control.end_energies_current = outcome.end_energies;
  // velocity Verlet and fast projection solve for no multipliers; with contacts, the last
  // stage's are of the modes the step started with (a row an impact at its end switched on, or
  // one about to let go, may pull): constraintForces settles them at the state
  control.multipliers_current =
      model_->numContacts() == 0 &&
      (driven_ || (plan.method == integrator_ && !integrator_->holds_constraints));
  if (plan.method != integrator_)
  {
    // the stiff-safe method solves for no multipliers: the forces of the failed attempt are
    // left in data, so they are evaluated at the accepted state
    ++total.stiff_steps;
    if (!driven_)
      evaluateCurrentState(total);
    control.multipliers_current = model_->numContacts() == 0;
  }
  for (std::size_t k = 0; k < data_->contacts.size(); ++k)
    control.step_normal_forces[k] = data_->contacts[k].normal_force;
  if (control.rejection_substeps > 1 && ++control.accepted_since_rejection >= RELAX_AFTER_STEPS)
  {
    control.rejection_substeps /= 2;
    control.accepted_since_rejection = 0;
  }
}

StepStatistics Simulator::step(int count)
{
  // as mj_step reads: plan the step, mark its start, take it (attempts, splits, the stiff
  // fallback, the energy budget), then accept it or put it back
  const EffectCounters before = data_->counters;
  StepStatistics total;
  total.solve.method = model_->solveMethod();
  for (int k = 0; k < count; ++k)
  {
    updateLinkPairs();  // may replace the model and its data (self-collision's pairs)
    Data& data = *data_;
    startContactStep(*model_, data, settings_);  // the active set at the step's start
    StepPlan plan = planStep(total);
    markStart();
    const StepOutcome outcome = takeStep(plan, total);
    if (outcome.failed != StepCheck::None)
    {
      if (total.failed_check == StepCheck::None)
        total.failed_check = outcome.failed;
      // a hold over its limit is put back whatever the splits: the caller lets go of it
      if (settings_.max_substeps > 1 || outcome.failed == StepCheck::HoldForce)
      {
        putBack(outcome.ledger_before);
        break;
      }
      // max_substeps = 1: the checks only report; the step stands as taken (as before checks)
    }
    acceptStep(plan, outcome, total);
  }
  Data& data = *data_;
  total.effects = data.counters.since(before);
  // the batch's friction solves that stopped short, stalled or at their limit (every attempt's)
  total.unconverged_friction = std::exchange(data.control.unconverged_friction, 0);
  data.statistics = total;
  return total;
}

Diagnostics Simulator::diagnostics() const
{
  return computeDiagnostics(*model_, data_->state, diagnostic_rows_, diagnostic_rates_,
                            &data_->tracks, &data_->carriers);
}

void Simulator::constraintForces(Points& forces, Eigen::VectorXd& multipliers)
{
  forwardUncounted(true);
  forces = data_->constraint_forces;
  multipliers = data_->multipliers;
}

}  // namespace constrained_particles
