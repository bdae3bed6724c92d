// The step checks' sums (Simulator::takeStep's one sweep for the kinetic energy, the energy
// scale and finiteness) against the sums written out by hand, and when the next step may start
// from the last step's end energies and kept gravity sum.
#include "stabilization.hpp"
#include "test_helpers.hpp"

#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace constrained_particles;

namespace
{
const std::string DIRECTORY = SCENES_DIR;
}  // namespace

// The step checks' one sweep (Simulator::attemptStep) against the sums written out by hand.
TEST(StepCheckSums, OneSweepGivesTheKineticEnergyScaleAndFiniteness)
{
  Scene scene;
  scene.masses = { 1.0, 2.0, 0.5 };
  // damping acts from outside: the scale takes the whole T (an isolated scene's, below, T about
  // the centre of mass)
  scene.forces = { GravityForce{}, LinearDampingForce{} };
  const Model model = Model::compile(scene);
  ASSERT_FALSE(model.isolated());
  State state;
  state.positions.resize(3, 3);
  state.velocities.resize(3, 3);
  state.positions << 0.0, 1.0, -2.0,  //
      0.5, 0.0, 3.0,                  //
      -1.0, 4.0, 0.0;
  state.velocities << 1.0, 0.0, 2.0,  //
      0.0, 3.0, 0.0,                  //
      0.0, 0.0, -1.0;
  Points forces(3, 3);
  forces << 3.0, 0.0, 0.0,  //
      4.0, 0.0, 0.0,        //
      0.0, -2.0, 1.0;
  // 1/2 (1 * 1 + 2 * 9 + 0.5 * 5) = 10.75 J; |f| = 5 + 2 + 1 N; the box is 3 x 3 x 5 m
  const StepCheckSums sums = stepCheckSums(model, state, forces);
  EXPECT_TRUE(sums.finite);
  EXPECT_DOUBLE_EQ(sums.kinetic, 10.75);
  EXPECT_DOUBLE_EQ(sums.scale, 10.75 + 8.0 * std::sqrt(9.0 + 9.0 + 25.0));
  EXPECT_EQ(sums.kinetic, kineticEnergy(model, state));
  // the scale as it was written before the one sweep: Eigen's reductions over the particles
  const Vec3 extent = state.positions.rowwise().maxCoeff() - state.positions.rowwise().minCoeff();
  EXPECT_DOUBLE_EQ(sums.scale,
                   kineticEnergy(model, state) + forces.colwise().norm().sum() * extent.norm());
  // gravity alone: P = (2, 6, -0.5) kg m/s, M = 3.5 kg, |P|^2 / 2M = 40.25 / 7 = 5.75 J
  scene.forces = { GravityForce{} };
  const Model isolated = Model::compile(scene);
  ASSERT_TRUE(isolated.isolated());
  const StepCheckSums about_centre = stepCheckSums(isolated, state, forces);
  EXPECT_DOUBLE_EQ(about_centre.kinetic, 10.75);
  EXPECT_DOUBLE_EQ(about_centre.scale, 5.0 + 1e-9 * 5.75 + 8.0 * std::sqrt(9.0 + 9.0 + 25.0));
  EXPECT_EQ(about_centre.scale, energyScale(isolated, state, forces));
  const double bad[] = { std::numeric_limits<double>::infinity(),
                         -std::numeric_limits<double>::infinity(),
                         std::numeric_limits<double>::quiet_NaN() };
  for (double value : bad)
    for (int where = 0; where < 3; ++where)
    {
      State broken = state;
      if (where == 0)
        broken.positions(2, 1) = value;
      else if (where == 1)
        broken.velocities(0, 2) = value;
      else
        broken.time = value;
      EXPECT_FALSE(stepCheckSums(model, broken, forces).finite) << value << " at " << where;
      EXPECT_FALSE(isFinite(broken));
    }
}

// A step starts from the last step's end energies when nothing has written the state or the
// applied forces since: whenever they are marked current they are what a sweep would measure.
TEST(StepCheckSums, TheNextStepStartsFromTheLastStepsEnergiesOnlyWhileTheyHold)
{
  int current = 0;
  for (const std::string& name : listScenes(DIRECTORY))
    for (const std::string& integrator : integratorNames())
    {
      const SceneDescription description = loadSceneFile(DIRECTORY + "/" + name + ".yaml");
      const BuiltScene built = buildScene(description);
      StepSettings settings = description.solver.applyTo(StepSettings{});
      settings.integrator = integrator;
      Simulator simulator(built.scene, built.initial_state, settings,
                          description.solver.solve_method);
      const std::string what = name + " (" + integrator + ")";
      for (int k = 0; k < 60; ++k)
      {
        simulator.step(1);
        const Data& data = simulator.data();
        if (k == 30)
        {
          Points forces;
          Eigen::VectorXd multipliers;
          simulator.constraintForces(forces, multipliers);  // evaluates the applied forces anew
          EXPECT_FALSE(data.control.end_energies_current) << what;
        }
        if (!data.control.end_energies_current)
          continue;
        ++current;
        const State& x = simulator.state();
        EXPECT_EQ(data.control.end_kinetic, kineticEnergy(simulator.model(), x)) << what;
        EXPECT_EQ(data.control.end_potential, potentialEnergy(simulator.model(), x)) << what;
        EXPECT_EQ(data.control.end_scale, energyScale(simulator.model(), x, data.applied_forces))
            << what;
      }
    }
  EXPECT_GT(current, 1000);
}

// The same where steps fall back to the stiff-safe method, which evaluates the forces again at
// the accepted state: a spring's force there is not the last stage's, so the energies are not
// current then, or are those of the new forces.
TEST(StepCheckSums, AFallbackStepsForcesAreNotTakenForTheLastStages)
{
  const int n = 40;
  Scene scene;
  State start;
  start.positions.resize(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
  {
    scene.masses.push_back(0.01);
    start.positions.col(i) = Vec3(0.01 * i, 0.0, 0.0);
    if (i + 1 < n)
      scene.constraints.push_back(LinkConstraint{ i, i + 1, 0.01 });
  }
  scene.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
  scene.forces = { GravityForce{}, SpringForce{ 1, n - 1, 50.0, 0.0 } };
  StepSettings settings;
  settings.integrator = "rk4";
  settings.dt = 5e-2;
  settings.max_substeps = 4;
  Simulator simulator(scene, start, settings);
  int stiff = 0;
  for (int k = 0; k < 5; ++k)  // the first steps fall back (later ones fail the energy check)
  {
    stiff += simulator.step(1).stiff_steps;
    const Data& data = simulator.data();
    if (!data.control.end_energies_current)
      continue;
    EXPECT_EQ(data.control.end_scale,
              energyScale(simulator.model(), simulator.state(), data.applied_forces))
        << "step " << k;
  }
  EXPECT_GE(stiff, 3);
}

// Whatever writes the state, the forces or the settings between steps leaves the end energies
// not current: the next step measures its start afresh.
TEST(StepCheckSums, WritingTheStateOrForcesBetweenStepsForgetsTheEndEnergies)
{
  const SceneDescription description = loadSceneFile(DIRECTORY + "/chain.yaml");
  const BuiltScene built = buildScene(description);
  const StepSettings settings = description.solver.applyTo(StepSettings{});
  Simulator simulator(built.scene, built.initial_state, settings, description.solver.solve_method);
  const std::vector<std::pair<std::string, std::function<void()>>> writes = {
    { "setState", [&] { simulator.setState(simulator.state()); } },
    { "restoreState", [&] { simulator.restoreState(simulator.state()); } },
    { "setPerturbations", [&] { simulator.setPerturbations({ GravityForce{} }); } },
    { "setStepSettings", [&] { simulator.setStepSettings(settings); } },
    { "setForces", [&] { simulator.setForces(built.scene.forces); } },
    { "reset", [&] { simulator.reset(); } },
  };
  for (const auto& [name, write] : writes)
  {
    simulator.setPerturbations({});
    simulator.step(3);
    ASSERT_TRUE(simulator.data().control.end_energies_current) << "before " << name;
    write();
    EXPECT_FALSE(simulator.data().control.end_energies_current) << name;
  }
}

// Under gravity alone the energy check reads sum |m_i g| kept from the stages
// (Data::gravity_force_sum) instead of a square root per particle: the same sum as a sweep over
// the applied forces gives, and the same scale; with a second force it is summed again.
TEST(StepCheckSums, TheKeptGravitySumIsTheSweptOne)
{
  Scene scene = constrained_particles::testing::pinnedChain({ 0.1, 0.7, 0.3, 1.9 }, 0.2);
  State start;
  start.positions = Points::Zero(3, 4);
  start.velocities = Points::Zero(3, 4);
  for (int i = 0; i < 4; ++i)
    start.positions(0, i) = 0.2 * i;
  Simulator simulator(scene, start, StepSettings{});
  simulator.step(3);
  const Data& data = simulator.data();
  ASSERT_TRUE(data.applied_forces_are_gravity);
  const double swept = forceNormSum(data.applied_forces);
  EXPECT_EQ(data.gravity_force_sum, swept);
  const State& x = simulator.state();
  EXPECT_EQ(stepCheckSums(simulator.model(), x, data.applied_forces, &data.gravity_force_sum).scale,
            stepCheckSums(simulator.model(), x, data.applied_forces).scale);
  // 3.0 kg in all: 3.0 |g| N, the pinned particle's m g included as applied
  EXPECT_NEAR(swept, 3.0 * 9.81, 1e-12);
  scene.forces.push_back(LinearDampingForce{});
  Simulator damped(scene, x, StepSettings{});
  damped.step(2);
  EXPECT_FALSE(damped.data().applied_forces_are_gravity);
}

// The step leaves the violation its last projection measured (StepStatistics::
// end_position_error), so a reader need not evaluate every row again: the same figure as
// diagnostics() on either path; -1 where no projection measured it.
TEST(StepCheckSums, TheStepLeavesTheViolationItsProjectionMeasured)
{
  const Scene chain = constrained_particles::testing::pinnedChain(std::vector<double>(8, 0.1), 0.1);
  const State start = constrained_particles::testing::horizontalStart(8);
  for (const StagePaths paths : { StagePaths::Specialized, StagePaths::Generic })
  {
    StepSettings settings;
    settings.projection_tolerance = 1e-4;  // loose: the error left is not 0
    Simulator simulator(chain, start, settings, SolveMethod::Automatic, paths);
    const StepStatistics statistics = simulator.step(50);
    const double measured = simulator.diagnostics().max_position_error;
    EXPECT_GT(measured, 0.0);
    EXPECT_NEAR(statistics.end_position_error, measured, 1e-15 + 1e-12 * measured);
  }
  for (const char* integrator : { "rk4", "velocity_verlet" })
  {
    StepSettings settings;
    settings.integrator = integrator;
    if (std::string(integrator) == "rk4")
      settings.stabilization = Stabilization::Baumgarte;
    Simulator simulator(chain, start, settings);
    EXPECT_EQ(simulator.step(10).end_position_error, -1.0) << integrator;
  }
}

// A particle alone at rest on a surface has no extent and no motion: the energy-rise check's
// scale (energyScale plus what a sub-step exchanged) is 0, and rounding alone failed it, even in
// ~max_substeps sub-steps (the fuzz found it: rope_on_table set to one particle faulted at t = 0
// under every integrator). The scale is floored at Simulator::ENERGY_SCALE_FLOOR; a real rise
// over it is still caught (the check is test_hard_cases' and test_impacts').
TEST(StepCheckSums, AParticleAloneAtRestOnASurfaceSteps)
{
  SceneDescription d = loadSceneFile(std::string(SCENES_DIR) + "/rope_on_table.yaml");
  ChainChange one;
  one.num_particles = 1;
  one.link_length = 1.9589916587751457;
  one.particle_mass = 5.492910509450149;
  setChains(d, one);
  const BuiltScene built = buildScene(d);
  for (const char* integrator : { "rk4", "midpoint", "dopri5", "semi_implicit_euler" })
  {
    StepSettings settings = d.solver.applyTo(StepSettings{});
    settings.integrator = integrator;
    Simulator simulator(built.scene, built.initial_state, settings);
    const StepStatistics stats = simulator.step(100);
    EXPECT_EQ(stats.failed_check, StepCheck::None) << integrator;
    EXPECT_EQ(stats.rejections[static_cast<int>(StepCheck::EnergyRise)], 0) << integrator;
    EXPECT_LT((simulator.state().positions - built.initial_state.positions).norm(), 1e-12)
        << integrator;
  }
}
