/// @file test_holder_session.cpp
/// @brief HolderSession: holder samples onto a simulator's tracks, teleports, latency, holds that
/// let go (no ROS master).
#include "constrained_particles/ros/holder_session.hpp"

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

HolderSample at(std::int64_t stamp_ns, const Vec3& position, std::int64_t arrival_ns = -1)
{
  HolderSample sample;
  sample.stamp_ns = stamp_ns;
  sample.arrival_ns = arrival_ns < 0 ? stamp_ns : arrival_ns;
  sample.position = position;
  return sample;
}

// a pacer on the node's own clock (~publish_clock): stamp [ns] = sim time [s] x 1e9
Pacer ownClock()
{
  return Pacer(Pacer::Source::PublishClock, 1.0, [] { return 0.0; });
}
}  // namespace

TEST(HolderSession, SortsSamplesIntoTakenLateUnorderedFutureAndOutOfRange)
{
  Simulator simulator = heldChain();
  HolderSession holders(HolderLimits{});
  holders.setModel(simulator.model(), true);
  const Pacer pacer = ownClock();
  simulator.step(100);  // t = 0.1 s at the default dt of 1 ms
  const std::uint64_t serial = holders.serial();
  holders.post(serial, 0,
               { at(110000000, Vec3(0.0001, 0, 0)),   // 0.11 s: taken
                 at(105000000, Vec3(0.0001, 0, 0)),   // before the last knot: unordered
                 at(120000000, Vec3(0.0002, 0, 0)),   // taken
                 at(9000000000, Vec3(0.0003, 0, 0)),  // 9 s: over 5 s ahead of 0.1 s
                 at(130000000, Vec3(2e6, 0, 0)) });   // outside limits::COORDINATE
  holders.post(serial + 1, 0, { at(140000000, Vec3(0.0004, 0, 0)) });  // another model's
  holders.post(serial, 0, { at(50000000, Vec3(0.0, 0, 0)) });          // before the last knot too
  holders.follow(simulator, pacer, 1e-3);
  const HolderStatus& status = holders.status()[0];
  EXPECT_EQ(status.holder, "hand");
  EXPECT_EQ(status.taken, 2u);
  EXPECT_EQ(status.unordered, 2u);
  EXPECT_EQ(status.future, 1u);
  EXPECT_EQ(status.out_of_range, 1u);
  EXPECT_EQ(status.jumps, 0u);
  EXPECT_EQ(simulator.tracks()[0].last().position, Vec3(0.0002, 0, 0));
  // late: its time already past, with no knot after now
  holders.setModel(simulator.model(), true);
  simulator.tracks()[0].restart(Vec3::Zero());
  holders.post(holders.serial(), 0, { at(50000000, Vec3(0.0, 0, 0)) });
  holders.follow(simulator, pacer, 1e-3);
  EXPECT_EQ(holders.status()[0].late, 1u);
}

// A jump over ~anchor_max_jump, or faster than ~anchor_max_speed, is a teleport at its time,
// counted once with its distance; the scene is carried rigidly (velocities and links kept).
TEST(HolderSession, AJumpIsATeleportCountedOnceAndCarriesTheScene)
{
  Simulator simulator = heldChain();
  HolderLimits limits;
  limits.max_jump = 0.5;
  limits.max_speed = 10.0;
  HolderSession holders(limits);
  holders.setModel(simulator.model(), true);
  const Pacer pacer = ownClock();
  // still at the origin, then 2 m along x at 0.05 s (one sample: no path between)
  holders.post(holders.serial(), 0,
               { at(10000000, Vec3::Zero()), at(20000000, Vec3::Zero()),
                 at(50000000, Vec3(2.0, 0, 0)), at(60000000, Vec3(2.0, 0, 0)) });
  holders.follow(simulator, pacer, 1e-3);
  EXPECT_EQ(holders.status()[0].jumps, 1u);
  EXPECT_DOUBLE_EQ(holders.status()[0].last_jump, 2.0);
  EXPECT_EQ(holders.stepsToNextJump(simulator, 1000), 50u);
  simulator.step(50);
  const State before = simulator.state();
  EXPECT_TRUE(holders.afterChunk(simulator));
  const State after = simulator.state();
  EXPECT_LE((Vec3(after.positions.col(0)) - Vec3(2.0, 0, 0)).norm(), 1e-12);
  EXPECT_LE((after.positions - before.positions - Points(Vec3(2.0, 0, 0).replicate(1, 3))).norm(),
            1e-12);
  EXPECT_LE((after.velocities - before.velocities).norm(), 1e-12);
  // 0.2 m in 5 ms is 40 m/s: over ~anchor_max_speed, a teleport too
  holders.post(holders.serial(), 0, { at(65000000, Vec3(2.2, 0, 0)) });
  holders.follow(simulator, pacer, 1e-3);
  EXPECT_EQ(holders.status()[0].jumps, 2u);
}

// The latency asked is the slowest arrival of a sample two after the knot the steps leave, with
// its margin; ~anchor_lag fixes it.
TEST(HolderSession, LatencyCoversTheArrivalOfTheSampleTwoAhead)
{
  Simulator simulator = heldChain();
  HolderSession holders(HolderLimits{});
  EXPECT_EQ(holders.wantedLatency(), 0.0);  // no model, no holder
  holders.setModel(simulator.model(), true);
  EXPECT_EQ(holders.wantedLatency(),
            HolderSession::INITIAL_LATENCY * HolderSession::LATENCY_FACTOR +
                HolderSession::LATENCY_MARGIN);
  const Pacer pacer = ownClock();
  // 30 Hz, each arriving 5 ms after its stamp, one 20 ms late
  std::vector<HolderSample> samples;
  for (int k = 1; k <= 20; ++k)
  {
    const std::int64_t stamp = 1000000000 + k * 33333333;
    samples.push_back(at(stamp, Vec3::Zero(), stamp + (k == 10 ? 20000000 : 5000000)));
  }
  holders.post(holders.serial(), 0, samples);
  holders.follow(simulator, pacer, 1e-3);
  // the slowest: two intervals and 20 ms
  EXPECT_NEAR(holders.status()[0].needed_latency, 2 * 0.033333333 + 0.020, 1e-9);
  EXPECT_NEAR(
      holders.wantedLatency(),
      (2 * 0.033333333 + 0.020) * HolderSession::LATENCY_FACTOR + HolderSession::LATENCY_MARGIN,
      1e-9);
  HolderLimits fixed;
  fixed.lag = 0.25;
  HolderSession lagged(fixed);
  lagged.setModel(simulator.model(), true);
  EXPECT_EQ(lagged.wantedLatency(), 0.25);
}

// A hold over its limit lets go: the constraints without it, the release noted with why.
TEST(HolderSession, AHoldOverItsLimitLetsGo)
{
  Simulator simulator = heldChain();
  HolderSession holders(HolderLimits{});
  holders.setModel(simulator.model(), true);
  Scene scene = simulator.model().scene();
  holders.limitHolds(scene);
  const auto* anchor = std::get_if<FrameAnchorConstraint>(&scene.constraints.back());
  ASSERT_NE(anchor, nullptr);
  EXPECT_NEAR(anchor->max_force, HolderSession::MAX_FORCE_WEIGHTS * 0.3 * 9.81, 1e-12);
  StepStatistics over;
  over.failed_check = StepCheck::HoldForce;
  over.hold = 0;
  over.hold_force = 1000.0;
  holders.letGo(simulator, over);
  EXPECT_EQ(simulator.model().scene().constraints.size(), 2u);  // the two links
  EXPECT_TRUE(simulator.model().tracked().empty());
  EXPECT_EQ(holders.status().size(), 0u);  // the model set anew: no holder left
  ASSERT_EQ(holders.releases().size(), 1u);
  EXPECT_EQ(holders.releases()[0].particle, 0);
  EXPECT_EQ(holders.releases()[0].holder, "hand");
  EXPECT_NE(holders.releases()[0].why.find("1000"), std::string::npos);
}

// Samples posted for a model an attach, detach or let-go replaced go to the same holder's track in
// the new one (found by particle and holder); those of a holder it dropped are dropped.
TEST(HolderSession, PostsFollowTheirHolderAcrossAModelChange)
{
  Scene scene = heldChain().model().scene();
  FrameAnchorConstraint other;
  other.particle = 2;
  other.frame = "other";
  scene.constraints.push_back(other);
  Simulator simulator(scene, heldChain().state(), StepSettings{});
  HolderSession holders(HolderLimits{});
  holders.setModel(simulator.model(), true);
  ASSERT_EQ(holders.status().size(), 2u);
  ASSERT_EQ(holders.status()[1].holder, "other");
  const std::uint64_t before = holders.serial();
  const Vec3 low(0, 0, -0.4);  // where particle 2 hangs
  // one waiting in the inbox when the model changes, one posted after it for the old model
  holders.post(before, 1, { at(10000000, low), at(20000000, low) });
  holders.post(before, 0, { at(10000000, Vec3::Zero()) });  // "hand": about to be let go
  StepStatistics over;
  over.failed_check = StepCheck::HoldForce;
  over.hold = 0;
  over.hold_force = 1000.0;
  holders.letGo(simulator, over);
  ASSERT_EQ(holders.status().size(), 1u);
  EXPECT_EQ(holders.status()[0].holder, "other");
  EXPECT_NE(holders.serial(), before);
  holders.post(before, 1, { at(30000000, low) });
  holders.post(before, 0, { at(40000000, Vec3::Zero()) });  // its holder is gone: dropped
  const Pacer pacer = ownClock();
  holders.follow(simulator, pacer, 1e-3);
  EXPECT_EQ(holders.status()[0].taken, 3u);
  EXPECT_EQ(simulator.tracks()[0].last().position, low);
  // "hand" held again (an ~attach): samples made for its first hold, before it was let go, are
  // not the new hold's
  HolderSession::AttachRequest again;
  again.particle = 0;
  again.frame = "hand";
  again.keep_offset = true;
  holders.attach(simulator, again, Eigen::Isometry3d::Identity(), 40000000);
  ASSERT_EQ(holders.status().size(), 2u);
  const int hand = holders.status()[0].holder == "hand" ? 0 : 1;
  holders.post(before, 0, { at(60000000, Vec3(0.001, 0, 0)) });
  holders.follow(simulator, pacer, 1e-3);
  EXPECT_EQ(holders.status()[hand].taken, 0u);
  // a new scene: the old scene's samples are another run's
  holders.setModel(simulator.model(), true);
  holders.post(before, 1, { at(70000000, low) });
  holders.follow(simulator, pacer, 1e-3);
  for (const HolderStatus& status : holders.status())
    EXPECT_EQ(status.taken, 0u) << status.holder;
}

// A still holder's sample (a chain on /tf_static) leaves the point at rest there: it does not
// coast on at the velocity the track had before it.
TEST(HolderSession, AStillSampleLeavesThePointAtRest)
{
  for (const bool still : { false, true })
  {
    Simulator simulator = heldChain();
    HolderSession holders(HolderLimits{});
    holders.setModel(simulator.model(), true);
    HolderSample last = at(30000000, Vec3(0.02, 0, 0));
    last.still = still;
    holders.post(holders.serial(), 0,
                 { at(10000000, Vec3::Zero()), at(20000000, Vec3(0.01, 0, 0)), last });
    holders.follow(simulator, ownClock(), 1e-3);
    const ImposedMotion later = simulator.tracks()[0].motion(0.2);
    if (still)
    {
      EXPECT_EQ(later.velocity, Vec3::Zero());
      EXPECT_EQ(later.position, Vec3(0.02, 0, 0));
    }
    else
      EXPECT_GT(later.velocity.norm(), 0.1);  // a moving holder's newest sample: it coasts on
  }
}

// A sample that arrived over FUTURE_LIMIT after its stamp is of another clock: counted late, and
// it does not measure the latency (which would otherwise ask for seconds of it).
TEST(HolderSession, ASampleSecondsLateIsCountedAndNotMeasured)
{
  Simulator simulator = heldChain();
  HolderSession holders(HolderLimits{});
  holders.setModel(simulator.model(), true);
  const double initial = holders.wantedLatency();
  std::vector<HolderSample> samples;
  for (int k = 1; k <= 10; ++k)
  {
    const std::int64_t stamp = k * 33333333;
    samples.push_back(at(stamp, Vec3::Zero(), stamp + 6000000000));  // 6 s after its stamp
  }
  holders.post(holders.serial(), 0, samples);
  holders.follow(simulator, ownClock(), 1e-3);
  EXPECT_EQ(holders.status()[0].late, 10u);
  EXPECT_EQ(holders.status()[0].taken, 0u);
  EXPECT_EQ(holders.wantedLatency(), initial);
}

// A still holder's pose holds at any time: one stamped before the steps' time (a long dt, a
// stamp a step behind) is taken ahead of them, not dropped as late.
TEST(HolderSession, AStillSampleIsNeverLate)
{
  Simulator simulator = heldChain();
  HolderSession holders(HolderLimits{});
  holders.setModel(simulator.model(), true);
  simulator.step(100);                                  // t = 0.1 s
  HolderSample shelf = at(50000000, Vec3(0.01, 0, 0));  // stamped at 0.05 s
  shelf.still = true;
  holders.post(holders.serial(), 0, { shelf });
  holders.follow(simulator, ownClock(), 0.05);  // steps of 50 ms ahead
  EXPECT_EQ(holders.status()[0].late, 0u);
  EXPECT_EQ(holders.status()[0].taken, 1u);
  EXPECT_EQ(simulator.tracks()[0].last().position, Vec3(0.01, 0, 0));
  EXPECT_GE(simulator.tracks()[0].last().time, 0.15);
}

// A carried obstacle's holder comes after the frame anchors' (its status names the shape): its
// first pose puts the shape there at once, later ones are knots of its track, a jump over
// ~anchor_max_jump puts it there at once too (counted) and carries no particle along.
TEST(HolderSession, CarriedObstacleTakesItsPosesAndTeleportsAlone)
{
  Scene scene;
  scene.masses = { 0.1 };
  Shape finger;
  finger.name = "finger";
  finger.type = ShapeType::Sphere;
  finger.radius = 0.05;
  finger.frame = "finger_link";
  finger.position = Vec3(0.1, 0.0, 0.0);  // in its frame
  scene.constraints = { ShapeContact{ 0, finger, 0.01 } };
  State start;
  start.positions = Points::Zero(3, 1);
  start.velocities = Points::Zero(3, 1);
  Simulator simulator(scene, start, StepSettings{});
  HolderSession holders(HolderLimits{});
  holders.setModel(simulator.model(), true);
  ASSERT_EQ(holders.status().size(), 1u);
  EXPECT_EQ(holders.status()[0].particle, -1);
  EXPECT_EQ(holders.status()[0].shape, "finger");
  EXPECT_EQ(holders.status()[0].holder, "finger_link");
  const Pacer pacer = ownClock();
  simulator.step(100);  // t = 0.1 s
  const std::uint64_t serial = holders.serial();
  HolderSample first = at(110000000, Vec3(1.0, 0, 0));
  first.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Vec3::UnitZ()));
  holders.post(serial, 0, { first, at(120000000, Vec3(1.001, 0, 0)) });
  holders.follow(simulator, pacer, 1e-3);
  ASSERT_EQ(simulator.carriers().size(), 1u);
  const AnchorTrack& track = simulator.carriers()[0];
  // there at once (at rest at the first pose now), then off towards the second
  EXPECT_EQ(track.motion(0.1).position, Vec3(1.0, 0, 0));
  EXPECT_TRUE(track.orientation(0.1).isApprox(first.orientation, 1e-15));
  EXPECT_EQ(track.last().position, Vec3(1.001, 0, 0));
  EXPECT_EQ(holders.status()[0].taken, 2u);
  EXPECT_EQ(holders.status()[0].jumps, 0u);
  // 2 m in 10 ms: a teleport, put there at once; the particle stays where it is
  holders.post(serial, 0, { at(130000000, Vec3(3.0, 0, 0)) });
  holders.follow(simulator, pacer, 1e-3);
  EXPECT_EQ(simulator.carriers()[0].motion(0.1).position, Vec3(3.0, 0, 0));
  EXPECT_EQ(holders.status()[0].jumps, 1u);
  EXPECT_NEAR(holders.status()[0].last_jump, 1.999, 1e-12);
  EXPECT_FALSE(holders.afterChunk(simulator));  // nothing carried along
  EXPECT_EQ(Vec3(simulator.state().positions.col(0)), Vec3::Zero());
}
