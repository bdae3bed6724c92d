// dynamic_reconfigure's config to and from the node's settings by the field descriptors
// (reconfigure_mapping.hpp): every cfg parameter is a field or a scene override, a changed value
// reaches its field and an unchanged one leaves the candidate alone.
#include "constrained_particles/ros/reconfigure_mapping.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <iterator>
#include <cmath>
#include <set>

namespace constrained_particles
{
namespace
{
SceneDescription chainScene()
{
  return loadSceneFile(std::string(SCENES_DIR) + "/chain.yaml");
}

TEST(ReconfigureMapping, EveryCfgParameterIsAFieldOrASceneOverride)
{
  std::set<std::string> mapped;
  for (const std::string& name : reconfigurableFields())
    mapped.insert(name);
  for (const std::string& name : { "gravity_x", "gravity_y", "gravity_z", "damping" })
    mapped.insert(name);
  std::set<std::string> parameters;
  for (const auto& description : SimulatorConfig::__getParamDescriptions__())
    parameters.insert(description->name);
  EXPECT_EQ(mapped, parameters);
  // the thirteen fields the node used to list by hand, twice
  EXPECT_EQ(reconfigurableFields().size(), 13u);
}

TEST(ReconfigureMapping, AChangedValueReachesItsFieldAndNothingElseMoves)
{
  const SceneDescription scene = chainScene();
  NodeParameters before;
  NodeParameters after = before;
  after.step.dt = 0.002;
  after.step.integrator = "semi_implicit_euler";
  after.step.stabilization = Stabilization::Baumgarte;
  after.step.baumgarte_frequency = 5.0;
  after.step.baumgarte_damping_ratio = 0.5;
  after.step.adaptive_tolerance = 1e-6;
  after.step.max_substeps = 16;
  after.step.energy_budget = 0.05;
  after.real_time_factor = 2.0;
  after.publish_rate = 20.0;
  after.accuracy_window = 1.5;
  after.tf_frames = 3;
  after.interactive = !before.interactive;
  const SimulatorConfig shown = configFrom(before, scene);
  EXPECT_EQ(shown.dt, before.step.dt);
  EXPECT_EQ(shown.integrator, before.step.integrator);
  EXPECT_EQ(shown.stabilization, stabilizationName(before.step.stabilization));
  EXPECT_EQ(shown.gravity_z, sceneGravity(scene).z());
  SimulatorConfig requested = configFrom(after, scene);
  requested.gravity_x = 1.0;
  NodeParameters candidate = before;
  applyChangedFields(shown, requested, scene, candidate);
  EXPECT_EQ(candidate.step, after.step);
  EXPECT_EQ(candidate.real_time_factor, 2.0);
  EXPECT_EQ(candidate.publish_rate, 20.0);
  EXPECT_EQ(candidate.accuracy_window, 1.5);
  EXPECT_EQ(candidate.tf_frames, 3);
  EXPECT_EQ(candidate.interactive, after.interactive);
  ASSERT_TRUE(candidate.overrides.gravity.has_value());
  EXPECT_EQ(candidate.overrides.gravity->x(), 1.0);
  EXPECT_EQ(candidate.overrides.gravity->z(), sceneGravity(scene).z());
  EXPECT_FALSE(candidate.overrides.damping.has_value());
  // what the request left alone stays as the candidate has it, even where shown differs
  NodeParameters untouched = before;
  untouched.step.dt = 0.005;
  applyChangedFields(shown, shown, scene, untouched);
  EXPECT_EQ(untouched.step.dt, 0.005);
  EXPECT_FALSE(untouched.overrides.gravity.has_value());
}

// One field at a time: each reaches its own field and no other.
TEST(ReconfigureMapping, EachFieldAloneReachesOnlyItself)
{
  const SceneDescription scene = chainScene();
  const NodeParameters before;
  const SimulatorConfig shown = configFrom(before, scene);
  struct Case
  {
    const char* name;
    void (*change)(NodeParameters&);
  };
  const Case cases[] = {
    { "dt", [](NodeParameters& p) { p.step.dt = 0.003; } },
    { "integrator", [](NodeParameters& p) { p.step.integrator = "dopri5"; } },
    { "stabilization", [](NodeParameters& p) { p.step.stabilization = Stabilization::None; } },
    { "baumgarte_frequency", [](NodeParameters& p) { p.step.baumgarte_frequency = 3.0; } },
    { "baumgarte_damping_ratio", [](NodeParameters& p) { p.step.baumgarte_damping_ratio = 0.7; } },
    { "adaptive_tolerance", [](NodeParameters& p) { p.step.adaptive_tolerance = 1e-5; } },
    { "max_substeps", [](NodeParameters& p) { p.step.max_substeps = 8; } },
    { "energy_budget", [](NodeParameters& p) { p.step.energy_budget = 0.2; } },
    { "real_time_factor", [](NodeParameters& p) { p.real_time_factor = 3.0; } },
    { "publish_rate", [](NodeParameters& p) { p.publish_rate = 12.0; } },
    { "accuracy_window", [](NodeParameters& p) { p.accuracy_window = 2.0; } },
    { "tf_frames", [](NodeParameters& p) { p.tf_frames = 7; } },
    { "interactive", [](NodeParameters& p) { p.interactive = !p.interactive; } },
  };
  EXPECT_EQ(std::size(cases), reconfigurableFields().size());
  for (const Case& c : cases)
  {
    NodeParameters expected = before;
    c.change(expected);
    NodeParameters candidate = before;
    applyChangedFields(shown, configFrom(expected, scene), scene, candidate);
    EXPECT_EQ(candidate.step, expected.step) << c.name;
    EXPECT_EQ(candidate.real_time_factor, expected.real_time_factor) << c.name;
    EXPECT_EQ(candidate.publish_rate, expected.publish_rate) << c.name;
    EXPECT_EQ(candidate.accuracy_window, expected.accuracy_window) << c.name;
    EXPECT_EQ(candidate.tf_frames, expected.tf_frames) << c.name;
    EXPECT_EQ(candidate.interactive, expected.interactive) << c.name;
    EXPECT_FALSE(candidate.overrides.gravity.has_value()) << c.name;
  }
}

TEST(ReconfigureMapping, AnUnknownIntegratorIsRefusedNamingTheField)
{
  const SceneDescription scene = chainScene();
  const NodeParameters before;
  const SimulatorConfig shown = configFrom(before, scene);
  SimulatorConfig requested = shown;
  requested.integrator = "leapfrog";
  NodeParameters candidate = before;
  try
  {
    applyChangedFields(shown, requested, scene, candidate);
    FAIL() << "an unknown integrator was taken";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_EQ(e.field(), "integrator");
  }
  // NaN never equals itself: taken, for the runner's validation to refuse with its range
  requested = shown;
  requested.dt = NAN;
  applyChangedFields(shown, requested, scene, candidate);
  EXPECT_TRUE(std::isnan(candidate.step.dt));
}

}  // namespace
}  // namespace constrained_particles
