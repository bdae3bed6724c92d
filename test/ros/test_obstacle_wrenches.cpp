// ~obstacle_wrench's load without a master (obstacle_wrenches.hpp): a rope resting on a plane and
// a rope hanging over a post weigh on them as the statics say, and topic names.
#include "constrained_particles/ros/obstacle_wrenches.hpp"

#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iomanip>
#include <sstream>

namespace constrained_particles
{
namespace
{
Simulator simulatorOf(const std::string& yaml)
{
  const BuiltScene built = buildScene(parseScene(yaml, "test"));
  StepSettings settings;
  settings.integrator = "rk4";
  return Simulator(built.scene, built.initial_state, settings);
}

// A rope of 6 x 0.3 kg lying at rest on a plane 0.5 m below the origin, radius 2 cm: the plane
// carries all 6 weights, and their torque about its origin is that of the weights at their places.
TEST(ObstacleWrenches, ARopeRestingOnAPlaneWeighsOnIt)
{
  Simulator simulator = simulatorOf(R"(
shapes:
  floor: {type: plane, position: [0.3, 0.2, -0.5]}
  far: {type: sphere, position: [5, 5, 5], radius: 0.1}
chains:
  - {particles: 6, link_length: 0.2, particle_mass: 0.3, start: [0, 0, -0.48], obstacles: [floor, far], radius: 0.02, friction: 0.4}
forces:
  - {type: gravity, acceleration: [0, 0, -9.81]}
)");
  simulator.step(200);
  const std::vector<ObstacleWrench> loads =
      obstacleWrenches(simulator.model(), simulator.state().positions, simulator.data().contacts);
  ASSERT_EQ(loads.size(), 2u);
  EXPECT_EQ(loads[0].shape, "floor");
  EXPECT_EQ(loads[1].shape, "far");
  const double weight = 0.3 * 9.81;
  EXPECT_LE((loads[0].force - Vec3(0.0, 0.0, -6 * weight)).norm(), 1e-9 * weight)
      << loads[0].force.transpose();
  Vec3 torque = Vec3::Zero();
  for (int i = 0; i < 6; ++i)
  {
    const Vec3 at(0.2 * i, 0.0, -0.5);  // where each ball touches the floor
    torque += (at - Vec3(0.3, 0.2, -0.5)).cross(Vec3(0.0, 0.0, -weight));
  }
  EXPECT_LE((loads[0].torque - torque).norm(), 1e-9 * weight) << loads[0].torque.transpose();
  EXPECT_EQ(loads[1].force, Vec3::Zero());  // touched by nothing
  // another scene's contacts (none): no load, never a read past them
  const std::vector<ObstacleWrench> none =
      obstacleWrenches(simulator.model(), simulator.state().positions, {});
  EXPECT_EQ(none[0].force, Vec3::Zero());
}

// A link pinned at one end (x = -0.1 m) resting on a thin post at x = 0.03 m, its free end's
// 0.5 kg at x = 0.1 m, both balls clear of the post: a lever on a fulcrum. The post carries it
// through the link's capsule (segment_contact) alone, m g 0.2 / 0.13 straight down at its top,
// 0.65 along the link (so no torque about the post's centre below it; a contact point taken at
// 1 - s* would give one).
TEST(ObstacleWrenches, ALeverOnAThinPostWeighsOnItThroughItsCapsule)
{
  Simulator simulator = simulatorOf(R"(
shapes:
  post: {type: capsule, position: [0.03, 0, 0], rpy: [1.5707963267948966, 0, 0], radius: 0.01,
         length: 0.4}
chains:
  - {particles: 2, link_length: 0.2, particle_mass: 0.5, start: [-0.1, 0, 0.015], pin_first: true,
     obstacles: [post], radius: 0.005, capsules: true}
forces:
  - {type: gravity, acceleration: [0, 0, -9.81]}
)");
  simulator.step(200);
  ASSERT_NEAR(simulator.state().positions(2, 1), 0.015, 1e-9);  // held up, its ball clear
  const std::vector<ObstacleWrench> loads =
      obstacleWrenches(simulator.model(), simulator.state().positions, simulator.data().contacts);
  ASSERT_EQ(loads.size(), 1u);
  const double load = 0.5 * 9.81 * 0.2 / 0.13;
  EXPECT_LE((loads[0].force - Vec3(0.0, 0.0, -load)).norm(), 1e-9 * load)
      << loads[0].force.transpose();
  EXPECT_LE(loads[0].torque.norm(), 1e-9 * load) << loads[0].torque.transpose();
}

// A rope hanging at rest over a frictionless horizontal post with equal weights: the post carries
// the whole rope (its reaction balances every weight: nothing else holds it), straight down.
TEST(ObstacleWrenches, APostCarriesTheRopeHangingOverIt)
{
  const double reach = 0.21;  // post radius 0.2 + rope radius 0.01
  const int arc = 16;
  const double link = 2.0 * reach * std::sin(M_PI / (2 * arc));
  std::string particles = "particles:\n";
  auto text = [](double value)
  {
    std::ostringstream out;
    out << std::setprecision(17) << value;
    return out.str();
  };
  auto add = [&](double mass, double x, double z)
  {
    particles +=
        "  - {mass: " + text(mass) + ", position: [" + text(x) + ", 0, " + text(z) + "]}\n";
  };
  add(1.0, reach, -2 * link);
  add(0.01, reach, -link);
  for (int k = 0; k <= arc; ++k)
    add(0.01, reach * std::cos(M_PI * k / arc), reach * std::sin(M_PI * k / arc));
  add(0.01, -reach, -link);
  add(1.0, -reach, -2 * link);
  const int n = arc + 5;
  std::string links = "constraints:\n";
  for (int i = 0; i + 1 < n; ++i)
    links += "  - {type: link, first: " + std::to_string(i) + ", second: " + std::to_string(i + 1) +
             ", length: " + text(link) + "}\n";
  links += "  - {type: shape_contact, particles: all, shape: post, radius: 0.01}\n";
  Simulator simulator = simulatorOf(
      "shapes:\n  post: {type: cylinder, position: [0, 0, 0], rpy: [1.5707963267948966, 0, 0], "
      "radius: 0.2, length: 1}\n" +
      particles + links + "forces:\n  - {type: gravity}\n");
  simulator.step(100);
  const std::vector<ObstacleWrench> loads =
      obstacleWrenches(simulator.model(), simulator.state().positions, simulator.data().contacts);
  ASSERT_EQ(loads.size(), 1u);
  const double weight = (2 * 1.0 + (n - 2) * 0.01) * 9.81;
  EXPECT_LE((loads[0].force - Vec3(0.0, 0.0, -weight)).norm(), 1e-6 * weight)
      << loads[0].force.transpose();
  // symmetric about the post's axis: no torque about it
  EXPECT_LE(std::abs(loads[0].torque.y()), 1e-6 * weight * reach) << loads[0].torque.transpose();
}

TEST(ObstacleWrenches, TopicNamesAreRosNames)
{
  EXPECT_EQ(obstacleWrenchTopic("post"), "obstacle_wrench/post");
  EXPECT_EQ(obstacleWrenchTopic("gripper finger-1"), "obstacle_wrench/gripper_finger_1");
  EXPECT_EQ(obstacleWrenchTopic("2nd"), "obstacle_wrench/_2nd");
}

}  // namespace
}  // namespace constrained_particles
