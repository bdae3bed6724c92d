// The scene session without a runner: which settings a reset or a scene change runs under, what
// the user chose carrying over to every scene, and refused requests changing nothing.
#include "constrained_particles/ros/scene_session.hpp"
#include "scene_fixtures.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

namespace constrained_particles
{
namespace
{
using fixtures::parametersFor;
using fixtures::scene;

TEST(SceneSession, TheFirstSceneIsAdoptedWithSerialOneAndItsRegion)
{
  SceneSession session(parametersFor("chain"), scene("chain"));
  EXPECT_EQ(session.serial(), 0u);
  const SceneSession::Candidate first = session.initial();
  EXPECT_EQ(first.built.initial_state.positions.cols(), scene("chain").numParticles());
  session.adopt(first.description, first.built.initial_state);
  EXPECT_EQ(session.serial(), 1u);
  EXPECT_EQ(session.scene()->name, "chain");
  const RegionSpec region = sceneRegion(first.description, first.built.initial_state);
  EXPECT_EQ(session.region().low, region.low);
  EXPECT_EQ(session.region().high, region.high);
}

TEST(SceneSession, AResetToAnotherSceneRunsItsOwnSettingsUnderTheUsersOnly)
{
  NodeParameters parameters = parametersFor("chain");
  parameters.step.dt = 0.004;
  parameters.step_given = { "dt" };
  SceneSession session(parameters, scene("chain"));
  StepSettings current = session.initial().settings;
  ASSERT_EQ(current.dt, 0.004);
  current.projection_tolerance = 1e-7;  // in force now, not chosen by the user
  // pinned_pendulum's file says velocity_verlet; the user's dt stands over its 0.001
  const SceneSession::Candidate other = session.forReset("pinned_pendulum", current);
  EXPECT_EQ(other.description.name, "pinned_pendulum");
  EXPECT_EQ(other.settings.integrator, "velocity_verlet");
  EXPECT_EQ(other.settings.dt, 0.004);
  EXPECT_EQ(other.settings.projection_tolerance, StepSettings{}.projection_tolerance);
  // the current scene again keeps every setting in force
  const SceneSession::Candidate again = session.forReset("", current);
  EXPECT_EQ(again.description.name, "chain");
  EXPECT_EQ(again.settings.projection_tolerance, 1e-7);
}

TEST(SceneSession, AStepSettingAReconfigureChangedIsTheUsersForEveryScene)
{
  SceneSession session(parametersFor("chain"), scene("chain"));
  const StepSettings before = session.initial().settings;
  StepSettings after = before;
  after.dt = 0.004;
  session.chooseStep(before, after);
  const StepSettings pendulum = session.settingsFor(scene("pinned_pendulum"));
  EXPECT_EQ(pendulum.dt, 0.004);
  // a field left alone still comes from each scene's own section (the file says velocity_verlet)
  EXPECT_EQ(pendulum.integrator, "velocity_verlet");
  EXPECT_NE(StepSettings{}.integrator, "velocity_verlet");
}

TEST(SceneSession, ARefusedRequestNamesItsFieldAndChangesNothing)
{
  NodeParameters parameters = parametersFor("chain");
  parameters.max_particles = scene("chain").numParticles();
  SceneSession session(parameters, scene("chain"));
  const SceneSession::Candidate first = session.initial();
  session.adopt(first.description, first.built.initial_state);
  ChainChange longer;
  longer.num_particles = parameters.max_particles + 1;
  longer.link_length = 0.1;
  longer.particle_mass = 0.1;
  try
  {
    session.forChange([&](SceneDescription& d) { setChains(d, longer); }, first.settings);
    FAIL() << "a chain over ~max_particles was accepted";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_EQ(e.field(), "num_particles");
    EXPECT_NE(std::string(e.what()).find("~max_particles"), std::string::npos) << e.what();
  }
  EXPECT_THROW(session.forReset("no_such_scene", first.settings), InvalidInput);
  EXPECT_EQ(session.serial(), 1u);
  EXPECT_EQ(session.scene()->numParticles(), parameters.max_particles);
  SceneDescription over = scene("chain");
  setChains(over, longer);
  try
  {
    SceneSession refused(parameters, over);
    FAIL() << "a first scene over ~max_particles was accepted";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_EQ(e.field(), "~scenario");
  }
}

TEST(SceneSession, SceneRequestsAreCheckedHereNamingTheirField)
{
  NodeParameters parameters = parametersFor("surface_chain");
  parameters.max_particles = 50;
  SceneSession session(parameters, scene("surface_chain"));
  const SceneSession::Candidate first = session.initial();
  session.adopt(first.description, first.built.initial_state);
  const auto refusedField = [&](const std::function<void()>& request)
  {
    try
    {
      request();
    }
    catch (const InvalidInput& e)
    {
      return e.field();
    }
    return std::string("(accepted)");
  };
  const StepSettings& s = first.settings;
  EXPECT_EQ(refusedField([&] { session.forSurface("hyperbolic", {}, "", s); }), "type");
  EXPECT_EQ(refusedField([&] { session.forSurface("expression", { 1.0 }, "x*y", s); }),
            "coefficients");
  EXPECT_EQ(refusedField(
                [&] {
                  session.forSurface("plane", { 0, 0, 0 }, "x*y", s);
                }),
            "expression");
  EXPECT_EQ(refusedField([&] { session.forSurface("expression", {}, "x*", s); }), "expression");
  ChainChange chain;
  chain.num_particles = 0;
  chain.link_length = 0.1;
  chain.particle_mass = 0.1;
  EXPECT_EQ(refusedField([&] { session.forChain(chain, s); }), "num_particles");
  try
  {
    chain.num_particles = 51;
    session.forChain(chain, s);
    ADD_FAILURE() << "a chain of 51 was accepted under ~max_particles 50";
  }
  catch (const InvalidInput& e)
  {
    // the request's own range, with ~max_particles as its top
    EXPECT_NE(std::string(e.what()).find("[1, 50]"), std::string::npos) << e.what();
  }
  chain.num_particles = 6;
  chain.link_length = -1.0;
  EXPECT_EQ(refusedField([&] { session.forChain(chain, s); }), "link_length");
  chain.link_length = 0.1;
  chain.particle_mass = std::nan("");
  EXPECT_EQ(refusedField([&] { session.forChain(chain, s); }), "particle_mass");
  EXPECT_EQ(session.serial(), 1u);
  // and accepted, the candidate carries the change; the current scene is unchanged until adopted
  chain.particle_mass = 0.2;
  const SceneSession::Candidate longer = session.forChain(chain, s);
  EXPECT_EQ(longer.built.initial_state.positions.cols(),
            first.built.initial_state.positions.cols() - 5 + 6);
  const SceneSession::Candidate bowl = session.forSurface("expression", {}, "0.5*(x*x+y*y)", s);
  EXPECT_EQ(bowl.description.surfaces.front().surface.type, SurfaceType::Expression);
  EXPECT_EQ(session.scene()->numParticles(), first.description.numParticles());
}

TEST(SceneSession, GravityAndDampingChangeOnlyWhenTheyDiffer)
{
  SceneSession session(parametersFor("chain"), scene("chain"));
  const SceneSession::Candidate first = session.initial();
  session.adopt(first.description, first.built.initial_state);
  const Vec3 gravity = sceneGravity(*session.scene());
  EXPECT_FALSE(session.withGravityAndDamping(gravity, sceneDamping(*session.scene())));
  const std::optional<SceneDescription> moon =
      session.withGravityAndDamping(Vec3(0, 0, -1.62), 0.5);
  ASSERT_TRUE(moon);
  EXPECT_EQ(sceneGravity(*moon), Vec3(0, 0, -1.62));
  EXPECT_EQ(sceneDamping(*moon), 0.5);
  session.adoptChange(*moon);
  EXPECT_EQ(session.serial(), 2u);
  EXPECT_EQ(sceneGravity(*session.scene()), Vec3(0, 0, -1.62));
}

}  // namespace
}  // namespace constrained_particles
