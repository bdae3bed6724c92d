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
