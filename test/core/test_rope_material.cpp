// A rope's material (issue 49). Bending stiffness (effects/bending.hpp): the discrete elastic
// rod's bending energy and moment against their closed forms, a clamped cable's tip deflection
// against beam theory (under a tip load and under its own weight, converging as the cable is cut
// finer), and a bent cable swinging for 60 s with its bending energy booked by the energy ledger
// (that the force is minus the gradient of the energy is test_registry's, for every conservative
// kind, by finite differences). What a rope user reads (rope_readings.hpp): a hanging rope's
// tensions, each the weight below it.
#include "constrained_particles/core/rope_readings.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace constrained_particles;
using constrained_particles::testing::stateOf;

namespace
{
// A joint of links l (first along +x, the second turned by phi in the x-z plane) [m].
Points jointAt(double phi, double l)
{
  Points p(3, 3);
  p.col(0) = Vec3(-l, 0.0, 0.0);
  p.col(1) = Vec3::Zero();
  p.col(2) = Vec3(l * std::cos(phi), 0.0, l * std::sin(phi));
  return p;
}

// A cable of `segments` links beyond a clamp, L = 1 m long, EI 1 N m^2, 0.01 kg/m: particle 1
// pinned at the clamp (x = 0), the rest linked along +x from it, and particle 0 pinned a link
// behind it, unlinked (a link between two pinned particles is a zero row), which sets the
// direction the cable leaves the clamp. The clamp's bend, at particle 1, is spread over the half
// link on the cable's side (length l / 2: the other half is in the wall; with l the clamp turns
// too far, by the moment there times l / (2 EI), and the tip is off at first order, by 3 l / (2 L)
// under a tip load and 2 l / L under the cable's weight); the others at 2 .. segments over l.
// Lumped masses: l rho on the inner particles, half that on the tip.
double clampedTipDeflection(int segments, double tip_force, double gravity)
{
  const double L = 1.0, EI = 1.0, rho = 0.01, l = L / segments;
  const int n = segments + 2, tip = n - 1;
  Scene scene;
  scene.masses.assign(n, rho * l);
  scene.masses[tip] = 0.5 * rho * l;
  Points p = Points::Zero(3, n);
  for (int i = 0; i < n; ++i)
    p(0, i) = (i - 1) * l;
  for (int i = 1; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, l });
  scene.constraints.push_back(PinConstraint{ 0, Vec3(p.col(0)) });
  scene.constraints.push_back(PinConstraint{ 1, Vec3(p.col(1)) });
  for (int i = 1; i + 1 < n; ++i)
    scene.forces.push_back(BendingForce{ i - 1, i, i + 1, EI, i == 1 ? 0.5 * l : l });
  if (tip_force != 0.0)
    scene.forces.push_back(ExternalForce{ tip, Vec3(0.0, 0.0, -tip_force) });
  if (gravity != 0.0)
    scene.forces.push_back(GravityForce{ Vec3(0.0, 0.0, -gravity) });
  // the first mode, omega_1 = 3.516 sqrt(EI / (rho L^4)), decays at c / 2m = omega_1
  const double omega_1 = 3.516 * std::sqrt(EI / (rho * std::pow(L, 4)));
  scene.forces.push_back(LinearDampingForce{ 2.0 * omega_1 * rho * l });
  StepSettings settings;
  settings.integrator = "rk4";
  // 0.5 / omega_max, omega_max the bending's largest frequency, sqrt(16 EI / (l^3 m)), taken
  // twice as stiff for the clamp's joint (rk4's limit is 2.8 / omega)
  settings.dt = 0.5 / std::sqrt(2.0 * 16.0 * EI / (l * l * l * rho * l));
  Simulator simulator(scene, stateOf(p, Points::Zero(3, n)), settings);
  // the fall's speed, omega_1 times the 1 mm deflection, decays as (1 + omega_1 t) e^-(omega_1 t)
  // (the higher modes faster; slower where the coarse cable's first mode is overdamped)
  const int steps = static_cast<int>(std::ceil(24.0 / omega_1 / settings.dt));
  const StepStatistics stats = simulator.step(steps);
  EXPECT_EQ(stats.failed_check, StepCheck::None) << segments;
  EXPECT_EQ(stats.stiff_steps, 0) << segments;
  EXPECT_EQ(stats.solve.singular_count, 0) << segments;
  // at rest: what motion is left, v / omega_1, is under 3e-5 of the deflection
  EXPECT_LT(simulator.state().velocities.norm(), 1e-6) << segments << " segments: not at rest";
  return -simulator.state().positions(2, tip);
}

// observed order of three errors at h, h/2, h/4
double observedOrder(const double (&error)[3])
{
  return std::log2(std::abs(error[1]) / std::abs(error[2]));
}
}  // namespace

// U = EI (2 tan(phi/2))^2 / (2 l): 0 straight, EI phi^2 / (2 l) for small phi (to phi^4), 2 EI / l
// at a right angle; and it grows without bound as the joint folds back.
TEST(Bending, EnergyIsTheDiscreteElasticRodsClosedForm)
{
  const BendingForce joint{ 0, 1, 2, 0.7, 0.05 };
  const std::vector<double> masses(3, 1.0);
  EXPECT_EQ(potentialEnergy(joint, masses, jointAt(0.0, 0.05)), 0.0);
  const double phi = 1e-3;
  EXPECT_NEAR(potentialEnergy(joint, masses, jointAt(phi, 0.05)) / (0.7 * phi * phi / 0.1), 1.0,
              1e-6);
  EXPECT_NEAR(potentialEnergy(joint, masses, jointAt(M_PI / 2, 0.05)), 2.0 * 0.7 / 0.05, 1e-12);
  for (const double turn : { 2.0, 2.5, 3.0 })
    EXPECT_NEAR(potentialEnergy(joint, masses, jointAt(turn, 0.05)),
                0.7 * std::pow(2.0 * std::tan(turn / 2), 2) / 0.1, 1e-9 * std::tan(turn / 2));
  // a straight joint pushes nothing; a bent one pushes its ends to straighten it, with no net force
  Points f = Points::Zero(3, 3);
  accumulateForce(joint, masses, jointAt(0.0, 0.05), Points::Zero(3, 3), f);
  EXPECT_EQ(f.norm(), 0.0);
  accumulateForce(joint, masses, jointAt(0.3, 0.05), Points::Zero(3, 3), f);
  EXPECT_LT(f(2, 2), 0.0);  // the far end pushed back down towards the line
  EXPECT_LT(f.rowwise().sum().norm(), 1e-12 * f.norm());
  // folded back exactly: no direction to bend in, no force, a finite energy
  Points folded = jointAt(M_PI, 0.05);
  folded(2, 2) = 0.0;
  Points g = Points::Zero(3, 3);
  accumulateForce(joint, masses, folded, Points::Zero(3, 3), g);
  EXPECT_EQ(g.norm(), 0.0);
  EXPECT_TRUE(std::isfinite(potentialEnergy(joint, masses, folded)));
}

// A cantilever under a tip load F bends its tip by F L^3 / (3 EI) (Euler-Bernoulli, small
// deflection: here 1e-3 L); under its own weight w per metre by w L^4 / (8 EI). The cable cut into
// 10, 20 and 40 links comes to rest closer each time, at second order, within 1 % at 40.
TEST(Bending, AClampedCablesTipDeflectsAsBeamTheorySays)
{
  const double EI = 1.0, L = 1.0, rho = 0.01;
  struct Case
  {
    const char* name;
    double tip_force, gravity, exact;
  };
  const double F = 3e-3, g = 0.8;  // deflections of 1e-3 m
  const Case cases[] = { { "tip load", F, 0.0, F * std::pow(L, 3) / (3.0 * EI) },
                         { "own weight", 0.0, g, rho * g * std::pow(L, 4) / (8.0 * EI) } };
  for (const Case& c : cases)
  {
    double error[3];
    for (int k = 0; k < 3; ++k)
    {
      const int segments = 10 << k;
      const double deflection = clampedTipDeflection(segments, c.tip_force, c.gravity);
      error[k] = deflection / c.exact - 1.0;
      std::printf("%s, %d links: tip %.9g m, beam theory %.9g m, relative error %.3g\n", c.name,
                  segments, deflection, c.exact, error[k]);
    }
    EXPECT_LT(std::abs(error[2]), 1e-3) << c.name;
    EXPECT_LT(std::abs(error[1]), std::abs(error[0])) << c.name;
    EXPECT_LT(std::abs(error[2]), std::abs(error[1])) << c.name;
    const double order = observedOrder(error);
    std::printf("%s: observed order %.3f\n", c.name, order);
    EXPECT_GT(order, 1.8) << c.name;
  }
}

// A cable bent into a quarter circle, pinned at one end, with no gravity, springs straight and
// bends back for 60 s: its energy, all bending at the start, goes nearly all kinetic and back
// (each over 0.9 of it), and the energy ledger balances within the budget (no step handed over)
// under rk4 and velocity Verlet.
TEST(Bending, ABentCableSpringingFor60SecondsBalancesItsLedger)
{
  const int n = 10;
  const double l = 0.1, m = 0.05, EI = 0.01;
  Scene scene;
  scene.masses.assign(n, m);
  Points p(3, n);
  for (int i = 0; i < n; ++i)  // a quarter circle of radius (n - 1) l / (pi / 2)
  {
    const double r = (n - 1) * l / (M_PI / 2), a = i * (M_PI / 2) / (n - 1);
    p.col(i) = Vec3(r * std::sin(a), 0.0, r * std::cos(a) - r);
  }
  const double chord = (p.col(1) - p.col(0)).norm();
  for (int i = 0; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, chord });
  scene.constraints.push_back(PinConstraint{ 0, Vec3(p.col(0)) });
  for (int i = 1; i + 1 < n; ++i)
    scene.forces.push_back(BendingForce{ i - 1, i, i + 1, EI, chord });
  for (const char* integrator : { "rk4", "velocity_verlet" })
  {
    StepSettings settings;
    settings.integrator = integrator;
    settings.dt = 1e-3;
    Simulator simulator(scene, stateOf(p, Points::Zero(3, n)), settings);
    double most_bending = 0.0, least_bending = INFINITY, most_kinetic = 0.0, worst = 0.0;
    for (int k = 0; k < 600; ++k)
    {
      const StepStatistics stats = simulator.step(100);
      ASSERT_EQ(stats.failed_check, StepCheck::None) << integrator;
      ASSERT_EQ(stats.rejections[static_cast<int>(StepCheck::EnergyBudget)], 0)
          << integrator << " at t = " << simulator.state().time;
      ASSERT_EQ(stats.stiff_steps, 0) << integrator;
      const EnergyLedger& ledger = simulator.energyLedger();
      most_bending = std::max(most_bending, ledger.potential);  // the bends' only
      least_bending = std::min(least_bending, ledger.potential);
      most_kinetic = std::max(most_kinetic, ledger.kinetic);
      worst = std::max(
          worst, std::abs(ledger.residual()) / ledger.budgetScale(Simulator::ENERGY_SCALE_FLOOR));
    }
    EXPECT_FALSE(simulator.data().control.budget_fallback) << integrator;
    const EnergyLedger& ledger = simulator.energyLedger();
    std::printf(
        "%s: bending energy %.4g..%.4g J (%.4g J at the start), kinetic up to %.4g J, "
        "|residual| up to %.3g of the budget's scale (budget %.3g)\n",
        integrator, least_bending, most_bending, ledger.initial_energy, most_kinetic, worst,
        settings.energy_budget);
    // the energy, all bending at the start, goes nearly all kinetic and back
    EXPECT_GT(most_bending - least_bending, 0.9 * ledger.initial_energy) << integrator;
    EXPECT_GT(most_kinetic, 0.9 * ledger.initial_energy) << integrator;
    EXPECT_LT(worst, settings.energy_budget) << integrator;
  }
}

// A chain's bend_stiffness in a scene file is a bend record at each inner particle, after the
// file's own forces; sceneForces gives the same list that buildScene puts in the scene.
TEST(Bending, AChainsBendStiffnessIsABendAtEachInnerParticle)
{
  const std::string yaml =
      "particles: [{position: [0, 0, 5]}]\n"
      "chains:\n"
      "  - {particles: 4, link_length: 0.2, bend_stiffness: 0.3}\n"
      "  - {particles: 3, link_length: 0.1, start: [0, 1, 0]}\n"
      "forces: [{type: gravity}]\n";
  const SceneDescription d = parseScene(yaml, "bend.yaml");
  const BuiltScene built = buildScene(d);
  ASSERT_EQ(built.scene.forces.size(), 3u);
  EXPECT_TRUE(std::holds_alternative<GravityForce>(built.scene.forces[0]));
  for (int k = 0; k < 2; ++k)
  {
    const auto& joint = std::get<BendingForce>(built.scene.forces[1 + k]);
    EXPECT_EQ(joint.first, 1 + k);  // the chain's particles are 1..4, after the explicit one
    EXPECT_EQ(joint.middle, 2 + k);
    EXPECT_EQ(joint.last, 3 + k);
    EXPECT_EQ(joint.stiffness, 0.3);
    EXPECT_EQ(joint.length, 0.2);
  }
  EXPECT_EQ(sceneForces(d).size(), built.scene.forces.size());
  const std::string bad = "chains:\n  - {particles: 4, bend_stiffness: -1}\n";
  try
  {
    buildScene(parseScene(bad, "bad.yaml"));
    ADD_FAILURE() << "a negative bend_stiffness was taken";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_NE(std::string(e.what()).find("bend_stiffness"), std::string::npos) << e.what();
  }
}

// The moment a bend carries is dU/dphi: EI kappa = EI phi / l for small phi, and by central
// differences of U at large ones; bendingMoments lists each bend's at its particle.
TEST(Bending, TheMomentIsTheEnergysRateInTheAngle)
{
  const BendingForce joint{ 0, 1, 2, 0.7, 0.05 };
  const std::vector<double> masses(3, 1.0);
  EXPECT_EQ(bendingMoment(joint, jointAt(0.0, 0.05)), 0.0);
  EXPECT_NEAR(bendingMoment(joint, jointAt(1e-4, 0.05)) / (0.7 * 1e-4 / 0.05), 1.0, 1e-8);
  for (const double phi : { 0.3, 1.0, 2.0, 3.0 })
  {
    const double rate = (potentialEnergy(joint, masses, jointAt(phi + 1e-6, 0.05)) -
                         potentialEnergy(joint, masses, jointAt(phi - 1e-6, 0.05))) /
                        2e-6;
    EXPECT_NEAR(bendingMoment(joint, jointAt(phi, 0.05)), rate, 1e-6 * rate) << phi;
  }
  Points folded = jointAt(M_PI, 0.05);
  folded(2, 2) = 0.0;
  EXPECT_TRUE(std::isfinite(bendingMoment(joint, folded)));
  Scene scene;
  scene.masses.assign(4, 1.0);
  scene.forces = { GravityForce{}, BendingForce{ 1, 2, 3, 0.7, 0.05 }, joint };
  const Model model = Model::compile(scene);
  Points p = Points::Zero(3, 4);
  p.leftCols(3) = jointAt(1.0, 0.05);
  p.col(3) = p.col(2) + Vec3(0.05, 0.0, 0.0);
  const std::vector<JointMoment> moments = bendingMoments(model, p);
  ASSERT_EQ(moments.size(), 2u);
  EXPECT_EQ(moments[0].particle, 2);
  EXPECT_EQ(moments[0].moment, bendingMoment(BendingForce{ 1, 2, 3, 0.7, 0.05 }, p));
  EXPECT_EQ(moments[1].particle, 1);
  EXPECT_EQ(moments[1].moment, bendingMoment(joint, p));
}

// A rope hanging at rest from a pin: each link's tension is the weight of the particles below it
// (1e-9 relative), under links and slack links alike, in the scene's order; a slack link gone
// slack pulls nothing.
TEST(RopeReadings, AHangingRopesTensionsAreTheWeightBelowEachLink)
{
  const int n = 8;
  const double m = 0.3, l = 0.2;
  for (const bool slack : { false, true })
  {
    Scene scene;
    scene.masses.assign(n, m);
    scene.forces = { GravityForce{} };
    Points p = Points::Zero(3, n);
    for (int i = 0; i < n; ++i)
      p(2, i) = -i * l;
    scene.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
    for (int i = 0; i + 1 < n; ++i)
      if (slack)
        scene.constraints.push_back(SlackLink{ i, i + 1, l });
      else
        scene.constraints.push_back(LinkConstraint{ i, i + 1, l });
    Simulator simulator(scene, stateOf(p, Points::Zero(3, n)), StepSettings{});
    simulator.step(200);
    const std::vector<LinkTension> tensions =
        linkTensions(simulator.model(), simulator.state().positions, simulator.data().multipliers);
    ASSERT_EQ(tensions.size(), static_cast<std::size_t>(n - 1)) << slack;
    for (int k = 0; k + 1 < n; ++k)
    {
      EXPECT_EQ(tensions[k].first, k);
      EXPECT_EQ(tensions[k].second, k + 1);
      const double below = (n - 1 - k) * m * 9.81;
      EXPECT_NEAR(tensions[k].tension / below, 1.0, 1e-9) << (slack ? "slack " : "") << k;
    }
  }
  // a slack link with its particles closer than its length pulls nothing
  Scene loose;
  loose.masses = { 1.0, 1.0 };
  loose.constraints = { PinConstraint{ 0, Vec3::Zero() }, SlackLink{ 0, 1, 1.0 } };
  Points p = Points::Zero(3, 2);
  p(0, 1) = 0.5;
  Simulator simulator(loose, stateOf(p, Points::Zero(3, 2)), StepSettings{});
  simulator.step(10);
  const std::vector<LinkTension> tensions =
      linkTensions(simulator.model(), simulator.state().positions, simulator.data().multipliers);
  ASSERT_EQ(tensions.size(), 1u);
  EXPECT_EQ(tensions[0].tension, 0.0);
  EXPECT_THROW(linkTensions(simulator.model(), p, Eigen::VectorXd()), std::invalid_argument);
}
