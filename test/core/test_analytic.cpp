// Analytic cases from physics.md, closed-form motions, and the energy ordering of integrators.
#include "constrained_particles/core/simulator.hpp"
#include "test_helpers.hpp"

#include <algorithm>

#include <gtest/gtest.h>

using namespace constrained_particles;
using constrained_particles::testing::beadScene;
using constrained_particles::testing::computeAccelerations;
using constrained_particles::testing::G;
using constrained_particles::testing::stateOf;

namespace
{
struct SwingPeriod
{
  int crossings = 0;  ///< zero crossings of x seen (2 for a period)
  double period = 0;  ///< twice the time between the first two [s]
};

// Steps until x(positions) has crossed zero twice (at most 5 s of sim time), calling each_step
// after every step; crossing times are interpolated linearly within the step.
template <typename X, typename EachStep>
SwingPeriod measurePeriod(Simulator& simulator, X x_of, EachStep each_step)
{
  SwingPeriod result;
  double previous_x = x_of(simulator.state().positions), previous_t = simulator.state().time;
  double first = 0;
  while (result.crossings < 2 && simulator.state().time < 5.0)
  {
    simulator.step();
    each_step();
    const double x = x_of(simulator.state().positions), t = simulator.state().time;
    if ((x > 0) != (previous_x > 0))
    {
      const double crossing = previous_t + (t - previous_t) * previous_x / (previous_x - x);
      if (++result.crossings == 1)
        first = crossing;
      else
        result.period = 2.0 * (crossing - first);  // two crossings are half a period apart
    }
    previous_x = x;
    previous_t = t;
  }
  return result;
}

}  // namespace

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
  const SwingPeriod swing = measurePeriod(
      simulator, [](const Points& q) { return q(0, 1); }, [] {});
  ASSERT_EQ(swing.crossings, 2);
  const double expected = 2 * M_PI * std::sqrt(L / G) * (1 + theta0 * theta0 / 16);
  EXPECT_NEAR(swing.period, expected, 1e-5 * expected);
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
  settings.energy_budget = 0.0;  // the methods' errors over the whole run are compared
  Simulator simulator(built.scene, built.initial_state, settings);
  const double e0 = simulator.diagnostics().totalEnergy();
  double worst = 0;
  while (simulator.state().time < duration)
  {
    // a failed check puts the step back: the error then stands where it stopped
    const bool failed = simulator.step(10).failed_check != StepCheck::None;
    worst = std::max(worst, std::abs(simulator.diagnostics().totalEnergy() - e0));
    if (failed)
      break;
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

// A bead on a straight wire along d: it slides with a = (g.d^) d^, and the wire's force is the
// rest of its weight, m (a - g).
TEST(Analytic, BeadSlidesAlongTiltedWire)
{
  const Vec3 d = Vec3(1.0, 0.5, 0.3).normalized();
  const Vec3 g(0.0, 0.0, -G), start(0.2, -0.1, 1.0);
  const double m = 1.5, speed = 0.4;
  Scene scene;
  scene.masses = { m };
  scene.forces = { GravityForce{ g } };
  scene.constraints = { PointOnLineConstraint{ 0, start, Vec3(2.0, 1.0, 0.6) } };
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator simulator(scene, stateOf(start, speed * d), settings);
  const Vec3 a = g.dot(d) * d;
  Points forces;
  Eigen::VectorXd multipliers;
  simulator.constraintForces(forces, multipliers);
  EXPECT_LE((Vec3(forces.col(0)) - m * (a - g)).norm(), 1e-12);
  simulator.step(1000);
  const double t = simulator.state().time;
  const Vec3 expected = start + speed * t * d + 0.5 * t * t * a;
  EXPECT_LE((Vec3(simulator.state().positions.col(0)) - expected).norm(), 1e-9);
  EXPECT_LE(simulator.diagnostics().max_position_error, 1e-10);
}

// A particle on an inclined plane with normal n slides with a = g - (g.n^) n^.
TEST(Analytic, ParticleSlidesOnInclinedPlane)
{
  const Vec3 n = Vec3(0.3, -0.2, 1.0).normalized();
  const Vec3 g(0.0, 0.0, -G), point(0.0, 0.0, 0.5);
  Scene scene;
  scene.masses = { 0.7 };
  scene.forces = { GravityForce{ g } };
  scene.constraints = { PointOnPlaneConstraint{ 0, point, Vec3(0.3, -0.2, 1.0) } };
  const Vec3 v0 = Vec3(0.5, 0.4, 0.0) - Vec3(0.5, 0.4, 0.0).dot(n) * n;  // in the plane
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator simulator(scene, stateOf(point, v0), settings);
  simulator.step(1000);
  const double t = simulator.state().time;
  const Vec3 a = g - g.dot(n) * n;
  EXPECT_LE((Vec3(simulator.state().positions.col(0)) - (point + v0 * t + 0.5 * t * t * a)).norm(),
            1e-9);
}

// An L of two equal masses on arms of length l, its vertex pinned and its angle theta_0 held:
// a compound pendulum, T = 2 pi sqrt(I / (M g d)) = 2 pi sqrt(l / (g cos(theta_0 / 2))) for
// small swings (with the theta^2 / 16 correction of its amplitude).
TEST(Analytic, AngleConstraintMakesARigidCompoundPendulum)
{
  const double l = 0.5, opening = M_PI / 2, swing = 0.05;
  Scene scene;
  scene.masses = { 1.0, 0.8, 0.8 };  // the vertex's mass plays no part: it is pinned
  scene.forces = { GravityForce{} };
  scene.constraints = { PinConstraint{ 0, Vec3::Zero() }, LinkConstraint{ 0, 1, l },
                        LinkConstraint{ 0, 2, l }, AngleConstraint{ { { 1, 0, 2 } }, opening } };
  Points p = Points::Zero(3, 3);
  for (int side : { 1, 2 })
  {
    const double angle = swing + (side == 1 ? -0.5 : 0.5) * opening;  // from -z, in x-z
    p.col(side) = l * Vec3(std::sin(angle), 0.0, -std::cos(angle));
  }
  StepSettings settings;
  settings.dt = 1e-4;
  Simulator simulator(scene, stateOf(p, Points::Zero(3, 3)), settings);
  EXPECT_EQ(simulator.model().solveMethod(), SolveMethod::Tree);
  // the centre of mass crosses x = 0 every half period
  double worst_angle = 0.0;
  const SwingPeriod measured = measurePeriod(
      simulator, [](const Points& q) { return 0.5 * (q(0, 1) + q(0, 2)); },
      [&]
      {
        const Vec3 a = simulator.state().positions.col(1), b = simulator.state().positions.col(2);
        worst_angle =
            std::max(worst_angle, std::abs(std::acos(a.dot(b) / (a.norm() * b.norm())) - opening));
      });
  ASSERT_EQ(measured.crossings, 2);
  const double expected =
      2 * M_PI * std::sqrt(l / (G * std::cos(opening / 2))) * (1 + swing * swing / 16);
  EXPECT_NEAR(measured.period, expected, 1e-5 * expected);
  EXPECT_LE(worst_angle, 1e-9);
}

// A straight rod of three masses at l, 2 l, 3 l from a pinned end, held straight by two
// collinear records (links keep the lengths): a compound pendulum, T = 2 pi sqrt(I / (g S)),
// I = sum m_k r_k^2, S = sum m_k r_k, for small swings (with the theta^2 / 16 correction).
TEST(Analytic, CollinearConstraintsMakeAStiffRod)
{
  const double l = 0.3, swing = 0.05;
  const std::vector<double> m = { 0.6, 0.8, 0.5 };
  Scene scene;
  scene.masses = { 1.0, m[0], m[1], m[2] };  // the pinned end's mass plays no part
  scene.forces = { GravityForce{} };
  scene.constraints = { PinConstraint{ 0, Vec3::Zero() },
                        LinkConstraint{ 0, 1, l },
                        LinkConstraint{ 1, 2, l },
                        LinkConstraint{ 2, 3, l },
                        CollinearConstraint{ { { 0, 1, 2 } } },
                        CollinearConstraint{ { { 1, 2, 3 } } } };
  Points p = Points::Zero(3, 4);
  for (int k = 1; k < 4; ++k)
    p.col(k) = k * l * Vec3(std::sin(swing), 0.0, -std::cos(swing));
  StepSettings settings;
  settings.dt = 1e-4;
  Simulator simulator(scene, stateOf(p, Points::Zero(3, 4)), settings);
  double inertia = 0.0, moment = 0.0;
  for (int k = 1; k < 4; ++k)
  {
    inertia += m[k - 1] * (k * l) * (k * l);
    moment += m[k - 1] * (k * l);
  }
  double worst_bend = 0.0;  // distance of the middle particles from the line end to end [m]
  const SwingPeriod measured = measurePeriod(
      simulator, [](const Points& q) { return q(0, 3); },
      [&]
      {
        const Points& q = simulator.state().positions;
        const Vec3 axis = Vec3(q.col(3)).normalized();
        for (int k = 1; k < 3; ++k)
          worst_bend = std::max(worst_bend, Vec3(q.col(k)).cross(axis).norm());
      });
  ASSERT_EQ(measured.crossings, 2);
  const double expected = 2 * M_PI * std::sqrt(inertia / (G * moment)) * (1 + swing * swing / 16);
  EXPECT_NEAR(measured.period, expected, 1e-5 * expected);
  EXPECT_LE(worst_bend, 1e-9);
}

// A moving anchor with no amplitude is a pin: the same motion to the last bit.
TEST(Analytic, MovingAnchorAtRestIsAPin)
{
  Scene pinned = constrained_particles::testing::pinnedChain({ 1.0, 0.5, 2.0, 1.0 }, 0.4);
  Scene driven = pinned;
  driven.constraints.back() = MovingAnchorConstraint{ 0, Vec3::Zero(), Vec3::Zero(), 2.0, 0.3 };
  Points p(3, 4);
  for (int i = 0; i < 4; ++i)
    p.col(i) = 0.4 * i * Vec3(std::sin(0.8), 0.0, -std::cos(0.8));
  StepSettings settings;
  Simulator a(pinned, stateOf(p, Points::Zero(3, 4)), settings);
  Simulator b(driven, stateOf(p, Points::Zero(3, 4)), settings);
  a.step(500);
  b.step(500);
  EXPECT_EQ(a.state().positions, b.state().positions);
  EXPECT_EQ(a.state().velocities, b.state().velocities);
}

// A driven pivot moves exactly as prescribed, the chain stays on its constraints, and the
// energy the chain gains is the work the driver's reaction does: dE = R . v_pivot dt.
TEST(Analytic, MovingAnchorDrivesExactlyAndItsWorkIsTheEnergyGained)
{
  const Vec3 amplitude(0.15, 0.0, 0.05);
  const double frequency = 1.2, phase = 0.4;
  Scene scene = constrained_particles::testing::pinnedChain({ 0.5, 0.3, 0.3, 0.3 }, 0.3);
  const MovingAnchorConstraint anchor{ 0, Vec3(0.0, 0.0, 1.0), amplitude, frequency, phase };
  scene.constraints.back() = anchor;
  Points p(3, 4);
  for (int i = 0; i < 4; ++i)
    p.col(i) = imposedMotion(anchor, 0.0).position + 0.3 * i * Vec3(0.3, 0.0, -1.0).normalized();
  StepSettings settings;
  settings.dt = 1e-4;
  Simulator simulator(scene, stateOf(p, Points::Zero(3, 4)), settings);
  const double e0 = simulator.diagnostics().totalEnergy();
  Points forces;
  Eigen::VectorXd multipliers;
  auto power = [&]
  {
    // the driver's reaction (the last three multipliers), not the links' pull on the pivot:
    // links are internal and do no net work
    simulator.constraintForces(forces, multipliers);
    return Vec3(multipliers.tail<3>()).dot(simulator.state().velocities.col(0));
  };
  double work = 0.0, previous = power(), worst_drive = 0.0;
  for (int k = 0; k < 10000; ++k)
  {
    simulator.step();
    const ImposedMotion motion = imposedMotion(anchor, simulator.state().time);
    worst_drive = std::max(
        worst_drive, (Vec3(simulator.state().positions.col(0)) - motion.position).norm() +
                         (Vec3(simulator.state().velocities.col(0)) - motion.velocity).norm());
    const double now = power();
    work += 0.5 * settings.dt * (previous + now);
    previous = now;
  }
  EXPECT_EQ(worst_drive, 0.0);
  EXPECT_LE(simulator.diagnostics().max_position_error, 1e-10);
  const double gained = simulator.diagnostics().totalEnergy() - e0;
  EXPECT_GT(std::abs(gained), 1e-3);                         // the driver does work
  EXPECT_NEAR(gained, work, 1e-7 * (std::abs(work) + 1.0));  // measured 3e-9
}
