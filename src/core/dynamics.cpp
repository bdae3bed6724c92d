#include "constrained_particles/core/dynamics.hpp"

#include <boost/numeric/odeint.hpp>

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
namespace
{
const char* const INTEGRATOR_NAMES[] = { "explicit_euler",  "semi_implicit_euler",
                                         "midpoint",        "rk4",
                                         "velocity_verlet", "dopri5" };
const char* const STABILIZATION_NAMES[] = { "none", "baumgarte", "projection" };

template <typename Enum, std::size_t N>
Enum parseName(const std::string& name, const char* const (&names)[N], const std::string& field)
{
  for (std::size_t i = 0; i < N; ++i)
    if (name == names[i])
      return static_cast<Enum>(i);
  std::string valid;
  for (std::size_t i = 0; i < N; ++i)
    valid += std::string(i ? ", " : "") + names[i];
  throw InvalidInput(field, "= '" + name + "' is unknown; valid: " + valid);
}

void requireRange(const std::string& field, double value, double low, bool low_exclusive,
                  double high, const std::string& unit)
{
  const bool below = low_exclusive ? !(value > low) : !(value >= low);
  if (!std::isfinite(value) || below || value > high)
  {
    throw InvalidInput(field, "= " + formatValue(value) + ", must be in " +
                                  (low_exclusive ? "(" : "[") + formatValue(low) + ", " +
                                  formatValue(high) + "] " + unit);
  }
}

}  // namespace

const char* integratorName(Integrator integrator)
{
  return INTEGRATOR_NAMES[static_cast<int>(integrator)];
}

const char* stabilizationName(Stabilization stabilization)
{
  return STABILIZATION_NAMES[static_cast<int>(stabilization)];
}

Integrator parseIntegrator(const std::string& name, const std::string& field)
{
  return parseName<Integrator>(name, INTEGRATOR_NAMES, field);
}

Stabilization parseStabilization(const std::string& name, const std::string& field)
{
  return parseName<Stabilization>(name, STABILIZATION_NAMES, field);
}

std::vector<std::string> integratorNames()
{
  return { std::begin(INTEGRATOR_NAMES), std::end(INTEGRATOR_NAMES) };
}

std::vector<std::string> stabilizationNames()
{
  return { std::begin(STABILIZATION_NAMES), std::end(STABILIZATION_NAMES) };
}

void validateStepSettings(const StepSettings& settings)
{
  requireRange("dt", settings.dt, 0.0, true, 1.0, "[s]");
  switch (settings.integrator)
  {
    case Integrator::ExplicitEuler:
    case Integrator::SemiImplicitEuler:
    case Integrator::Midpoint:
    case Integrator::RK4:
    case Integrator::VelocityVerlet:
    case Integrator::DormandPrince:
      break;
    default:
      throw InvalidInput("integrator", "is not a known integrator");
  }
  switch (settings.stabilization)
  {
    case Stabilization::None:
    case Stabilization::Baumgarte:
    case Stabilization::Projection:
      break;
    default:
      throw InvalidInput("stabilization", "is not a known stabilization");
  }
  requireRange("baumgarte_frequency", settings.baumgarte_frequency, 0.0, true, 1e4, "[Hz]");
  requireRange("baumgarte_damping_ratio", settings.baumgarte_damping_ratio, 0.0, false, 100.0,
               "[1]");
  requireRange("projection_tolerance", settings.projection_tolerance, 0.0, true, 1.0, "[m]");
  requireRange("projection_max_iterations", settings.projection_max_iterations, 1.0, false, 1000.0,
               "[1]");
}

Dynamics::Dynamics(const Model& model) : solver_(model)
{
  const int n = model.numParticles();
  rhs_.setZero(model.numRows());
  multipliers_.setZero(model.numMultipliers());
  applied_forces_.setZero(3, n);
  constraint_forces_.setZero(3, n);
  zero_velocities_.setZero(3, n);
  for (Points& scratch : scratch_)
    scratch.setZero(3, n);
}

const Points& Dynamics::computeAppliedForces(const Points& positions, const Points& velocities)
{
  const Scene& scene = solver_.model().scene();
  applied_forces_.setZero();
  EffectCounters& counters = solver_.counters();
  for (const Force& force : scene.forces)
  {
    accumulateForce(force, scene.masses, positions, velocities, applied_forces_);
    ++counters.forces[force.index()];
  }
  return applied_forces_;
}

SolveReport Dynamics::computeAccelerations(const Points& positions, const Points& velocities,
                                           double baumgarte_omega, double baumgarte_zeta,
                                           Points& accelerations)
{
  const Model& model = solver_.model();
  const Scene& scene = model.scene();
  const auto& w = model.inverseMasses();
  const int m = model.numRows();

  // applied forces: only those the scene lists
  computeAppliedForces(positions, velocities);

  // (J W J^T) lambda = -(Jdot v + J W f) - (2 zeta omega Cdot + omega^2 C)
  SolveReport report;
  constraint_forces_.setZero();
  if (m > 0)
  {
    solver_.evaluate(positions, velocities);
    report = solver_.factorize();
    solver_.multiplyJacobianInverseMass(applied_forces_, rhs_);
    rhs_ = -(solver_.jdotV() + rhs_);
    if (baumgarte_omega > 0.0)
    {
      const auto& rows = solver_.rows();
      const double stiffness = baumgarte_omega * baumgarte_omega;
      const double damping = 2.0 * baumgarte_zeta * baumgarte_omega;
      for (int r = 0; r < m; ++r)
      {
        const ConstraintRow& row = rows[r];
        Vec3 relative = velocities.col(row.particle[0]);
        if (row.particle[1] >= 0)
          relative -= velocities.col(row.particle[1]);
        const double c_dot = row.gradient.dot(relative);
        rhs_[r] -= damping * c_dot + stiffness * row.value;
      }
    }
    solver_.solveInPlace(rhs_);
    multipliers_.head(m) = rhs_;
    solver_.addJacobianTranspose(rhs_, constraint_forces_);
  }

  // a = W (f + f_c); a pin's reaction cancels everything else on its particle
  const int n = model.numParticles();
  for (int i = 0; i < n; ++i)
    accelerations.col(i) = w[i] * (applied_forces_.col(i) + constraint_forces_.col(i));
  const auto& pins = model.pins();
  for (std::size_t k = 0; k < pins.size(); ++k)
  {
    const Constraint& pin = scene.constraints[pins[k]];
    ++solver_.counters().constraints[pin.index()];
    const int i = std::get<PinConstraint>(pin).particle;
    const Vec3 reaction = -(applied_forces_.col(i) + constraint_forces_.col(i));
    constraint_forces_.col(i) += reaction;
    multipliers_.segment<3>(m + 3 * static_cast<int>(k)) = reaction;
    accelerations.col(i).setZero();
  }
  return report;
}

void Dynamics::applyPins(Points& positions)
{
  const Scene& scene = solver_.model().scene();
  for (int k : solver_.model().pins())
  {
    const PinConstraint& pin = std::get<PinConstraint>(scene.constraints[k]);
    positions.col(pin.particle) = pin.anchor;
    ++solver_.counters().constraints[scene.constraints[k].index()];
  }
}

void Dynamics::pinVelocities(Points& velocities)
{
  const Scene& scene = solver_.model().scene();
  for (int k : solver_.model().pins())
  {
    velocities.col(std::get<PinConstraint>(scene.constraints[k]).particle).setZero();
    ++solver_.counters().constraints[scene.constraints[k].index()];
  }
}

ProjectionReport Dynamics::projectPositions(Points& positions, double tolerance, int max_iterations)
{
  ProjectionReport report;
  applyPins(positions);
  const int m = solver_.model().numRows();
  for (int iteration = 0; m > 0; ++iteration)
  {
    solver_.evaluate(positions, zero_velocities_);
    report.max_position_error = solver_.maxPositionError();
    report.converged = report.max_position_error <= tolerance;
    if (report.converged || iteration >= max_iterations ||
        !std::isfinite(report.max_position_error))
      break;
    // dp = -W J^T (J W J^T)^-1 C
    report.singular |= solver_.factorize().singular;
    rhs_ = solver_.values();
    solver_.solveInPlace(rhs_);
    solver_.addInverseMassJacobianTranspose(rhs_, -1.0, positions);
    report.iterations = iteration + 1;
  }
  return report;
}

ProjectionReport Dynamics::shakePositions(const Points& reference, Points& positions,
                                          double tolerance, int max_iterations, Points* corrections)
{
  ProjectionReport report;
  applyPins(positions);
  const Model& model = solver_.model();
  const int m = model.numRows();
  if (m == 0)
    return report;
  // directions W J(reference)^T stay fixed; J W J^T at the reference approximates the Jacobian
  solver_.evaluate(reference, zero_velocities_);
  report.singular = solver_.factorize().singular;
  for (int iteration = 0;; ++iteration)
  {
    evaluateRows(model, positions, zero_velocities_, trial_rows_);
    report.max_position_error = maxPositionError(trial_rows_);
    report.converged = report.max_position_error <= tolerance;
    if (report.converged || iteration >= max_iterations ||
        !std::isfinite(report.max_position_error))
      break;
    for (int r = 0; r < m; ++r)
      rhs_[r] = trial_rows_[r].value;
    solver_.solveInPlace(rhs_);
    solver_.addInverseMassJacobianTranspose(rhs_, -1.0, positions);
    if (corrections)
      solver_.addInverseMassJacobianTranspose(rhs_, -1.0, *corrections);
    report.iterations = iteration + 1;
  }
  if (!report.converged && std::isfinite(report.max_position_error))
  {
    const int shake_iterations = report.iterations;
    Points& before = scratch_[NUM_SCRATCH - 1];
    if (corrections)
      before = positions;
    report = projectPositions(positions, tolerance, max_iterations);
    report.iterations += shake_iterations;
    if (corrections)
      *corrections += positions - before;
  }
  return report;
}

double Dynamics::projectVelocities(const Points& positions, Points& velocities, bool* singular,
                                   bool rows_current, bool measure_change)
{
  // the change is J^T-shaped: track its size through the multipliers, not a copy of v
  pinVelocities(velocities);
  if (solver_.model().numRows() == 0)
    return 0.0;
  // dv = -W J^T (J W J^T)^-1 J v; only J is needed, not Jdot v
  if (!rows_current)
    solver_.evaluate(positions, velocities);
  const bool was_singular = solver_.factorize().singular;
  if (singular)
    *singular = was_singular;
  solver_.multiplyJacobian(velocities, rhs_);
  solver_.solveInPlace(rhs_);
  if (!measure_change)
  {
    solver_.addInverseMassJacobianTranspose(rhs_, -1.0, velocities);
    return 0.0;
  }
  Points& change = scratch_[NUM_SCRATCH - 1];
  change.setZero();
  solver_.addInverseMassJacobianTranspose(rhs_, -1.0, change);
  velocities += change;
  return change.colwise().norm().maxCoeff();
}

namespace
{
// keeps the worst of two factorisation reports
void mergeReport(SolveReport& into, const SolveReport& from)
{
  into.method = from.method;
  into.singular |= from.singular;
  into.min_pivot_ratio = std::min(into.min_pivot_ratio, from.min_pivot_ratio);
  into.regularization = std::max(into.regularization, from.regularization);
}

using OdeState = std::vector<double>;

}  // namespace

StepReport step(const StepSettings& settings, State& state, Dynamics& dynamics)
{
  StepReport report;
  const double dt = settings.dt;
  const bool baumgarte = settings.stabilization == Stabilization::Baumgarte;
  const double omega = baumgarte ? 2.0 * M_PI * settings.baumgarte_frequency : 0.0;
  const double zeta = settings.baumgarte_damping_ratio;
  Points& p = state.positions;
  Points& v = state.velocities;
  const int n = static_cast<int>(p.cols());
  const auto& w = dynamics.model().inverseMasses();
  auto accelerations = [&](const Points& pos, const Points& vel, Points& acc)
  { mergeReport(report.solve, dynamics.computeAccelerations(pos, vel, omega, zeta, acc)); };

  bool project = settings.stabilization == Stabilization::Projection;
  switch (settings.integrator)
  {
    case Integrator::ExplicitEuler:
    case Integrator::SemiImplicitEuler:
    {
      Points& a = dynamics.scratch(0);
      accelerations(p, v, a);
      if (settings.integrator == Integrator::ExplicitEuler)
      {
        p += dt * v;
        v += dt * a;
      }
      else
      {
        // symplectic: the position update uses the new velocity
        v += dt * a;
        p += dt * v;
      }
      break;
    }
    case Integrator::Midpoint:
    {
      Points& a1 = dynamics.scratch(0);
      Points& a2 = dynamics.scratch(1);
      Points& p_mid = dynamics.scratch(2);
      Points& v_mid = dynamics.scratch(3);
      accelerations(p, v, a1);
      p_mid = p + 0.5 * dt * v;
      v_mid = v + 0.5 * dt * a1;
      accelerations(p_mid, v_mid, a2);
      p += dt * v_mid;
      v += dt * a2;
      break;
    }
    case Integrator::RK4:
    {
      Points& a1 = dynamics.scratch(0);
      Points& a2 = dynamics.scratch(1);
      Points& a3 = dynamics.scratch(2);
      Points& a4 = dynamics.scratch(3);
      Points& v2 = dynamics.scratch(4);
      Points& v3 = dynamics.scratch(5);
      Points& trial = dynamics.scratch(6);
      accelerations(p, v, a1);
      v2 = v + 0.5 * dt * a1;
      trial = p + 0.5 * dt * v;
      accelerations(trial, v2, a2);
      v3 = v + 0.5 * dt * a2;
      trial = p + 0.5 * dt * v2;
      accelerations(trial, v3, a3);
      trial = p + dt * v3;
      Points& v4 = dynamics.scratch(7);
      v4 = v + dt * a3;
      accelerations(trial, v4, a4);
      p += (dt / 6.0) * (v + 2.0 * v2 + 2.0 * v3 + v4);
      v += (dt / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
      break;
    }
    case Integrator::VelocityVerlet:
    {
      // kick with applied forces, drift, SHAKE onto C = 0 (the constraint impulse), kick,
      // RATTLE onto J v = 0
      Points& p_old = dynamics.scratch(0);
      p_old = p;
      const Points& f_start = dynamics.computeAppliedForces(p, v);
      for (int i = 0; i < n; ++i)
        v.col(i) += (0.5 * dt * w[i]) * f_start.col(i);
      p += dt * v;
      // v_n+1/2 = (p_n+1 - p_n) / dt, formed as v + correction / dt: subtracting positions
      // would turn their round-off into a velocity error that grows like 1 / dt
      Points& correction = dynamics.scratch(1);
      correction.setZero();
      report.projection = dynamics.shakePositions(p_old, p, settings.projection_tolerance,
                                                  settings.projection_max_iterations, &correction);
      v += correction / dt;
      const Points& f_end = dynamics.computeAppliedForces(p, v);
      for (int i = 0; i < n; ++i)
        v.col(i) += (0.5 * dt * w[i]) * f_end.col(i);
      bool singular = false;
      report.projection.max_velocity_change = dynamics.projectVelocities(p, v, &singular);
      report.projection.singular |= singular;
      project = false;
      break;
    }
    case Integrator::DormandPrince:
    {
      namespace odeint = boost::numeric::odeint;
      OdeState x(6 * n);
      Eigen::Map<Points>(x.data(), 3, n) = p;
      Eigen::Map<Points>(x.data() + 3 * n, 3, n) = v;
      Points& pos = dynamics.scratch(0);
      Points& vel = dynamics.scratch(1);
      Points& acc = dynamics.scratch(2);
      auto system = [&](const OdeState& y, OdeState& dydt, double)
      {
        pos = Eigen::Map<const Points>(y.data(), 3, n);
        vel = Eigen::Map<const Points>(y.data() + 3 * n, 3, n);
        accelerations(pos, vel, acc);
        Eigen::Map<Points>(dydt.data(), 3, n) = vel;
        Eigen::Map<Points>(dydt.data() + 3 * n, 3, n) = acc;
      };
      auto stepper =
          odeint::make_controlled(settings.adaptive_tolerance, settings.adaptive_tolerance,
                                  odeint::runge_kutta_dopri5<OdeState>());
      report.internal_steps = static_cast<int>(
          odeint::integrate_adaptive(stepper, system, x, state.time, state.time + dt, dt));
      p = Eigen::Map<const Points>(x.data(), 3, n);
      v = Eigen::Map<const Points>(x.data() + 3 * n, 3, n);
      break;
    }
  }

  if (project)
  {
    report.projection = dynamics.projectPositions(p, settings.projection_tolerance,
                                                  settings.projection_max_iterations);
    bool singular = false;
    report.projection.max_velocity_change =
        dynamics.projectVelocities(p, v, &singular, true, false);
    report.projection.singular |= singular;
  }
  state.time += dt;
  ++state.steps;
  return report;
}

}  // namespace constrained_particles
