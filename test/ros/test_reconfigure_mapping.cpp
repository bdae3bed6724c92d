// dynamic_reconfigure's config to and from the node's settings by the field descriptors
// (reconfigure_mapping.hpp): every cfg parameter is a field or a scene override, a changed value
// reaches its field and an unchanged one leaves the candidate alone.
#include "constrained_particles/ros/reconfigure_mapping.hpp"

#include <gtest/gtest.h>

#include <algorithm>
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
