/// @file dynamics.hpp
/// @brief Constraint forces, integrators, stabilisation and projection.
///
/// Witkin's formulation: with W = M^-1 and applied forces f,
///   (J W J^T) lambda = -(Jdot v + J W f) - (2 zeta omega Cdot + omega^2 C)   [Baumgarte term
///   only when selected], f_c = J^T lambda, a = W (f + f_c).
#pragma once

#include "constrained_particles/core/constraint_solver.hpp"
#include "constrained_particles/core/model.hpp"

#include <array>
#include <string>
#include <vector>

namespace constrained_particles
{
/// Time integrators. A switch over this enum errors on unknown values.
enum class Integrator
{
  ExplicitEuler,      ///< p += dt v, v += dt a(p, v): first order, energy grows
  SemiImplicitEuler,  ///< v += dt a(p, v), p += dt v: first order, symplectic
  Midpoint,           ///< explicit midpoint (RK2): second order
  RK4,                ///< classical Runge-Kutta, fourth order
  VelocityVerlet,     ///< velocity Verlet with SHAKE/RATTLE projections: second order,
                      ///< symplectic, constraints held to projection_tolerance every step;
                      ///< ignores `stabilization`
  DormandPrince,      ///< adaptive Dormand-Prince 5(4) (Boost.Odeint) within each dt, error
                      ///< per internal step <= adaptive_tolerance
};

/// Constraint drift correction.
enum class Stabilization
{
  None,        ///< Cddot = 0 only: C drifts
  Baumgarte,   ///< Cddot + 2 zeta omega Cdot + omega^2 C = 0
  Projection,  ///< after each step: Newton projection of p onto C = 0, then of v onto J v = 0
};

const char* integratorName(Integrator integrator);
const char* stabilizationName(Stabilization stabilization);
/// @throws InvalidInput naming field and the valid names
Integrator parseIntegrator(const std::string& name, const std::string& field = "integrator");
/// @throws InvalidInput naming field and the valid names
Stabilization parseStabilization(const std::string& name,
                                 const std::string& field = "stabilization");
std::vector<std::string> integratorNames();
std::vector<std::string> stabilizationNames();

/// How to take one step. Defaults are a good general choice.
struct StepSettings
{
  double dt = 1e-3;                                         ///< time step [s], in (0, 1]
  Integrator integrator = Integrator::RK4;                  ///< time integrator
  Stabilization stabilization = Stabilization::Projection;  ///< drift correction
  double baumgarte_frequency = 10.0;                        ///< f [Hz], omega = 2 pi f; in (0, 1e4]
  double baumgarte_damping_ratio = 1.0;                     ///< zeta [1], in [0, 100]
  double projection_tolerance = 1e-10;  ///< max position error after projection [m], > 0
  int projection_max_iterations = 20;   ///< Newton iterations per projection, in [1, 1000]
  double adaptive_tolerance = 1e-8;     ///< dopri5 absolute and relative tolerance, (0, 1]
};

/// @throws InvalidInput naming the first bad field and its valid range
void validateStepSettings(const StepSettings& settings);

/// Outcome of a projection of a state onto the constraints.
struct ProjectionReport
{
  int iterations = 0;              ///< Newton iterations taken
  bool converged = true;           ///< max position error <= tolerance
  double max_position_error = 0;   ///< after projection [m]
  double max_displacement = 0;     ///< largest distance a particle moved [m]
  double max_velocity_change = 0;  ///< largest velocity change of a particle [m/s]
  bool singular = false;           ///< J W J^T was singular during the projection
};

/// Acceleration function and workspace for one model.
class Dynamics
{
public:
  explicit Dynamics(const Model& model);

  const Model& model() const
  {
    return solver_.model();
  }

  /// Computes a = W (f + J^T lambda) at (p, v) [m/s^2], pinned particles 0.
  /// Fills multipliers(), constraintForces() and appliedForces().
  /// @param baumgarte_omega omega [rad/s] (0: no Baumgarte term)
  /// @param baumgarte_zeta damping ratio zeta [1]
  SolveReport computeAccelerations(const Points& positions, const Points& velocities,
                                   double baumgarte_omega, double baumgarte_zeta,
                                   Points& accelerations);

  /// One multiplier per row, then the reaction [N] of each pin (3 values).
  const Eigen::VectorXd& multipliers() const
  {
    return multipliers_;
  }
  /// Total constraint force on each particle [N] (pinned: links plus pin reaction).
  const Points& constraintForces() const
  {
    return constraint_forces_;
  }
  /// Applied forces at the last evaluation [N].
  const Points& appliedForces() const
  {
    return applied_forces_;
  }

  /// Moves positions onto C = 0 by Newton steps dp = -W J^T (J W J^T)^-1 C; pins exact.
  ProjectionReport projectPositions(Points& positions, double tolerance, int max_iterations);
  /// Removes the constraint-violating velocity: dv = -W J^T (J W J^T)^-1 J v; pins at rest.
  /// @return largest velocity change [m/s]
  /// @param rows_current the solver's rows were last evaluated at these positions (as
  /// projectPositions() leaves them): skip evaluating them again
  /// @param measure_change compute the return value (else 0: saves a pass over the particles)
  double projectVelocities(const Points& positions, Points& velocities, bool* singular = nullptr,
                           bool rows_current = false, bool measure_change = true);

  /// SHAKE: moves positions onto C = 0 along the fixed directions W J(reference)^T (the
  /// constraint forces of a step that started at `reference`), falling back to
  /// projectPositions() if that does not converge in max_iterations.
  /// @param corrections if given, the displacement SHAKE applies is added to it, summed from the
  /// small corrections themselves (no cancellation against the positions)
  ProjectionReport shakePositions(const Points& reference, Points& positions, double tolerance,
                                  int max_iterations, Points* corrections = nullptr);

  /// Applied forces alone at positions p and velocities v [N] (no constraint solve).
  const Points& computeAppliedForces(const Points& positions, const Points& velocities);

  ConstraintSolver& solver()
  {
    return solver_;
  }
  /// How often each force, constraint and solve was evaluated since construction.
  const EffectCounters& counters() const
  {
    return solver_.counters();
  }

  /// Scratch arrays of 3 x n for the integrators, so a step allocates nothing.
  Points& scratch(int index)
  {
    return scratch_[index];
  }
  static constexpr int NUM_SCRATCH = 8;

private:
  void applyPins(Points& positions);
  void pinVelocities(Points& velocities);

  ConstraintSolver solver_;
  Eigen::VectorXd rhs_, multipliers_;
  Points applied_forces_, constraint_forces_, zero_velocities_;
  std::vector<ConstraintRow> trial_rows_;
  std::array<Points, NUM_SCRATCH> scratch_;
};

/// Outcome of one step.
struct StepReport
{
  SolveReport solve;            ///< worst factorisation of the step (singular if any was)
  ProjectionReport projection;  ///< when stabilization is Projection, or VelocityVerlet
  int internal_steps = 1;       ///< DormandPrince: accepted internal steps within dt
};

/// Advances the state by settings.dt with the chosen integrator and stabilisation.
/// Assumes model, state and settings were validated.
StepReport step(const StepSettings& settings, State& state, Dynamics& dynamics);

}  // namespace constrained_particles
