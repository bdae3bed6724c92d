/// @file simulator.hpp
/// @brief A model, its data and its step settings, with validated updates: a refused change
/// leaves everything as it was.
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/forward_path.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"

#include <memory>
#include <optional>

namespace constrained_particles
{
/// Steps one scene. Not thread-safe: callers serialise access.
class Simulator
{
public:
  /// Validates and compiles scene, initial state and settings; projects the initial state onto
  /// the constraints (eliminated particles where their kinds put them at its time).
  /// `paths`: StagePaths::Generic keeps every evaluation on the generic stages, also after
  /// scene and force changes (equivalence tests; the motion is the same).
  /// @throws InvalidInput naming the first bad field
  Simulator(const Scene& scene, const State& initial_state, const StepSettings& settings,
            SolveMethod method = SolveMethod::Automatic,
            StagePaths paths = StagePaths::Specialized);

  /// Takes `count` steps of stepSettings().dt, each checked and split into sub-steps when needed:
  ///  - before a step, the stability estimate (stability.hpp) splits it into the fewest
  ///    2^k sub-steps that keep omega_max dt_sub inside the integrator's stability limit;
  ///  - after each (sub-)step, the checks (StepCheck): finite; every projection converged;
  ///    for a conservative scene (only conservative forces, no driven anchor) total energy
  ///    rose by at most ENERGY_RISE_TOLERANCE of energyScale() plus what the sub-step
  ///    exchanged, at least ENERGY_SCALE_FLOOR; no singular solve where the last
  ///    accepted step had none; dopri5 within its guards. A failed step is put back and retaken
  ///    as twice the sub-steps, up to max_substeps; the count then relaxes back, halving after
  ///    RELAX_AFTER_STEPS accepted steps;
  ///  - a step the estimate says needs more than max_substeps, or that fails at max_substeps, is
  ///    taken by the stiff-safe STIFF_FALLBACK (fast projection: bounded at any dt, first order,
  ///    dissipative) with its own sub-steps from 1 (StepStatistics::stiff_steps counts them);
  ///  - dopri5's guard goes to the fallback at once (it adapts its internal steps already:
  ///    sub-steps would repeat them); a check the fallback fails at max_substeps is final:
  ///    StepStatistics::failed_check names it and the batch ends there, that step put back (the
  ///    state is the last accepted step's);
  ///  - max_substeps = 1 takes each step as asked, as before the checks existed (no sub-steps, no
  ///    fallback, nothing put back): a failed check is only reported in failed_check (the node
  ///    faults on it). A
  ///    singular solve at max_substeps is accepted (regularised).
  /// @return the worst and the totals over the steps taken
  StepStatistics step(int count = 1);

  /// Back to the initial state (time 0, step count 0).
  void reset();

  /// Teleports to a state, projected onto the constraints (eliminated particles exact); time and
  /// step count are kept from the current state.
  /// @throws InvalidInput if the state is malformed or cannot be projected, or puts a free
  /// particle below the surface its surface_contact keeps it above, or inside the obstacle its
  /// shape_contact keeps it out of (by over CONTACT_START_DEPTH, field "positions[i]"); state and
  /// contacts untouched
  ProjectionReport setState(const State& state);

  /// Replaces the scene and initial state, and resets. A carried obstacle of the same name in
  /// both rests where it is now (its holder's world goes on). @throws InvalidInput; nothing
  /// changes
  void setScene(const Scene& scene, const State& initial_state,
                SolveMethod method = SolveMethod::Automatic);
  /// The same with new step settings, taken only with the scene. @throws InvalidInput; nothing
  /// changes, the settings neither
  void setScene(const Scene& scene, const State& initial_state, const StepSettings& settings,
                SolveMethod method = SolveMethod::Automatic);

  /// @throws InvalidInput naming the bad setting; settings untouched
  void setStepSettings(const StepSettings& settings);

  /// Puts back a state taken earlier from state() (no projection: it was valid then).
  /// @throws InvalidInput if it does not fit this model or is not finite; state untouched
  void restoreState(const State& state);

  /// Replaces the scene's applied forces, keeping the state (e.g. gravity changed at run time)
  /// and the perturbations. @throws InvalidInput naming the bad force; nothing changes
  void setForces(const std::vector<Force>& forces);

  /// Replaces the scene's constraints, keeping the state, forces and perturbations (a particle
  /// grabbed or let go at run time: a frame_anchor added or removed). A held particle's track is
  /// kept where the same particle is tracked again; a newly tracked one rests where it is. The
  /// state is projected onto the new constraints (like setState) and the energy ledger opened.
  /// @throws InvalidInput naming the bad constraint or the failed projection; nothing changes
  ProjectionReport setConstraints(const std::vector<Constraint>& constraints);

  /// Replaces the scene's height fields (as many as it has), keeping the state, forces,
  /// perturbations and holders' tracks: the ground changes under a resting rope. The state is
  /// projected onto the constraints on the new surfaces (a bead on one moves onto it), then each
  /// particle a surface contact keeps above its new surface but now below it is lifted onto it
  /// (an inelastic impact: its velocity into the surface goes); the report's max_displacement
  /// [m] and max_velocity_change [m/s] say by how much. The energy ledger is opened anew.
  /// @throws InvalidInput naming "surfaces" (another count) or the failed projection; nothing
  /// changes
  ProjectionReport setSurfaces(const std::vector<Surface>& surfaces);

  /// Replaces the scene's obstacle contacts (its shape_contact and segment_contact records, and a
  /// self-colliding rope's link pairs, made again at the next step) with `contacts`, keeping the
  /// state, forces, perturbations, holders' and carried shapes' tracks: an obstacle added, moved,
  /// resized or removed under the running rope (~set_obstacle). As setSurfaces, the state is
  /// projected onto the constraints, then each particle or link a contact keeps out of its
  /// obstacle but now inside it is moved out (its velocity into it taken out); the report says by
  /// how much. Where the projection finds no way out at once (a shape moved deep over a rope,
  /// its normals all along the rope's line), each shape the old contacts name too, of the same
  /// type, on the same holder and not a mesh, is moved there in steps (its position, sizes and
  /// rotation along the way; a step halved where it is still too deep, down to 1/256 of the way
  /// in at most 64 projections), the particles pushed out of its way at each step as by a shape
  /// moving slowly there; the report's change_steps says how many it took.
  /// @throws InvalidInput naming "contacts[k]" (a record of another kind, or invalid), the
  /// failed projection, or "contacts" for a change too deep even in steps; nothing changes
  ProjectionReport setObstacles(const std::vector<Constraint>& contacts);

  /// Replaces the forces applied from outside the model (Data::perturbations: a push, a grabbed
  /// particle's target spring), evaluated from the next step on beside the model's own and
  /// counted with them; empty = none. Cheap: no recompilation. A conservative scene's energy
  /// check is off while any is set (they do work on it). A new scene (setScene) starts without.
  /// @throws InvalidInput naming "perturbations[k].<field>"; nothing changes
  void setPerturbations(const std::vector<Force>& perturbations);

  const Model& model() const
  {
    return *model_;
  }
  /// Counts the models this simulator has had: a scene change, and a self-colliding rope's link
  /// pairs changing within step() (updateLinkPairs), each make a new one. A caller keeping a copy
  /// of model() takes another when this changes.
  std::uint64_t modelVersion() const
  {
    return model_version_;
  }
  /// The stage path the steps take under the current settings, and why (forward_path.hpp); the
  /// energy budget's fallback, while it holds the run, is the stiff-safe method's.
  PathChoice forwardPath() const
  {
    if (!data_->control.budget_fallback)
      return choosePath(*model_, settings_);
    StepSettings fallback = settings_;
    fallback.integrator = STIFF_FALLBACK;
    return choosePath(*model_, fallback);
  }
  /// Rows, forces, multipliers and buffers of the last evaluation (after the fused chain stages
  /// only part of `rows` is of it: Data::rows says which).
  const Data& data() const
  {
    return *data_;
  }
  const State& state() const
  {
    return data_->state;
  }
  /// The tracked records' paths (Data::tracks, in Model::tracked() order), in sim time: written
  /// between steps by whoever samples their holders (AnchorTrack::append with now = state().time
  /// changes nothing before it). reset() puts each back at rest where its particle starts.
  std::vector<AnchorTrack>& tracks()
  {
    return data_->tracks;
  }
  const std::vector<AnchorTrack>& tracks() const
  {
    return data_->tracks;
  }
  /// The carried shapes' paths (Data::carriers, in Model::carriers() order: each the holder
  /// frame's origin and orientation), in sim time: written by whoever samples their holders, as
  /// tracks() are. A shape whose track has no knot rests at its own pose.
  std::vector<AnchorTrack>& carriers()
  {
    return data_->carriers;
  }
  const std::vector<AnchorTrack>& carriers() const
  {
    return data_->carriers;
  }
  /// Every track at rest where its point is now (AnchorTrack::restart): the held particles
  /// stopped, the velocities projected onto the constraints again and the energy ledger opened
  /// (the stop is no step's doing). For when the stamps a track's knots stood for are gone (an
  /// unpause, a clock that went back, a teleport). Carried obstacles rest too, where they are.
  void restTracks();
  const State& initialState() const
  {
    return initial_state_;
  }
  const StepSettings& stepSettings() const
  {
    return settings_;
  }

  /// How often each effect and solve was evaluated since the scene was set (steps, projections
  /// and constraintForces()).
  const EffectCounters& effectCounters() const
  {
    return data_->counters;
  }

  /// Errors and energies of the current state.
  Diagnostics diagnostics() const;

  /// The energy account since the last change of the state or the world (openLedger, data.hpp).
  const EnergyLedger& energyLedger() const
  {
    return data_->ledger;
  }

  /// Whether the energy budget judges this scene's steps (StepSettings::energy_budget): not
  /// where a sampled path moves something (a frame anchor, a carried shape), whose
  /// acceleration jumps at every sample (there the residual measures the quadrature rather
  /// than the method), nor yet where a contact has friction: fast_projection, the fallback,
  /// gains energy at first order sliding with friction over a convex surface (docs/stability.md).
  bool budgetJudges() const
  {
    return budget_judges_;
  }
  /// The residual the energy budget judges [J]: the ledger's, less what the run had gained when
  /// the method taking the steps took it (StepControl::budget_base_residual: the stiff fallback
  /// at its takeover, new step settings when set): a method is judged by what it gains itself.
  double budgetResidual() const
  {
    return data_->ledger.residual() - data_->control.budget_base_residual;
  }

  /// Constraint forces [N] and multipliers at the current state (computed on demand); with
  /// contacts, of the active set settled there (no acting contact pulls). Reading them never
  /// changes the motion.
  void constraintForces(Points& forces, Eigen::VectorXd& multipliers);

  /// A conservative scene's energy may rise in one sub-step by this fraction of energyScale() at
  /// its start plus the energy it exchanged (|dT| + |dU|).
  static constexpr double ENERGY_RISE_TOLERANCE = 1e-3;
  /// The stiff-safe method a step falls back to (integrators.hpp).
  static constexpr const char* STIFF_FALLBACK = "fast_projection";
  /// Most sub-steps the stability estimate computes when it decides on the fallback.
  static constexpr int MAX_STABILITY_SUBSTEPS = 1 << 30;
  /// The energy budget's smallest scale [J]: a scene at rest with no force has none of its own.
  static constexpr double ENERGY_SCALE_FLOOR = 1e-6;
  /// Accepted steps at a rejection's sub-step count before it is halved again.
  static constexpr int RELAX_AFTER_STEPS = 16;

private:
  /// One step of dt as `substeps` sub-steps from data.control.start, checked; the statistics of
  /// its sub-steps merged into `attempt`. @return the first check a sub-step failed, or None
  /// Sets conservative_, has_stiffness_ and driven_ from the model's scene (after any scene
  /// change).
  void readSceneKind();
  /// Self-collision at a step's start: the link pairs within linkPairMargin() of touching
  /// (nearLinkPairs) become the model's link_pair_contact rows. While each is in the model already
  /// nothing changes; else the model is compiled again with them (far pairs dropped) and the data
  /// carried over whole: state, contacts (the pairs' by their particles), step memory, ledger,
  /// statistics and holders' tracks; modelVersion() counts the change. A pair's row is off until
  /// it touches. No-op without Scene::self_collisions.
  void updateLinkPairs();

  /// Makes `model` and `data` the simulator's (the old data, which refers to the old model, goes
  /// first), reads the scene's kind and sizes the diagnostics' workspaces to its rows.
  void install(std::unique_ptr<Model> model, std::unique_ptr<Data> data);

  /// `from` under a changed world (`model`, `data`: its tracks and carriers): projected onto the
  /// constraints, then each contact now inside its surface or obstacle switched on and its
  /// particles moved out (resolveImpacts at rest); `data` holds the result. nullopt if that leaves
  /// them off their constraints by over twice the tolerance (no way out found: `error` says how
  /// far [m]); `report` the projection's.
  /// @throws InvalidInput naming `field` if the projection fails or the result is not finite
  std::optional<State> movedOut(const Model& model, Data& data, const State& from,
                                const std::string& field, ProjectionReport* report,
                                double* error) const;

  /// Installs `model` and `data` (the data holding the running state's tracks and carriers)
  /// after a change of the world under the state (setSurfaces, setObstacles), with `from` (the
  /// running state, or one moved through the change's steps) movedOut onto it; the report's
  /// displacement and velocity change are from the running state. The ledger is opened anew.
  /// @throws InvalidInput naming `field`; nothing changes
  ProjectionReport installChangedWorld(std::unique_ptr<Model> model, std::unique_ptr<Data> data,
                                       const std::string& field, const State& from);

  /// Opens the energy ledger at the current state (t0).
  void openLedger();
  /// The driven anchors' power at the current state with the forces acting now [W] (a forward
  /// stage there; 0 without a driven anchor).
  double drivenPower();
  /// Books one accepted step of `dt` [s] ending at the current state, whose end energies are
  /// control.end_* where `end_energies` (else measured here).
  void bookStep(double dt, bool end_energies);

  /// Every stage at the current state (forces, multipliers, accelerations), on copies of it.
  /// `settle`: with the contacts' active set settled there first (settleActiveSet), for forces
  /// read between steps; else with the modes as they are (a step's start: chosen).
  void forwardAtState(bool settle = false);
  /// forwardAtState(settle) outside any step (what it solves is no step's): data_->statistics
  /// and the friction count (StepControl::unconverged_friction) kept.
  void forwardUncounted(bool settle = false);
  /// forwardAtState() within a step, its solve merged into `total`.
  void evaluateCurrentState(StepStatistics& total);

  /// `accept_singular`: a new singular solve passes (the finest split). The attempt's
  /// statistics, all its sub-steps merged, are left in data_->statistics.
  StepCheck attemptStep(const IntegratorInfo& method, int substeps, bool accept_singular);

  /// The method a step starts with and its sub-steps.
  struct StepPlan
  {
    const IntegratorInfo* method;
    int substeps;
  };
  /// How a step ended: the check it failed (None if it passed), whether its accepted attempt
  /// had a singular solve, whether control.end_* hold its end energies, and the ledger before
  /// it was booked (put back with the step).
  struct StepOutcome
  {
    StepCheck failed = StepCheck::None;
    bool singular = false;
    bool end_energies = false;
    EnergyLedger ledger_before;
  };
  /// The step's stages, in order (Simulator::step):
  /// the method and sub-steps: the budget's fallback, else the integrator split as the
  /// stability estimate and the last rejections ask, or the stiff-safe method where no split
  /// can be stable
  StepPlan planStep(StepStatistics& total);
  /// control.start (to put back) and its energies
  void markStart();
  /// attempts from control.start until one passes: twice the sub-steps after a failed check,
  /// the stiff-safe method after the finest split failed; the last check failed, else None
  StepCheck attemptUntilPassed(StepPlan& plan, StepStatistics& total);
  /// attemptUntilPassed, then the booking and the energy budget: a step that overdraws it is
  /// retaken by the stiff-safe method, which keeps the run (control.budget_fallback)
  StepOutcome takeStep(StepPlan& plan, StepStatistics& total);
  /// a taken step's holds against their max_force (driven scenes evaluate the reactions at the
  /// step's end): one over it, or a step that could not be taken at all while holds with a
  /// limit held the scene, fails StepCheck::HoldForce naming the hold in `total`
  void checkHolds(StepOutcome& outcome, StepStatistics& total);
  /// a failed step: the state and the ledger as they were at control.start
  void putBack(const EnergyLedger& ledger_before);
  /// an accepted step: counted, and what the next step may reuse marked
  void acceptStep(const StepPlan& plan, const StepOutcome& outcome, StepStatistics& total);

  /// Everything a scene change replaces together.
  struct Compiled
  {
    std::unique_ptr<Model> model;
    std::unique_ptr<Data> data;
    State initial_state;
  };
  static Compiled compile(const Scene& scene, const State& initial_state,
                          const StepSettings& settings, SolveMethod method, StagePaths paths);

  std::unique_ptr<Model> model_;
  std::unique_ptr<Data> data_;
  State initial_state_;
  StepSettings settings_;
  StepSettings substep_settings_;  // settings_ with a sub-step's dt (attemptStep)
  StepStatistics driven_attempt_;  // a driven scene's attempt, aside while its end is evaluated
  StagePaths paths_ = StagePaths::Specialized;             // kept for every model compiled later
  SolveMethod requested_method_ = SolveMethod::Automatic;  // the scene's: link pair models too
  std::uint64_t model_version_ = 0;                        // models installed (modelVersion())
  const IntegratorInfo* integrator_ = nullptr;             // settings_.integrator's row
  const IntegratorInfo* stiff_ = nullptr;                  // STIFF_FALLBACK's row
  bool conservative_ = false;   // only conservative forces, no driven anchor: energy is checked
  bool has_stiffness_ = false;  // rows or springs: the stability estimate has something to see
  bool budget_judges_ = true;   // budgetJudges(), read from the scene (readSceneKind)
  bool driven_ = false;  // a driven anchor: its reactions are evaluated at each step's end (ledger)
  struct HoldLimit
  {
    int tracked;       // Model::tracked() index
    int eliminated;    // Model::eliminated() index (its reaction's)
    double max_force;  // [N]
  };
  std::vector<HoldLimit> hold_limits_;  // the tracked records with a max_force
  std::vector<double> hold_loads_;      // their reactions' size at the last accepted step [N]
  mutable RowData diagnostic_rows_;     // workspaces of diagnostics()
  mutable Eigen::VectorXd diagnostic_rates_;
};

}  // namespace constrained_particles
