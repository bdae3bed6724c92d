// ~anchor_wrench's force without a master (anchor_wrenches.hpp): what a holder feels against
// closed forms, a pin under a hanging chain and a driven anchor moving a free particle, and the
// topic names frames become.
#include "constrained_particles/ros/anchor_wrenches.hpp"

#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace constrained_particles
{
namespace
{
Simulator simulatorOf(const std::string& yaml, const std::string& integrator)
{
  const BuiltScene built = buildScene(parseScene(yaml, "test"));
  StepSettings settings;
  settings.integrator = integrator;
  return Simulator(built.scene, built.initial_state, settings);
}

TEST(AnchorWrenches, AChainHangingAtRestWeighsOnItsPin)
{
  // n = 6 particles of 0.3 kg hanging straight down from a pin: the pin carries all n weights
  Simulator simulator = simulatorOf(R"(
chains:
  - {particles: 6, link_length: 0.2, particle_mass: 0.3, start: [0, 0, 0], direction: [0, 0, -1], pin_first: true}
forces:
  - {type: gravity, acceleration: [0, 0, -9.81]}
)",
                                    "rk4");
  simulator.step(100);
  Points forces;
  Eigen::VectorXd multipliers;
  simulator.constraintForces(forces, multipliers);
  ASSERT_EQ(simulator.model().eliminatedParticles(), std::vector<int>{ 0 });
  const Vec3 holder = holderForce(simulator.model(), multipliers, 0);
  const double weight = 6 * 0.3 * 9.81;
  EXPECT_LE((holder - Vec3(0.0, 0.0, -weight)).norm(), 1e-12 * weight) << holder.transpose();
}

TEST(AnchorWrenches, ADrivenAnchorFeelsTheInertiaOfWhatItMoves)
{
  // a lone particle of 2 kg driven along x = 0.1 sin(2 pi t), no gravity: the holder feels
  // -m a(t) = m (2 pi)^2 0.1 sin(2 pi t), the particle's inertia (its reaction is m a)
  for (const char* integrator : { "rk4", "velocity_verlet", "semi_implicit_euler" })
  {
    Simulator simulator = simulatorOf(R"(
particles:
  - {mass: 2.0, position: [0, 0, 0]}
constraints:
  - {type: moving_anchor, particle: 0, amplitude: [0.1, 0, 0], frequency: 1.0}
)",
                                      integrator);
    simulator.step(137);
    Points forces;
    Eigen::VectorXd multipliers;
    simulator.constraintForces(forces, multipliers);
    const double t = simulator.state().time;
    const double omega = 2.0 * M_PI;
    const Vec3 expected(2.0 * omega * omega * 0.1 * std::sin(omega * t), 0.0, 0.0);
    const Vec3 holder = holderForce(simulator.model(), multipliers, 0);
    EXPECT_LE((holder - expected).norm(), 1e-12 * 2.0 * omega * omega * 0.1)
        << integrator << ": " << holder.transpose() << " vs " << expected.transpose();
  }
}

TEST(AnchorWrenches, FramesBecomeValidTopicNames)
{
  EXPECT_EQ(anchorWrenchTopic("particle_0"), "anchor_wrench/particle_0");
  EXPECT_EQ(anchorWrenchTopic("robot1/particle_12"), "anchor_wrench/robot1/particle_12");
  EXPECT_EQ(anchorWrenchTopic("rope-a.b7"), "anchor_wrench/rope_a_b7");
  EXPECT_EQ(anchorWrenchTopic("3d/7"), "anchor_wrench/_3d/_7");
  EXPECT_EQ(anchorWrenchTopic("a//b/"), "anchor_wrench/a/b");
}

}  // namespace
}  // namespace constrained_particles
