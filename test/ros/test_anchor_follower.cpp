/// @file test_anchor_follower.cpp
/// @brief AnchorFollower: holder samples onto a simulator's tracks (no ROS master).
#include "constrained_particles/ros/anchor_follower.hpp"

#include <gtest/gtest.h>

using namespace constrained_particles;

namespace
{
// a chain of 3 hanging from a frame anchor at the origin
Simulator heldChain()
{
  Scene scene;
  scene.masses = { 0.1, 0.1, 0.1 };
  scene.constraints = { LinkConstraint{ 0, 1, 0.2 }, LinkConstraint{ 1, 2, 0.2 } };
  FrameAnchorConstraint anchor;
  anchor.particle = 0;
  anchor.frame = "hand";
  scene.constraints.push_back(anchor);
  scene.forces = { GravityForce{} };
  Points p(3, 3);
  p << 0, 0, 0, 0, 0, 0, 0, -0.2, -0.4;
  State start;
  start.positions = p;
  start.velocities = Points::Zero(3, 3);
  return Simulator(scene, start, StepSettings{});
}

HolderSample at(std::int64_t stamp_ns, const Vec3& position)
{
  HolderSample sample;
  sample.stamp_ns = stamp_ns;
  sample.position = position;
  return sample;
}

// stamps [ns] are sim time [s] x 1e9: the mapping the tests give
double simTime(std::int64_t stamp_ns)
{
  return static_cast<double>(stamp_ns) * 1e-9;
}
}  // namespace

TEST(AnchorFollower, SortsSamplesIntoTakenLateUnorderedFutureAndOutOfRange)
{
  Simulator simulator = heldChain();
  AnchorFollower follower;
  follower.setModel(1, simulator.model());
  simulator.step(100);                 // t = 0.1 s at the default dt of 1 ms
  const std::int64_t lag = 100000000;  // 0.1 s
  follower.post(1, 0,
                { at(10000000, Vec3(0.01, 0, 0)),           // 0.01 + 0.1 = 0.11 s: taken
                  at(5000000, Vec3(0.01, 0, 0)),            // before the last knot: unordered
                  at(20000000, Vec3(0.02, 0, 0)),           // taken
                  at(9000000000, Vec3(0.03, 0, 0)),         // 9.1 s: over 5 s ahead of 0.2 s
                  at(30000000, Vec3(2e6, 0, 0)) });         // outside limits::COORDINATE
  follower.post(2, 0, { at(40000000, Vec3(0.04, 0, 0)) });  // another model's: dropped
  follower.post(1, 0, { at(-50000000, Vec3(0.0, 0, 0)) });  // 0.05 s: before the last knot too
  const auto jumps = follower.apply(simulator, simTime, lag, 0.5, 1e-3);
  EXPECT_TRUE(jumps.empty());
  const HolderStatus& status = follower.status()[0];
  EXPECT_EQ(status.holder, "hand");
  EXPECT_EQ(status.taken, 2u);
  EXPECT_EQ(status.unordered, 2u);  // the earlier one, and the late one after the knots
  EXPECT_EQ(status.future, 1u);
  EXPECT_EQ(status.out_of_range, 1u);
  EXPECT_EQ(simulator.tracks()[0].last().position, Vec3(0.02, 0, 0));
  // late: a fresh track (no knot after it) and a time already past
  follower.setModel(3, simulator.model());
  simulator.tracks()[0].restart(Vec3::Zero());
  follower.post(3, 0, { at(-50000000, Vec3(0.0, 0, 0)) });
  follower.apply(simulator, simTime, lag, 0.5, 1e-3);
  EXPECT_EQ(follower.status()[0].late, 1u);
}

TEST(AnchorFollower, AJumpRestartsTheTrackAndReportsItsDisplacement)
{
  Simulator simulator = heldChain();
  AnchorFollower follower;
  follower.setModel(1, simulator.model());
  const std::int64_t lag = 100000000;
  follower.post(1, 0,
                { at(10000000, Vec3(0.01, 0, 0)), at(20000000, Vec3(1.0, 0, 0)),
                  at(30000000, Vec3(3.0, 0, 0)) });
  const auto jumps = follower.apply(simulator, simTime, lag, 0.5, 1e-3);
  ASSERT_EQ(jumps.size(), 1u);  // two jumps of one holder in one post: one, summed
  EXPECT_EQ(jumps[0].first, 0);
  EXPECT_LE((jumps[0].second - Vec3(2.99, 0, 0)).norm(), 1e-15);
  EXPECT_EQ(follower.status()[0].jumps, 2u);
  EXPECT_EQ(simulator.tracks()[0].size(), 0u);  // at rest at the last jump's pose
  EXPECT_EQ(simulator.tracks()[0].hold(), Vec3(3.0, 0, 0));
}
