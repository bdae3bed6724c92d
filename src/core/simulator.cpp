#include "constrained_particles/core/simulator.hpp"

#include "stabilization.hpp"
#include "stages.hpp"

#include <string>

namespace constrained_particles
{
Simulator::Compiled Simulator::compile(const Scene& scene, const State& initial_state,
                                       const StepSettings& settings, SolveMethod method)
{
  validateStepSettings(settings);
  Compiled compiled;
  compiled.model = std::make_unique<Model>(Model::compile(scene, method));
  const Model& model = *compiled.model;
  model.validateState(initial_state, "initial_state");
  compiled.data = std::make_unique<Data>(model);
  compiled.initial_state = initial_state;
  State& start = compiled.initial_state;
  // a run starts at t = 0 (reset): driven motion is imposed at that time, not the state's
  start.time = 0.0;
  start.steps = 0;
  const ProjectionReport projection =
      projectPositions(model, *compiled.data, start.time, start.positions,
                       settings.projection_tolerance, settings.projection_max_iterations);
  if (!projection.converged)
  {
    // name the constraint left furthest from holding: it is (one of) those that cannot all hold
    // (named by kind and particles: a scene file's indices differ, its chains' links come first)
    const RowData& rows = compiled.data->rows;
    const RowRecord* worst = nullptr;
    double worst_violation = -1.0;
    for (const RowRecord& record : model.rowRecords())
      for (int r = record.first_row; r < record.first_row + record.rows; ++r)
        if (worst_violation == worst_violation &&  // a NaN row is the worst and stays so
            !(rows.violation[r] <= worst_violation))
        {
          worst_violation = rows.violation[r];
          worst = &record;
        }
    std::string where = "(none)";
    if (worst)
    {
      const Constraint& constraint = scene.constraints[worst->constraint];
      where = std::string("a ") + kindOf(constraint) + " on particles";
      std::visit(
          [&](const auto& c)
          {
            using Kind = std::decay_t<decltype(c)>;
            if constexpr (!Kind::ELIMINATED)
              for (int particle : rowParticles(c))
                where += " " + std::to_string(particle);
          },
          constraint);
    }
    throw InvalidInput("initial_state.positions",
                       "cannot be projected onto the constraints: error " +
                           formatValue(projection.max_position_error) + " m after " +
                           std::to_string(projection.iterations) +
                           " Newton iterations, largest at " + where +
                           "; the constraints may not all hold at once (check lengths, angles "
                           "and anchors against each other)");
  }
  projectVelocities(model, *compiled.data, start.time, start.positions, start.velocities, false,
                    false);
  if (!isFinite(start))
    throw InvalidInput("initial_state.positions",
                       "projection onto the constraints produced a non-finite state");
  return compiled;
}

Simulator::Simulator(const Scene& scene, const State& initial_state, const StepSettings& settings,
                     SolveMethod method)
{
  Compiled compiled = compile(scene, initial_state, settings, method);
  data_.reset();  // the old data refers to the old model: it goes first
  model_ = std::move(compiled.model);
  data_ = std::move(compiled.data);
  initial_state_ = compiled.initial_state;
  settings_ = settings;
  integrator_ = &findIntegrator(settings.integrator);
  diagnostic_rows_.resize(*model_);
  diagnostic_rates_.setZero(model_->numRows());
  reset();
}

StepStatistics Simulator::step(int count)
{
  const Model& model = *model_;
  Data& data = *data_;
  State& x = data.state;
  const EffectCounters before = data.counters;
  data.statistics = StepStatistics{};
  data.statistics.solve.method = model.solveMethod();
  for (int k = 0; k < count; ++k)
  {
    const double end = x.time + settings_.dt;
    integrator_->step(model, data, settings_);
    imposeEliminated(model, data, end, &x.positions, &x.velocities);
    if (!integrator_->holds_constraints && settings_.stabilization == Stabilization::Projection)
    {
      ProjectionReport report =
          projectPositions(model, data, end, x.positions, settings_.projection_tolerance,
                           settings_.projection_max_iterations);
      bool singular = false;
      report.max_velocity_change =
          projectVelocities(model, data, end, x.positions, x.velocities, true, false, &singular);
      report.singular |= singular;
      data.statistics.projection.merge(report);
    }
    x.time = end;
    ++x.steps;
    ++data.statistics.steps;
  }
  data.statistics.effects = data.counters.since(before);
  return data.statistics;
}

void Simulator::reset()
{
  data_->state = initial_state_;
  data_->state.time = 0.0;
  data_->state.steps = 0;
  data_->statistics = StepStatistics{};
}

ProjectionReport Simulator::setState(const State& state)
{
  model_->validateState(state, "");
  State projected = state;
  projected.time = data_->state.time;
  projected.steps = data_->state.steps;
  ProjectionReport report =
      projectPositions(*model_, *data_, projected.time, projected.positions,
                       settings_.projection_tolerance, settings_.projection_max_iterations);
  if (!report.converged)
  {
    throw InvalidInput("positions", "cannot be projected onto the constraints: error " +
                                        formatValue(report.max_position_error) + " m after " +
                                        std::to_string(report.iterations) +
                                        " Newton iterations; state unchanged");
  }
  report.max_velocity_change = projectVelocities(
      *model_, *data_, projected.time, projected.positions, projected.velocities, false, true);
  report.max_displacement = (projected.positions - state.positions).colwise().norm().maxCoeff();
  if (!isFinite(projected))
    throw InvalidInput("positions", "projection produced a non-finite state; state unchanged");
  data_->state = projected;
  return report;
}

void Simulator::restoreState(const State& state)
{
  model_->validateState(state);
  data_->state = state;
}

void Simulator::setScene(const Scene& scene, const State& initial_state, SolveMethod method)
{
  Compiled compiled = compile(scene, initial_state, settings_, method);
  data_.reset();  // the old data refers to the old model: it goes first
  model_ = std::move(compiled.model);
  data_ = std::move(compiled.data);
  initial_state_ = compiled.initial_state;
  diagnostic_rows_.resize(*model_);
  diagnostic_rates_.setZero(model_->numRows());
  reset();
}

void Simulator::setStepSettings(const StepSettings& settings)
{
  validateStepSettings(settings);
  integrator_ = &findIntegrator(settings.integrator);
  settings_ = settings;
}

void Simulator::setForces(const std::vector<Force>& forces)
{
  Scene scene = model_->scene();
  scene.forces = forces;
  auto model = std::make_unique<Model>(Model::compile(scene, model_->solveMethod()));
  auto data = std::make_unique<Data>(*model);
  data->state = data_->state;
  data_.reset();  // the old data refers to the old model: it goes first
  model_ = std::move(model);
  data_ = std::move(data);
}

Diagnostics Simulator::diagnostics() const
{
  return computeDiagnostics(*model_, data_->state, diagnostic_rows_, diagnostic_rates_);
}

void Simulator::constraintForces(Points& forces, Eigen::VectorXd& multipliers)
{
  Data& data = *data_;
  data.stages.p_stage = data.state.positions;
  data.stages.v_stage = data.state.velocities;
  forward(*model_, data, settings_, data.state.time, data.stages.p_stage, data.stages.v_stage,
          data.accelerations);
  forces = data.constraint_forces;
  multipliers = data.multipliers;
}

}  // namespace constrained_particles
