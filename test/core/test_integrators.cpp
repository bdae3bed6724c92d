// Integrators against a closed-form motion: ordering of accuracy at a fixed step, observed
// convergence orders, and what the symplectic and adaptive methods promise.
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using namespace constrained_particles;

namespace
{
constexpr double G = 9.81;
constexpr double CURVATURE = 1.5;  // bowl Z = k r^2 / 2 [1/m]
constexpr double RADIUS = 0.4;     // [m]

// A bead on a circular orbit in a bowl: speed sqrt(g k) r, angular rate sqrt(g k).
struct Orbit
{
  Scene scene;
  State start;
  double omega = std::sqrt(G * CURVATURE);

  Orbit()
  {
    scene =
        constrained_particles::testing::beadScene(makeSurface("bowl", { CURVATURE, CURVATURE }));
    start.positions = Vec3(RADIUS, 0, 0.5 * CURVATURE * RADIUS * RADIUS);
    start.velocities = Vec3(0, omega * RADIUS, 0);
  }

  Vec3 exact(double t) const
  {
    return Vec3(RADIUS * std::cos(omega * t), RADIUS * std::sin(omega * t),
                0.5 * CURVATURE * RADIUS * RADIUS);
  }
};

// position error at t = 1 s
double orbitError(const std::string& integrator, Stabilization stabilization, double dt,
                  double tolerance = 1e-8)
{
  const Orbit orbit;
  StepSettings settings;
  settings.dt = dt;
  settings.integrator = integrator;
  settings.stabilization = stabilization;
  settings.adaptive_tolerance = tolerance;
  Simulator simulator(orbit.scene, orbit.start, settings);
  const int steps = static_cast<int>(std::lround(1.0 / dt));
  simulator.step(steps);
  return (Vec3(simulator.state().positions.col(0)) - orbit.exact(simulator.state().time)).norm();
}

}  // namespace

TEST(Integrators, AccuracyOrderingAtFixedStep)
{
  for (Stabilization stabilization :
       { Stabilization::None, Stabilization::Baumgarte, Stabilization::Projection })
  {
    const double dt = 1e-2;
    const double euler = orbitError("explicit_euler", stabilization, dt);
    const double midpoint = orbitError("midpoint", stabilization, dt);
    const double rk4 = orbitError("rk4", stabilization, dt);
    const double dopri = orbitError("dopri5", stabilization, dt, 1e-11);
    const double verlet = orbitError("velocity_verlet", stabilization, dt);
    const std::string name = stabilizationName(stabilization);
    EXPECT_LT(rk4, midpoint) << name;
    EXPECT_LT(midpoint, euler) << name;
    EXPECT_LT(verlet, euler) << name;
    EXPECT_LT(dopri, rk4) << name;
  }
}

// err(dt) / err(dt/2) = 2^order in the asymptotic range, the order the table declares, for every
// row of the table with no per-integrator setting: dt is halved from 0.05 s and the finest pair
// whose error is still far above round-off is taken. An adaptive integrator is measured at the
// loosest tolerance, where it takes dt as its one internal step (checked), as a fixed-step one.
TEST(Integrators, ObservedOrdersMatchTheTable)
{
  const double FLOOR = 1e-12;  // [m]: errors below this are not read (round-off is ~1e-14)
  const double LOOSEST = limits::ADAPTIVE_TOLERANCE.high;
  for (const IntegratorInfo* integrator : integratorTable())
  {
    std::vector<double> dts, errors;
    for (double dt = 0.05; dt > 1e-4; dt /= 2)
    {
      const Orbit orbit;
      StepSettings settings;
      settings.dt = dt;
      settings.integrator = integrator->name;
      settings.stabilization = Stabilization::None;
      settings.adaptive_tolerance = LOOSEST;
      Simulator simulator(orbit.scene, orbit.start, settings);
      const long steps = std::lround(1.0 / dt);
      const StepStatistics statistics = simulator.step(static_cast<int>(steps));
      if (integrator->adaptive)
      {
        ASSERT_EQ(statistics.internal_steps, steps) << integrator->name << ", dt = " << dt;
      }
      dts.push_back(dt);
      errors.push_back(
          (Vec3(simulator.state().positions.col(0)) - orbit.exact(simulator.state().time)).norm());
    }
    int pair = -1;  // the finest (coarse, fine) pair above the floor
    for (std::size_t k = 0; k + 1 < errors.size(); ++k)
      if (errors[k + 1] > FLOOR)
        pair = static_cast<int>(k);
    ASSERT_GE(pair, 2) << integrator->name << ": too few steps above round-off to see the order";
    const double observed = std::log2(errors[pair] / errors[pair + 1]);
    EXPECT_NEAR(observed, integrator->order, 0.3)
        << integrator->name << " at dt = " << dts[pair] << " s: errors " << errors[pair] << ", "
        << errors[pair + 1] << " m";
  }
}

// velocity Verlet (SHAKE/RATTLE) holds every constraint to tolerance after every step, and its
// energy error does not grow: a 10-link pendulum, first and second half of a 20 s run
TEST(Integrators, VelocityVerletHoldsConstraintsWithoutEnergyDrift)
{
  const int n = 11;
  const Scene scene = constrained_particles::testing::pinnedChain(std::vector<double>(n, 0.2), 0.1);
  State start;
  start.positions.resize(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
    start.positions.col(i) = Vec3(0.1 * i * std::sin(0.5), 0, -0.1 * i * std::cos(0.5));
  StepSettings settings;
  settings.dt = 1e-3;
  settings.integrator = "velocity_verlet";
  settings.stabilization = Stabilization::None;  // ignored by velocity Verlet
  Simulator simulator(scene, start, settings);
  const double e0 = simulator.diagnostics().totalEnergy();
  double first_half = 0, second_half = 0, worst_constraint = 0;
  for (int k = 0; k < 20000; ++k)
  {
    simulator.step();
    const Diagnostics d = simulator.diagnostics();
    worst_constraint = std::max(worst_constraint, d.max_position_error);
    (k < 10000 ? first_half : second_half) =
        std::max(k < 10000 ? first_half : second_half, std::abs(d.totalEnergy() - e0));
  }
  EXPECT_LE(worst_constraint, settings.projection_tolerance);
  EXPECT_LT(first_half, 1e-2 * std::abs(e0) + 1e-3);
  EXPECT_LT(second_half, 2.0 * first_half);
}

TEST(Integrators, DormandPrinceTakesMoreStepsForTighterTolerance)
{
  const Orbit orbit;
  auto internal_steps = [&](double tolerance)
  {
    StepSettings settings;
    settings.dt = 0.1;
    settings.integrator = "dopri5";
    settings.stabilization = Stabilization::None;
    settings.adaptive_tolerance = tolerance;
    Simulator simulator(orbit.scene, orbit.start, settings);
    return simulator.step().internal_steps;
  };
  EXPECT_GT(internal_steps(1e-12), internal_steps(1e-4));
  EXPECT_LT(orbitError("dopri5", Stabilization::None, 0.1, 1e-12), 1e-9);
}
