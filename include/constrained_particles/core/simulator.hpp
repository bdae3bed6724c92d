/// @file simulator.hpp
/// @brief A model, its data and its step settings, with validated updates: a refused change
/// leaves everything as it was.
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"

#include <memory>

namespace constrained_particles
{
/// Steps one scene. Not thread-safe: callers serialise access.
class Simulator
{
public:
  /// Validates and compiles scene, initial state and settings; projects the initial state onto
  /// the constraints (eliminated particles where their kinds put them at its time).
  /// @throws InvalidInput naming the first bad field
  Simulator(const Scene& scene, const State& initial_state, const StepSettings& settings,
            SolveMethod method = SolveMethod::Automatic);

  /// Takes `count` steps of stepSettings().dt.
  /// @return the worst and the totals over all `count` steps
  StepStatistics step(int count = 1);

  /// Back to the initial state (time 0, step count 0).
  void reset();

  /// Teleports to a state, projected onto the constraints (eliminated particles exact); time and
  /// step count are kept from the current state.
  /// @throws InvalidInput if the state is malformed or cannot be projected; state untouched
  ProjectionReport setState(const State& state);

  /// Replaces the scene and initial state, and resets. @throws InvalidInput; nothing changes
  void setScene(const Scene& scene, const State& initial_state,
                SolveMethod method = SolveMethod::Automatic);

  /// @throws InvalidInput naming the bad setting; settings untouched
  void setStepSettings(const StepSettings& settings);

  /// Puts back a state taken earlier from state() (no projection: it was valid then).
  /// @throws InvalidInput if it does not fit this model or is not finite; state untouched
  void restoreState(const State& state);

  /// Replaces the scene's applied forces, keeping the state (e.g. gravity changed at run time).
  /// @throws InvalidInput naming the bad force; nothing changes
  void setForces(const std::vector<Force>& forces);

  const Model& model() const
  {
    return *model_;
  }
  /// Rows, forces, multipliers and buffers of the last evaluation.
  const Data& data() const
  {
    return *data_;
  }
  const State& state() const
  {
    return data_->state;
  }
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

  /// Constraint forces [N] and multipliers at the current state, as the next step would apply
  /// them (computed on demand).
  void constraintForces(Points& forces, Eigen::VectorXd& multipliers);

private:
  /// Everything a scene change replaces together.
  struct Compiled
  {
    std::unique_ptr<Model> model;
    std::unique_ptr<Data> data;
    State initial_state;
  };
  static Compiled compile(const Scene& scene, const State& initial_state,
                          const StepSettings& settings, SolveMethod method);

  std::unique_ptr<Model> model_;
  std::unique_ptr<Data> data_;
  State initial_state_;
  StepSettings settings_;
  const IntegratorInfo* integrator_ = nullptr;  // settings_.integrator's row
  mutable RowData diagnostic_rows_;             // workspaces of diagnostics()
  mutable Eigen::VectorXd diagnostic_rates_;
};

}  // namespace constrained_particles
