#include "constrained_particles/core/dynamics.hpp"

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
namespace
{
const char* const INTEGRATOR_NAMES[] = { "explicit_euler", "semi_implicit_euler", "rk4" };
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
    case Integrator::RK4:
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
  applied_forces_.setZero();
  for (const Force& force : scene.forces)
    std::visit([&](const auto& f)
               { accumulateForce(f, scene.masses, velocities, applied_forces_); },
               force);

  // (J W J^T) lambda = -(Jdot v + J W f) - (2 zeta omega Cdot + omega^2 C)
  SolveReport report;
  constraint_forces_.setZero();
  if (m > 0)
  {
    solver_.evaluate(positions, velocities);
    report = solver_.factorize();
    solver_.multiplyJacobianInverseMass(applied_forces_, rhs_);
    const auto& rows = solver_.rows();
    const double stiffness = baumgarte_omega * baumgarte_omega;
    const double damping = 2.0 * baumgarte_zeta * baumgarte_omega;
    for (int r = 0; r < m; ++r)
    {
      double b = -(rows[r].jdot_v + rhs_[r]);
      if (baumgarte_omega > 0.0)
      {
        const ConstraintRow& row = rows[r];
        double c_dot = row.gradient[0].dot(velocities.col(row.particle[0]));
        if (row.particle[1] >= 0)
          c_dot += row.gradient[1].dot(velocities.col(row.particle[1]));
        b -= damping * c_dot + stiffness * row.value;
      }
      rhs_[r] = b;
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
    const int i = std::get<PinConstraint>(scene.constraints[pins[k]]).particle;
    const Vec3 reaction = -(applied_forces_.col(i) + constraint_forces_.col(i));
    constraint_forces_.col(i) += reaction;
    multipliers_.segment<3>(m + 3 * static_cast<int>(k)) = reaction;
    accelerations.col(i).setZero();
  }
  return report;
}

void Dynamics::applyPins(Points& positions, Points* velocities) const
{
  const Scene& scene = solver_.model().scene();
  for (int k : solver_.model().pins())
  {
    const PinConstraint& pin = std::get<PinConstraint>(scene.constraints[k]);
    positions.col(pin.particle) = pin.anchor;
    if (velocities)
      velocities->col(pin.particle).setZero();
  }
}

ProjectionReport Dynamics::projectPositions(Points& positions, double tolerance, int max_iterations)
{
  ProjectionReport report;
  const Points original = positions;
  applyPins(positions, nullptr);
  const int m = solver_.model().numRows();
  report.converged = true;
  if (m > 0)
  {
    report.converged = false;
    for (int iteration = 0;; ++iteration)
    {
      solver_.evaluate(positions, zero_velocities_);
      const auto& rows = solver_.rows();
      double max_error = 0.0;
      for (int r = 0; r < m; ++r)
      {
        // NaN compares false: treat it as not converged
        if (!(rows[r].metric_error <= max_error))
          max_error = std::isnan(rows[r].metric_error) ? INFINITY : rows[r].metric_error;
      }
      report.max_position_error = max_error;
      if (max_error <= tolerance)
      {
        report.converged = true;
        break;
      }
      if (iteration >= max_iterations || !std::isfinite(max_error))
        break;
      // dp = -W J^T (J W J^T)^-1 C
      report.singular |= solver_.factorize().singular;
      for (int r = 0; r < m; ++r)
        rhs_[r] = rows[r].value;
      solver_.solveInPlace(rhs_);
      solver_.addInverseMassJacobianTranspose(rhs_, -1.0, positions);
      report.iterations = iteration + 1;
    }
  }
  report.max_displacement = (positions - original).colwise().norm().maxCoeff();
  return report;
}

double Dynamics::projectVelocities(const Points& positions, Points& velocities, bool* singular)
{
  const Points original = velocities;
  Points pinned_positions = positions;
  applyPins(pinned_positions, &velocities);
  if (solver_.model().numRows() > 0)
  {
    // dv = -W J^T (J W J^T)^-1 J v
    solver_.evaluate(positions, velocities);
    const bool was_singular = solver_.factorize().singular;
    if (singular)
      *singular = was_singular;
    solver_.multiplyJacobian(velocities, rhs_);
    solver_.solveInPlace(rhs_);
    solver_.addInverseMassJacobianTranspose(rhs_, -1.0, velocities);
  }
  return (velocities - original).colwise().norm().maxCoeff();
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
  auto accelerations = [&](const Points& pos, const Points& vel, Points& acc)
  { mergeReport(report.solve, dynamics.computeAccelerations(pos, vel, omega, zeta, acc)); };

  switch (settings.integrator)
  {
    case Integrator::ExplicitEuler:
    case Integrator::SemiImplicitEuler:
    {
      Points a(3, n);
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
    case Integrator::RK4:
    {
      Points a1(3, n), a2(3, n), a3(3, n), a4(3, n);
      accelerations(p, v, a1);
      const Points v2 = v + 0.5 * dt * a1;
      accelerations(p + 0.5 * dt * v, v2, a2);
      const Points v3 = v + 0.5 * dt * a2;
      accelerations(p + 0.5 * dt * v2, v3, a3);
      const Points v4 = v + dt * a3;
      accelerations(p + dt * v3, v4, a4);
      p += (dt / 6.0) * (v + 2.0 * v2 + 2.0 * v3 + v4);
      v += (dt / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
      break;
    }
  }

  if (settings.stabilization == Stabilization::Projection)
  {
    report.projection = dynamics.projectPositions(p, settings.projection_tolerance,
                                                  settings.projection_max_iterations);
    bool singular = false;
    report.projection.max_velocity_change = dynamics.projectVelocities(p, v, &singular);
    report.projection.singular |= singular;
  }
  state.time += dt;
  ++state.steps;
  return report;
}

}  // namespace constrained_particles
