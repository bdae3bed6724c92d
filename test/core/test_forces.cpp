// Applied forces: springs against their potential and the harmonic oscillator, quadratic drag
// against its terminal-velocity closed form, validation.
#include "constrained_particles/core/simulator.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace constrained_particles;
using constrained_particles::testing::G;
using constrained_particles::testing::Random;
using constrained_particles::testing::stateOf;

// f = -grad(k (|d| - L)^2 / 2), by central differences of the potential
TEST(Forces, SpringForceIsMinusGradientOfItsPotential)
{
  Random random(41);
  const SpringForce spring{ 0, 2, 35.0, 0.4 };
  const std::vector<double> masses(3, 1.0);
  for (int trial = 0; trial < 100; ++trial)
  {
    Points p(3, 3);
    for (int i = 0; i < 3; ++i)
      p.col(i) = random.vector(1.0);
    const Points v = Points::Zero(3, 3);
    Points f = Points::Zero(3, 3);
    accumulateForce(spring, masses, p, v, f);
    for (int i = 0; i < 3; ++i)
      for (int axis = 0; axis < 3; ++axis)
      {
        Points plus = p, minus = p;
        plus(axis, i) += 1e-6;
        minus(axis, i) -= 1e-6;
        const double gradient =
            (potentialEnergy(spring, masses, plus) - potentialEnergy(spring, masses, minus)) / 2e-6;
        EXPECT_NEAR(f(axis, i), -gradient, 1e-6 * (1 + std::abs(gradient)));
      }
  }
}

// a mass on a spring to a pinned particle: x(t) = L + A cos(sqrt(k/m) t)
TEST(Forces, SpringOscillatorMatchesClosedForm)
{
  const double k = 40.0, m = 0.5, L = 0.3, A = 0.1, omega = std::sqrt(k / m);
  Scene scene;
  scene.masses = { 1.0, m };
  scene.forces = { SpringForce{ 0, 1, k, L } };
  scene.constraints = { PinConstraint{ 0, Vec3::Zero() } };
  Points p(3, 2);
  p << 0, L + A, 0, 0, 0, 0;
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator simulator(scene, stateOf(p, Points::Zero(3, 2)), settings);
  simulator.step(1000);
  const double t = simulator.state().time;
  EXPECT_NEAR(simulator.state().positions(0, 1), L + A * std::cos(omega * t), 1e-9);
  EXPECT_NEAR(simulator.diagnostics().totalEnergy(), 0.5 * k * A * A, 1e-9);
}

// a double pendulum with a spring from the pin to its tip: energy with springs and gravity is
// conserved. Rest length 0 keeps f = -k d smooth: with L > 0 the force flips direction when the
// folded tip passes through the pin, which no fixed-step method integrates to high order.
TEST(Forces, SpringsConserveEnergyAlongsideConstraints)
{
  Scene scene;
  scene.masses = { 1.0, 1.0, 1.0 };
  scene.forces = { GravityForce{}, SpringForce{ 0, 2, 20.0, 0.0 } };
  scene.constraints = { LinkConstraint{ 0, 1, 0.5 }, LinkConstraint{ 1, 2, 0.5 },
                        PinConstraint{ 0, Vec3::Zero() } };
  Points p(3, 3);
  p << 0, 0.5, 1.0, 0, 0, 0, 0, 0, 0;
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator simulator(scene, stateOf(p, Points::Zero(3, 3)), settings);
  const double e0 = simulator.diagnostics().totalEnergy();
  simulator.step(3000);
  EXPECT_NEAR(simulator.diagnostics().totalEnergy(), e0, 1e-6);
  EXPECT_LE(simulator.diagnostics().max_position_error, 1e-9);
}

// falling from rest with f = -c |v| v: v(t) = v_t tanh(g t / v_t), v_t = sqrt(m g / c)
TEST(Forces, QuadraticDragReachesTerminalVelocity)
{
  const double m = 0.2, c = 0.05, terminal = std::sqrt(m * G / c);
  Scene scene;
  scene.masses = { m };
  scene.forces = { GravityForce{}, QuadraticDragForce{ c } };
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator simulator(scene, stateOf(Vec3::Zero(), Vec3::Zero()), settings);
  simulator.step(2000);
  const double t = simulator.state().time;
  EXPECT_NEAR(-simulator.state().velocities(2, 0), terminal * std::tanh(G * t / terminal), 1e-9);
  EXPECT_EQ(simulator.model().numRows(), 0);  // no constraints: nothing to solve
}

TEST(Forces, BadForcesAreRefused)
{
  Scene scene;
  scene.masses = { 1.0, 1.0 };
  auto refusedField = [&](const Force& force)
  {
    scene.forces = { force };
    try
    {
      Model::compile(scene);
    }
    catch (const InvalidInput& e)
    {
      return e.field();
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refusedField(SpringForce{ 0, 0, 1.0, 0.0 }), "forces[0].second");
  EXPECT_EQ(refusedField(SpringForce{ 0, 5, 1.0, 0.0 }), "forces[0].second");
  EXPECT_EQ(refusedField(SpringForce{ 0, 1, -1.0, 0.0 }), "forces[0].stiffness");
  EXPECT_EQ(refusedField(SpringForce{ 0, 1, 1.0, NAN }), "forces[0].rest_length");
  EXPECT_EQ(refusedField(QuadraticDragForce{ -0.1 }), "forces[0].coefficient");
  EXPECT_EQ(refusedField(QuadraticDragForce{ 0.1 }), "accepted");
}

// A target spring with c = 2 sqrt(k m) is a critically damped oscillator about its target:
// x(t) = a + (x0 - a)(1 + w t) e^(-w t), w = sqrt(k / m), from rest.
TEST(Forces, TargetSpringIsACriticallyDampedOscillator)
{
  const double m = 0.5, w = 6.0, k = m * w * w, c = 2.0 * m * w;
  const Vec3 target(1.0, -2.0, 0.5), x0(0.2, 0.3, -0.4);
  Scene scene;
  scene.masses = { m };
  scene.forces = { TargetSpringForce{ 0, target, k, c } };
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator simulator(scene, stateOf(x0, Vec3::Zero()), settings);
  simulator.step(1500);
  const double t = simulator.state().time;
  const Vec3 exact = target + (x0 - target) * (1.0 + w * t) * std::exp(-w * t);
  EXPECT_LE((Vec3(simulator.state().positions.col(0)) - exact).norm(), 1e-10);
  // rk4: four per step, and one where the first step's stability estimate reads the forces
  EXPECT_EQ(simulator.effectCounters().forceCount<TargetSpringForce>(), 1500u * 4u + 1u);
}

// Perturbations (a push, a target spring) act from the next step, only while set, are counted
// with the model's forces, survive a change of the model's forces, and a new scene has none.
TEST(Forces, PerturbationsActOnlyWhileSetAndAreCounted)
{
  // a bead on the plane z = 0 pushed along x: a = F / m while the push acts
  Scene scene;
  scene.masses = { 2.0 };
  scene.surfaces = { makeSurface(SurfaceType::Plane, { 0.0, 0.0, 0.0 }) };
  scene.constraints = { SurfaceConstraint{ 0, 0 } };
  scene.forces = { GravityForce{} };
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator simulator(scene, stateOf(Vec3::Zero(), Vec3(0.0, 0.5, 0.0)), settings);
  const Vec3 push(3.0, 0.0, 0.0);
  simulator.setPerturbations({ ExternalForce{ 0, push } });
  simulator.step(400);
  const double t1 = simulator.state().time, a = push.x() / 2.0;
  EXPECT_NEAR(simulator.state().positions(0, 0), 0.5 * a * t1 * t1, 1e-10);
  EXPECT_NEAR(simulator.state().positions(1, 0), 0.5 * t1, 1e-10);
  EXPECT_NEAR(simulator.state().positions(2, 0), 0.0, 1e-10);
  // rk4's four per step, and the stability estimate's evaluation after the change
  EXPECT_EQ(simulator.effectCounters().forceCount<ExternalForce>(), 400u * 4u + 1u);
  // gravity changed: the model is recompiled, the push stays
  simulator.setForces({ GravityForce{ Vec3(0.0, 0.0, -1.62) } });
  simulator.step(100);
  const double t2 = simulator.state().time;
  EXPECT_NEAR(simulator.state().positions(0, 0), 0.5 * a * t2 * t2, 1e-10);
  // released: constant velocity from here
  simulator.setPerturbations({});
  const double x2 = simulator.state().positions(0, 0);
  const std::uint64_t pushes = simulator.effectCounters().forceCount<ExternalForce>();
  simulator.step(200);
  EXPECT_NEAR(simulator.state().positions(0, 0), x2 + a * t2 * 0.2, 1e-10);
  EXPECT_EQ(simulator.effectCounters().forceCount<ExternalForce>(), pushes);
  // pushed again after steps under gravity alone (whose m g the stages keep): the push acts
  simulator.setPerturbations({ ExternalForce{ 0, push } });
  const double x3 = simulator.state().positions(0, 0), v3 = a * t2;
  simulator.step(100);
  EXPECT_NEAR(simulator.state().positions(0, 0), x3 + v3 * 0.1 + 0.5 * a * 0.1 * 0.1, 1e-10);
  // a new scene starts without them
  simulator.setPerturbations({ ExternalForce{ 0, push } });
  simulator.setScene(scene, stateOf(Vec3::Zero(), Vec3::Zero()));
  EXPECT_TRUE(simulator.data().perturbations.empty());
}

// A bad perturbation is refused naming it, and the ones set before stay.
TEST(Forces, BadPerturbationsAreRefusedNamingThem)
{
  Scene scene;
  scene.masses = { 1.0, 1.0 };
  Simulator simulator(scene, stateOf(Points::Zero(3, 2), Points::Zero(3, 2)), StepSettings{});
  const std::vector<Force> good = { ExternalForce{ 1, Vec3(0.0, 1.0, 0.0) } };
  simulator.setPerturbations(good);
  auto refusedField = [&](const std::vector<Force>& forces)
  {
    try
    {
      simulator.setPerturbations(forces);
    }
    catch (const InvalidInput& e)
    {
      return e.field();
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refusedField({ good[0], ExternalForce{ 2, Vec3::Zero() } }),
            "perturbations[1].particle");
  EXPECT_EQ(refusedField({ ExternalForce{ 0, Vec3(NAN, 0.0, 0.0) } }), "perturbations[0].force.x");
  EXPECT_EQ(refusedField({ TargetSpringForce{ 0, Vec3::Zero(), -1.0, 0.0 } }),
            "perturbations[0].stiffness");
  EXPECT_EQ(refusedField({ TargetSpringForce{ 0, Vec3(0.0, INFINITY, 0.0), 1.0, 0.0 } }),
            "perturbations[0].target.y");
  ASSERT_EQ(simulator.data().perturbations.size(), 1u);
  EXPECT_EQ(std::get<ExternalForce>(simulator.data().perturbations[0]).particle, 1);
}

// A conservative scene's energy check is off while a perturbation does work on it: a chain
// pulled by a target spring gains energy without a step being refused or split.
TEST(Forces, APerturbationTurnsTheEnergyCheckOff)
{
  Scene scene;
  scene.masses = { 1.0, 1.0, 1.0 };
  scene.forces = { GravityForce{} };
  scene.constraints = { PinConstraint{ 0, Vec3::Zero() }, LinkConstraint{ 0, 1, 0.5 },
                        LinkConstraint{ 1, 2, 0.5 } };
  Points p(3, 3);
  p << 0, 0, 0, 0, 0, 0, 0, -0.5, -1.0;
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator simulator(scene, stateOf(p, Points::Zero(3, 3)), settings);
  const double e0 = simulator.diagnostics().totalEnergy();
  const double m = 1.0, w = 10.0;
  simulator.setPerturbations({ TargetSpringForce{ 2, Vec3(1.0, 0.0, 0.0), m * w * w, 2 * m * w } });
  const StepStatistics statistics = simulator.step(1000);
  EXPECT_EQ(statistics.failed_check, StepCheck::None);
  EXPECT_EQ(statistics.rejected_steps, 0);
  EXPECT_GT(simulator.diagnostics().totalEnergy(), e0 + 1.0);  // lifted towards (1, 0, 0)
  EXPECT_LE(simulator.diagnostics().max_position_error, 1e-9);
  // the tip went towards the target (it started sqrt(2) m from it; gravity holds it below)
  EXPECT_LT((Vec3(simulator.state().positions.col(2)) - Vec3(1.0, 0.0, 0.0)).norm(), 0.5);
}
