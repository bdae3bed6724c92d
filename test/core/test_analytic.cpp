// Analytic cases from physics.md, closed-form motions, and the energy ordering of integrators.
#include "constrained_particles/core/simulator.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

using namespace constrained_particles;
using constrained_particles::testing::beadScene;
using constrained_particles::testing::computeAccelerations;
using constrained_particles::testing::G;
using constrained_particles::testing::stateOf;

// Plane z = a x from rest: xddot = -g a / (1 + a^2), |normal force| = m g / sqrt(1 + a^2).
TEST(Analytic, BeadSlidesDownPlane)
{
  for (double a : { 0.1, 0.5, 2.0 })
  {
    const double m = 2.5;
    const Scene scene = beadScene(makeSurface("plane", { a, 0.0, 0.0 }), m);
    Points p(3, 1), v = Points::Zero(3, 1);
    p.col(0) = Vec3(1.0, 0.3, a * 1.0);
    const Model model = Model::compile(scene);
    Data data(model);
    Points acc(3, 1);
    computeAccelerations(model, data, p, v, acc);
    const double expected_xddot = -G * a / (1 + a * a);
    EXPECT_NEAR(acc(0, 0), expected_xddot, 1e-12);
    EXPECT_NEAR(acc(1, 0), 0.0, 1e-12);
    EXPECT_NEAR(data.constraint_forces.col(0).norm(), m * G / std::sqrt(1 + a * a), 1e-12);

    // and the motion: x(t) = x0 + xddot t^2 / 2
    StepSettings settings;
    settings.dt = 1e-3;
    Simulator simulator(scene, stateOf(p, v), settings);
    simulator.step(1000);
    EXPECT_NEAR(simulator.state().positions(0, 0), 1.0 + 0.5 * expected_xddot, 1e-9);
    EXPECT_NEAR(simulator.state().positions(2, 0), a * simulator.state().positions(0, 0), 1e-9);
  }
}

// A bead at rest at the bottom of a bowl: f_c = -m g.
TEST(Analytic, BeadAtRestInBowlCancelsGravity)
{
  for (const Surface& surface :
       { makeSurface("bowl", { 1.0, 3.0 }), makeSurface("gaussian", { -0.5, 0.4, 0.2, -0.3 }) })
  {
    const double m = 0.7;
    const Scene scene = beadScene(surface, m);
    Points p(3, 1), v = Points::Zero(3, 1);
    const double x0 = surface.type == SurfaceType::Gaussian ? 0.2 : 0.0;
    const double y0 = surface.type == SurfaceType::Gaussian ? -0.3 : 0.0;
    p.col(0) = Vec3(x0, y0, evaluateSurface(surface, x0, y0).z);
    const Model model = Model::compile(scene);
    Data data(model);
    Points acc(3, 1);
    computeAccelerations(model, data, p, v, acc);
    EXPECT_LE((data.constraint_forces.col(0) - Vec3(0, 0, m * G)).norm(), 1e-12);
    EXPECT_LE(acc.norm(), 1e-12);
  }
}

// Bowl Z = k r^2 / 2: a horizontal circular orbit of radius r has speed sqrt(g k) r.
TEST(Analytic, BeadOrbitsInBowl)
{
  const double k = 1.5, r = 0.4, omega = std::sqrt(G * k);
  const Scene scene = beadScene(makeSurface("bowl", { k, k }), 1.0);
  Points p(3, 1), v(3, 1);
  p.col(0) = Vec3(r, 0, 0.5 * k * r * r);
  v.col(0) = Vec3(0, omega * r, 0);
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator simulator(scene, stateOf(p, v), settings);
  simulator.step(2000);
  const double t = simulator.state().time;
  const Vec3 expected(r * std::cos(omega * t), r * std::sin(omega * t), 0.5 * k * r * r);
  EXPECT_LE((Vec3(simulator.state().positions.col(0)) - expected).norm(), 1e-9);
}

// Hanging chain at rest, first particle pinned: the constraint force on every particle cancels
// its weight (for the pinned one, its weight plus the links' pull: again -m g).
TEST(Analytic, HangingChainAtRestCancelsWeights)
{
  const int n = 6;
  const Scene scene = constrained_particles::testing::pinnedChain({ 1.0, 0.5, 2.0, 1.0, 3.0, 0.25 },
                                                                  0.3, Vec3(0, 0, 1));
  Points p(3, n), v = Points::Zero(3, n);
  for (int i = 0; i < n; ++i)
    p.col(i) = Vec3(0, 0, 1 - 0.3 * i);
  const Model model = Model::compile(scene);
  Data data(model);
  Points acc(3, n);
  computeAccelerations(model, data, p, v, acc);
  for (int i = 0; i < n; ++i)
    EXPECT_LE((data.constraint_forces.col(i) - Vec3(0, 0, scene.masses[i] * G)).norm(), 1e-10) << i;
  EXPECT_LE(acc.norm(), 1e-10);
  // link tension = weight below it: force on the upper particle is lambda (p_i - p_i+1)
  double below = 0;
  for (int i = n - 1; i >= 1; --i)
  {
    below += scene.masses[i] * G;
    EXPECT_NEAR(-data.multipliers[i - 1] * 0.3, below, 1e-10) << i;
  }
}

// Pendulum of length L released at small angle theta0: T = 2 pi sqrt(L/g) (1 + theta0^2/16 + ...).
TEST(Analytic, PendulumPeriod)
{
  const double L = 0.8, theta0 = 0.05;
  Scene scene;
  scene.masses = { 1.0, 1.0 };
  scene.constraints = { LinkConstraint{ 0, 1, L }, PinConstraint{ 0, Vec3::Zero() } };
  scene.forces = { GravityForce{} };
  Points p(3, 2), v = Points::Zero(3, 2);
  p.col(0).setZero();
  p.col(1) = L * Vec3(std::sin(theta0), 0, -std::cos(theta0));
  StepSettings settings;
  settings.dt = 1e-4;
  Simulator simulator(scene, stateOf(p, v), settings);
  // time of the second zero crossing of x after release = one period... interpolate linearly
  double previous_x = simulator.state().positions(0, 1), previous_t = 0;
  int crossings = 0;
  double period = 0;
  while (crossings < 2 && simulator.state().time < 5.0)
  {
    simulator.step();
    const double x = simulator.state().positions(0, 1), t = simulator.state().time;
    if ((x > 0) != (previous_x > 0))
    {
      ++crossings;
      const double crossing = previous_t + (t - previous_t) * previous_x / (previous_x - x);
      if (crossings == 1)
        period = -crossing;
      else
        period += crossing;
    }
    previous_x = x;
    previous_t = t;
  }
  ASSERT_EQ(crossings, 2);
  period *= 2.0;  // two crossings are half a period apart
  const double expected = 2 * M_PI * std::sqrt(L / G) * (1 + theta0 * theta0 / 16);
  EXPECT_NEAR(period, expected, 1e-5 * expected);
}

namespace
{
// largest |E(t) - E(0)| over a run
double maxEnergyError(const std::string& scenario, const std::string& integrator,
                      Stabilization stabilization, double dt, double duration)
{
  const BuiltScene built = constrained_particles::testing::shippedScene(scenario);
  StepSettings settings;
  settings.dt = dt;
  settings.integrator = integrator;
  settings.stabilization = stabilization;
  Simulator simulator(built.scene, built.initial_state, settings);
  const double e0 = simulator.diagnostics().totalEnergy();
  double worst = 0;
  while (simulator.state().time < duration)
  {
    simulator.step(10);
    worst = std::max(worst, std::abs(simulator.diagnostics().totalEnergy() - e0));
  }
  return worst;
}

}  // namespace

// Without damping, RK4's energy error < semi-implicit Euler's < explicit Euler's.
TEST(Analytic, EnergyErrorOrderingOfIntegrators)
{
  for (const std::string& scenario : constrained_particles::testing::seedSceneNames())
    for (Stabilization stabilization : { Stabilization::Baumgarte, Stabilization::Projection })
    {
      const double dt = 2e-3, duration = 4.0;
      const double rk4 = maxEnergyError(scenario, "rk4", stabilization, dt, duration);
      const double symplectic =
          maxEnergyError(scenario, "semi_implicit_euler", stabilization, dt, duration);
      const double explicit_euler =
          maxEnergyError(scenario, "explicit_euler", stabilization, dt, duration);
      EXPECT_LT(rk4, symplectic) << scenario << " " << stabilizationName(stabilization);
      EXPECT_LT(symplectic, explicit_euler) << scenario << " " << stabilizationName(stabilization);
      RecordProperty(scenario + "_" + stabilizationName(stabilization),
                     std::to_string(rk4) + " < " + std::to_string(symplectic) + " < " +
                         std::to_string(explicit_euler));
    }
}
