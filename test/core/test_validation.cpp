// Bad input to the core is refused with an error naming the field, and changes nothing.
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

#include <limits>

using namespace constrained_particles;

namespace
{
constexpr double NaN = std::numeric_limits<double>::quiet_NaN();
constexpr double INF = std::numeric_limits<double>::infinity();

// runs fn, expects InvalidInput whose field is `field` and whose message mentions `mention`
template <typename Fn>
void expectRefused(Fn fn, const std::string& field, const std::string& mention = "")
{
  try
  {
    fn();
    ADD_FAILURE() << "accepted; expected refusal naming " << field;
  }
  catch (const InvalidInput& e)
  {
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    if (!mention.empty())
    {
      EXPECT_NE(std::string(e.what()).find(mention), std::string::npos) << e.what();
    }
  }
}

Scene validChain()
{
  Scene scene;
  scene.masses = { 1.0, 1.0, 1.0 };
  scene.constraints = { LinkConstraint{ 0, 1, 1.0 }, LinkConstraint{ 1, 2, 1.0 } };
  scene.forces = { GravityForce{} };
  return scene;
}

}  // namespace

TEST(Validation, SceneFieldsAreNamed)
{
  Scene s = validChain();
  s.masses.clear();
  expectRefused([&] { Model::compile(s); }, "masses", "at least 1");
  for (double bad : { 0.0, -1.0, NaN, INF })
  {
    s = validChain();
    s.masses[1] = bad;
    expectRefused([&] { Model::compile(s); }, "masses[1]", "[1e-09, 1e+06] [kg]");
  }
  for (double bad : { 0.0, -2.0, NaN, INF })
  {
    s = validChain();
    std::get<LinkConstraint>(s.constraints[1]).length = bad;
    expectRefused([&] { Model::compile(s); }, "constraints[1].length", "[1e-06, 1000] [m]");
  }
  s = validChain();
  std::get<LinkConstraint>(s.constraints[0]).second = 7;
  expectRefused([&] { Model::compile(s); }, "constraints[0].second", "[0, 2]");
  s = validChain();
  std::get<LinkConstraint>(s.constraints[0]).second = 0;
  expectRefused([&] { Model::compile(s); }, "constraints[0].second", "differ");
  s = validChain();
  s.constraints.push_back(SurfaceConstraint{ 0, 0 });
  expectRefused([&] { Model::compile(s); }, "constraints[2].surface");
  s = validChain();
  s.forces = { GravityForce{ Vec3(0, NaN, 0) } };
  expectRefused([&] { Model::compile(s); }, "forces[0].acceleration.y");
  s = validChain();
  s.forces = { LinearDampingForce{ -1.0 } };
  expectRefused([&] { Model::compile(s); }, "forces[0].coefficient", "[0, 1e+06] [N s/m]");
  s = validChain();
  s.forces = { ExternalForce{ 3, Vec3(0, 0, 1) } };
  expectRefused([&] { Model::compile(s); }, "forces[0].particle");
  s = validChain();
  s.constraints.push_back(PinConstraint{ 0, Vec3(INF, 0, 0) });
  expectRefused([&] { Model::compile(s); }, "constraints[2].anchor.x");
  s = validChain();
  s.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
  s.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
  expectRefused([&] { Model::compile(s); }, "constraints[3].particle", "already pinned");
}

// an angle left unset takes the angle the particles start with; a straight start is refused
// with the reason (no gradient at pi), not only the range
TEST(Validation, StraightAngleStartIsRefusedWithItsReason)
{
  const std::string head =
      "particles: [{position: [0, 0, 1]}, {position: [1, 0, 1]}, "
      "{position: [2, 0, 1]}]\n"
      "constraints:\n  - {type: link, first: 0, second: 1}\n"
      "  - {type: link, first: 1, second: 2}\n";
  auto refusal = [](const std::string& text) -> std::string
  {
    try
    {
      buildScene(parseScene(text, "angle.yaml"));
    }
    catch (const InvalidInput& e)
    {
      return e.what();
    }
    return "accepted";
  };
  const std::string straight = refusal(head + "  - {type: angle, particles: [0, 1, 2]}\n");
  EXPECT_NE(straight.find("constraints[2].angle = 3.14159"), std::string::npos) << straight;
  EXPECT_NE(straight.find("straight (pi)"), std::string::npos) << straight;
  const std::string folded = refusal(head + "  - {type: angle, particles: [0, 1, 2], angle: 0}\n");
  // a written angle out of range is refused as it is read, with its range
  EXPECT_NE(folded.find("constraints[2].angle = 0, must be in [0.001, 3.14] [rad]"),
            std::string::npos)
      << folded;
  // bent a little, it is taken
  EXPECT_EQ(refusal("particles: [{position: [0, 0, 1]}, {position: [1, 0, 1]}, "
                    "{position: [2, 0.1, 1]}]\n"
                    "constraints: [{type: angle, particles: [0, 1, 2]}]\n"),
            "accepted");
}

// a surface that puts its particle out of range, or is undefined where it starts, is refused
// when the scene is built, naming the particle and why
TEST(Validation, PlacementOutOfRangeIsRefused)
{
  auto refusal = [](const std::string& expression, const std::string& velocity)
  {
    try
    {
      buildScene(
          parseScene("surfaces: {ground: {type: expression, expression: '" + expression +
                         "'}}\nparticles: [{position: [0.5, 0, 0], velocity: " + velocity +
                         "}]\nconstraints: [{type: surface, particle: 0, surface: ground}]\n",
                     "placed.yaml"));
    }
    catch (const InvalidInput& e)
    {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string high = refusal("1e308*x*x", "[0, 0, 0]");
  EXPECT_NE(high.find("particle 0 position.z = 2.5e+307"), std::string::npos) << high;
  EXPECT_NE(high.find("[-1e+06, 1e+06] [m]"), std::string::npos) << high;
  const std::string undefined = refusal("sqrt(x-5)", "[0, 0, 0]");
  EXPECT_NE(undefined.find("particle 0 position.z"), std::string::npos) << undefined;
  EXPECT_NE(undefined.find("a surface must be defined"), std::string::npos) << undefined;
  // a steep slope lifts the velocity into the tangent plane, out of range
  const std::string steep = refusal("1e5*x", "[100, 0, 0]");
  EXPECT_NE(steep.find("particle 0 velocity.z"), std::string::npos) << steep;
  EXPECT_EQ(refusal("0.5*x*x", "[1, 0, 0]"), "accepted");
}

// constraints that cannot all hold at the start are refused naming the one left furthest off
TEST(Validation, InfeasibleStartNamesTheConstraint)
{
  Scene scene;
  scene.masses = { 1.0, 1.0 };
  scene.constraints = { PinConstraint{ 0, Vec3::Zero() }, PinConstraint{ 1, Vec3(2, 0, 0) },
                        LinkConstraint{ 0, 1, 1.0 } };
  State start;
  start.positions = Points::Zero(3, 2);
  start.positions(0, 1) = 2.0;
  start.velocities = Points::Zero(3, 2);
  expectRefused([&] { Simulator simulator(scene, start, StepSettings{}); },
                "initial_state.positions", "largest at a link on particles 0 1");
}

TEST(Validation, SurfacesAreChecked)
{
  expectRefused([] { makeSurface("cone", {}); }, "surface.type", "bowl");
  expectRefused([] { makeSurface("bowl", { NaN }); }, "surface.coefficients[0] (curvature_x)");
  expectRefused(
      [] {
        makeSurface("bowl", { 1.0, -1.0 });
      },
      "surface.coefficients[1] (curvature_y)", "[0, 1e+06]");
  expectRefused([] { makeSurface("gaussian", { 1.0, 0.0 }); }, "surface.coefficients[1] (width)");
  expectRefused([] { makeSurface("plane", { 1, 2, 3, 4 }); }, "surface.coefficients", "at most 3");
}

// what ~set_chain and ~chain/* change is checked before the scene is touched
TEST(Validation, ChainChangesAreChecked)
{
  ChainChange p;
  p.num_particles = 0;
  expectRefused([&] { validateChainChange(p, 1000000, "chain."); }, "chain.num_particles",
                "[1, 1000000]");
  p = ChainChange{};
  p.link_length = -0.5;
  expectRefused([&] { validateChainChange(p, 1000000, "chain."); }, "chain.link_length");
  p = ChainChange{};
  p.particle_mass = 0.0;
  expectRefused([&] { validateChainChange(p, 1000000, "chain."); }, "chain.particle_mass");
  Scene bead = constrained_particles::testing::shippedScene("bead").scene;
  bead.forces = { GravityForce{ Vec3(0, 0, NaN) } };
  expectRefused([&] { Model::compile(bead); }, "forces[0].acceleration.z");
  bead.forces = { LinearDampingForce{ -0.1 } };
  expectRefused([&] { Model::compile(bead); }, "forces[0].coefficient");
}

TEST(Validation, StepSettingsAreChecked)
{
  StepSettings s;
  for (double bad : { 0.0, -1e-3, NaN, INF, 2.0 })
  {
    s = StepSettings{};
    s.dt = bad;
    expectRefused([&] { validateStepSettings(s); }, "dt", "[1e-06, 1] [s]");
  }
  // 0 or 1e-300 made a dopri5 step never return
  for (double bad : { 0.0, 1e-300, -1.0, NaN, INF, 2.0 })
  {
    s = StepSettings{};
    s.adaptive_tolerance = bad;
    expectRefused([&] { validateStepSettings(s); }, "adaptive_tolerance", "[1e-14, 1] [1]");
  }
  s = StepSettings{};
  s.baumgarte_frequency = NaN;
  expectRefused([&] { validateStepSettings(s); }, "baumgarte_frequency");
  s = StepSettings{};
  s.baumgarte_damping_ratio = -1;
  expectRefused([&] { validateStepSettings(s); }, "baumgarte_damping_ratio");
  expectRefused([] { findIntegrator("leapfrog"); }, "integrator", "rk4");
  s = StepSettings{};
  s.integrator = "leapfrog";
  expectRefused([&] { validateStepSettings(s); }, "integrator", "velocity_verlet");
  expectRefused([] { parseStabilization("magic"); }, "stabilization", "projection");
  // an enum value cast from a bad integer is refused by name, not read out of bounds
  s = StepSettings{};
  s.stabilization = static_cast<Stabilization>(7);
  expectRefused([&] { validateStepSettings(s); }, "stabilization", "baumgarte");
}

TEST(Validation, RefusedChangesLeaveSimulatorUntouched)
{
  const BuiltScene scenario = constrained_particles::testing::shippedScene("chain");
  Simulator simulator(scenario.scene, scenario.initial_state, StepSettings{});
  simulator.step(25);
  const State before = simulator.state();
  const StepSettings settings_before = simulator.stepSettings();
  const int particles_before = simulator.model().numParticles();
  auto unchanged = [&]
  {
    EXPECT_EQ(simulator.state().positions, before.positions);
    EXPECT_EQ(simulator.state().velocities, before.velocities);
    EXPECT_EQ(simulator.state().time, before.time);
    EXPECT_EQ(simulator.state().steps, before.steps);
    EXPECT_EQ(simulator.model().numParticles(), particles_before);
    EXPECT_EQ(simulator.stepSettings().dt, settings_before.dt);
  };

  State bad = before;
  bad.positions(2, 3) = NaN;
  expectRefused([&] { simulator.setState(bad); }, "positions[3].z");
  unchanged();
  bad = before;
  bad.velocities.conservativeResize(3, 2);
  expectRefused([&] { simulator.setState(bad); }, "velocities", "one per particle");
  unchanged();

  Scene bad_scene = scenario.scene;
  bad_scene.masses[0] = -1;
  expectRefused([&] { simulator.setScene(bad_scene, scenario.initial_state); }, "masses[0]");
  unchanged();
  State wrong_size = scenario.initial_state;
  wrong_size.positions.conservativeResize(3, 1);
  expectRefused([&] { simulator.setScene(scenario.scene, wrong_size); }, "initial_state.positions");
  unchanged();

  StepSettings bad_settings = simulator.stepSettings();
  bad_settings.dt = -1;
  expectRefused([&] { simulator.setStepSettings(bad_settings); }, "dt");
  unchanged();
}

TEST(Validation, TeleportIsProjectedOntoConstraints)
{
  const BuiltScene scenario = constrained_particles::testing::shippedScene("chain");
  Simulator simulator(scenario.scene, scenario.initial_state, StepSettings{});
  State moved = simulator.state();
  moved.positions.col(2) += Vec3(0.05, -0.02, 0.03);
  moved.velocities.col(0) = Vec3(1, 0, 0);  // pinned: must come back to rest
  const ProjectionReport report = simulator.setState(moved);
  EXPECT_TRUE(report.converged);
  EXPECT_GT(report.max_displacement, 0.0);
  EXPECT_LE(report.max_displacement, 0.1);
  const Diagnostics d = simulator.diagnostics();
  EXPECT_LE(d.max_position_error, 1e-10);
  EXPECT_LE(d.max_velocity_error, 1e-10);
}
