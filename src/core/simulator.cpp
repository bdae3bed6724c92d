#include "constrained_particles/core/simulator.hpp"

#include <string>

namespace constrained_particles
{
Simulator::Compiled Simulator::compile(const Scene& scene, const State& initial_state,
                                       const StepSettings& settings, SolveMethod method)
{
  validateStepSettings(settings);
  Compiled compiled;
  compiled.model = std::make_unique<Model>(Model::compile(scene, method));
  compiled.model->validateState(initial_state, "initial_state");
  compiled.dynamics = std::make_unique<Dynamics>(*compiled.model);
  compiled.initial_state = initial_state;
  ProjectionReport projection = compiled.dynamics->projectPositions(
      compiled.initial_state.positions, settings.projection_tolerance,
      settings.projection_max_iterations);
  if (!projection.converged)
  {
    throw InvalidInput("initial_state.positions",
                       "cannot be projected onto the constraints: error " +
                           formatValue(projection.max_position_error) + " m after " +
                           std::to_string(projection.iterations) + " Newton iterations");
  }
  compiled.dynamics->projectVelocities(compiled.initial_state.positions,
                                       compiled.initial_state.velocities);
  return compiled;
}

Simulator::Simulator(const Scene& scene, const State& initial_state, const StepSettings& settings,
                     SolveMethod method)
{
  Compiled compiled = compile(scene, initial_state, settings, method);
  model_ = std::move(compiled.model);
  dynamics_ = std::move(compiled.dynamics);
  initial_state_ = compiled.initial_state;
  settings_ = settings;
  reset();
}

StepReport Simulator::step(int count)
{
  for (int k = 0; k < count; ++k)
    last_report_ = constrained_particles::step(settings_, state_, *dynamics_);
  return last_report_;
}

void Simulator::reset()
{
  state_ = initial_state_;
  state_.time = 0.0;
  state_.steps = 0;
  last_report_ = StepReport{};
}

ProjectionReport Simulator::setState(const State& state)
{
  model_->validateState(state, "");
  State projected = state;
  ProjectionReport report = dynamics_->projectPositions(
      projected.positions, settings_.projection_tolerance, settings_.projection_max_iterations);
  if (!report.converged)
  {
    throw InvalidInput("positions", "cannot be projected onto the constraints: error " +
                                        formatValue(report.max_position_error) + " m after " +
                                        std::to_string(report.iterations) +
                                        " Newton iterations; state unchanged");
  }
  report.max_velocity_change =
      dynamics_->projectVelocities(projected.positions, projected.velocities);
  report.max_displacement = (projected.positions - state.positions).colwise().norm().maxCoeff();
  if (!isFinite(projected))
    throw InvalidInput("positions", "projection produced a non-finite state; state unchanged");
  projected.time = state_.time;
  projected.steps = state_.steps;
  state_ = projected;
  return report;
}

void Simulator::restoreState(const State& state)
{
  model_->validateState(state);
  state_ = state;
}

void Simulator::setScene(const Scene& scene, const State& initial_state, SolveMethod method)
{
  Compiled compiled = compile(scene, initial_state, settings_, method);
  model_ = std::move(compiled.model);
  dynamics_ = std::move(compiled.dynamics);
  initial_state_ = compiled.initial_state;
  reset();
}

void Simulator::setStepSettings(const StepSettings& settings)
{
  validateStepSettings(settings);
  settings_ = settings;
}

void Simulator::setForces(const std::vector<Force>& forces)
{
  Scene scene = model_->scene();
  scene.forces = forces;
  auto model = std::make_unique<Model>(Model::compile(scene, model_->solveMethod()));
  auto dynamics = std::make_unique<Dynamics>(*model);
  model_ = std::move(model);
  dynamics_ = std::move(dynamics);
}

void Simulator::constraintForces(Points& forces, Eigen::VectorXd& multipliers)
{
  const bool baumgarte = settings_.stabilization == Stabilization::Baumgarte;
  const double omega = baumgarte ? 2.0 * M_PI * settings_.baumgarte_frequency : 0.0;
  Points accelerations(3, model_->numParticles());
  dynamics_->computeAccelerations(state_.positions, state_.velocities, omega,
                                  settings_.baumgarte_damping_ratio, accelerations);
  forces = dynamics_->constraintForces();
  multipliers = dynamics_->multipliers();
}

}  // namespace constrained_particles
