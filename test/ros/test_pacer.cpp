/// @file test_pacer.cpp
/// @brief Pacer without a runner: steps due against the clock less the latency, the stamp a
/// state stands for and its inverse, clock epochs, the latency's rise and fall, and `behind`.
#include "constrained_particles/ros/pacer.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

using namespace constrained_particles;
using namespace std::chrono_literals;

namespace
{
constexpr std::int64_t C0 = 1733000000000000000;  // a clock near the epoch, as a bag's [ns]
constexpr double DT = 1e-3;

Pacer following()
{
  return Pacer(Pacer::Source::FollowClock, 1.0, [] { return 0.0; });
}
}  // namespace

// Following /clock: the first clock anchors sim time 0; steps are due up to the clock less the
// latency, whole steps from integer nanoseconds; a state stands for the anchor plus its time.
TEST(Pacer, FollowsTheClockLessTheLatency)
{
  Pacer pacer = following();
  const auto now = Pacer::Clock::now();
  EXPECT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::Same);  // no clock yet
  EXPECT_EQ(pacer.due(now, 0.0, 0), 0u);
  EXPECT_EQ(pacer.standsFor(0.0, 0), -1);
  pacer.takeClock(C0);
  EXPECT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::First);
  EXPECT_EQ(pacer.due(now, 0.0, 0), 0u);
  EXPECT_EQ(pacer.standsFor(0.0, 0), C0);
  pacer.setLatency(0.05, now);
  pacer.takeClock(C0 + 80000000);  // 80 ms on: 30 steps are due behind a 50 ms latency
  EXPECT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::Same);
  EXPECT_EQ(pacer.due(now + 1s, 0.0, 0), 30u);
  EXPECT_EQ(pacer.standsFor(0.030, 30), C0 + 30000000);
  EXPECT_DOUBLE_EQ(pacer.simTimeOf(C0 + 30000000), 0.030);
}

// A clock that goes back (a bag played again) is a new epoch, anchored at it; noticed with no
// step taken (a paused scene notices it too).
TEST(Pacer, AClockThatGoesBackStartsANewEpoch)
{
  Pacer pacer = following();
  auto now = Pacer::Clock::now();
  pacer.takeClock(C0);
  EXPECT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::First);
  pacer.takeClock(C0 + 2000000000);
  EXPECT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::Same);
  now += 1s;
  EXPECT_EQ(pacer.due(now, 0.0, 0), 2000u);
  EXPECT_EQ(pacer.epoch(), 0u);
  pacer.takeClock(C0 + 5000000);  // back to the bag's start
  EXPECT_EQ(pacer.noticeEpoch(2.0, 2000), Pacer::Epoch::Back);
  EXPECT_EQ(pacer.epoch(), 1u);
  EXPECT_EQ(pacer.standsFor(2.0, 2000), C0 + 5000000);  // the state now stands for the new clock
  now += 1s;
  EXPECT_EQ(pacer.due(now, 2.0, 2000), 0u);
  // a clock a little behind the newest (two publishers' jitter, under a step) is the same epoch
  pacer.takeClock(C0 + 5000000 - 500000);
  EXPECT_EQ(pacer.noticeEpoch(2.0, 2000), Pacer::Epoch::Same);
}

// Following an uneven /clock for 10^6 steps: the state never stands for a time after the clock
// less the latency, nor a step or more before it (the stamp counts whole steps in integer
// nanoseconds: the sim time, a sum of dt, would drift by its rounding).
TEST(Pacer, FollowedStampsAreNeverAheadOfTheClockHoweverLong)
{
  Pacer pacer = following();
  const std::int64_t dt_ns = 1000000;
  pacer.reanchor(0.0, 0, 1e-3);
  const auto now = Pacer::Clock::now();
  pacer.setLatency(0.02, now);
  pacer.takeClock(C0);
  ASSERT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::First);
  double time = 0.0;
  std::uint64_t steps = 0;
  std::int64_t clock = C0;
  const std::int64_t latency_ns = 20000000;
  for (int k = 1; steps < 1000000; ++k)
  {
    clock += 33333333 + (k % 7) * 1234567;  // a 30 Hz clock with jitter
    pacer.takeClock(clock);
    ASSERT_EQ(pacer.noticeEpoch(time, steps), Pacer::Epoch::Same);
    const std::uint64_t n = pacer.due(now + k * 2ms, time, steps);
    for (std::uint64_t i = 0; i < n; ++i)
      time += 1e-3;
    steps += n;
    const std::int64_t stamp = pacer.standsFor(time, steps);
    ASSERT_LE(stamp, clock - latency_ns) << "at step " << steps;
    ASSERT_GT(stamp, clock - latency_ns - dt_ns) << "at step " << steps;
  }
}

// The latency rises at once and falls at LATENCY_RELEASE_RATE, or at once to 0.
TEST(Pacer, LatencyRisesAtOnceAndFallsGradually)
{
  Pacer pacer = following();
  const auto now = Pacer::Clock::now();
  pacer.setLatency(0.1, now);
  EXPECT_EQ(pacer.latency(), 0.1);
  pacer.setLatency(0.01, now + 100ms);
  EXPECT_NEAR(pacer.latency(), 0.1 - Pacer::LATENCY_RELEASE_RATE * 0.1, 1e-12);
  pacer.setLatency(0.01, now + 1s);
  EXPECT_EQ(pacer.latency(), 0.01);
  pacer.setLatency(0.0, now + 1100ms);
  EXPECT_EQ(pacer.latency(), 0.0);
}

// On wall time a state stands for the ROS time it was paced to, and simTimeOf inverts it at the
// real-time factor.
TEST(Pacer, WallStampsStandForTheTimePacedTo)
{
  double ros_now = 100.0;
  Pacer pacer(Pacer::Source::Wall, 2.0, [&ros_now] { return ros_now; });
  pacer.reanchor(5.0, 5000, DT);
  EXPECT_EQ(pacer.standsFor(5.0, 5000), 100000000000);
  EXPECT_EQ(pacer.standsFor(7.0, 6000), 101000000000);  // 2 s of sim time is 1 s at 2x
  EXPECT_NEAR(pacer.simTimeOf(101000000000), 7.0, 1e-12);
}

// Behind is the share of the wanted sim time not taken, dropped or never reached: a window that
// reached half of it, with nothing dropped, lags by half.
TEST(Pacer, BehindWhenTheWindowFallsShortWithNothingDropped)
{
  Pacer pacer(Pacer::Source::Wall, 1.0, [] { return 0.0; });
  pacer.beginWindow(0.0);
  const auto start = Pacer::Clock::now();
  EXPECT_TRUE(pacer.updateRate(start + 1100ms, 0.55, 550, false, false));
  EXPECT_FALSE(pacer.behind());  // one window: a busy moment
  EXPECT_TRUE(pacer.updateRate(start + 2200ms, 1.1, 1100, false, false));
  EXPECT_TRUE(pacer.behind());
  EXPECT_NEAR(pacer.achievedRealTimeFactor(), 0.5, 1e-9);
  EXPECT_TRUE(pacer.updateRate(start + 3300ms, 2.2, 2200, false, false));
  EXPECT_FALSE(pacer.behind());  // a window at the wanted rate clears it
}

// Wall pacing that could not keep up drops the time it could not take and goes on from the
// state at once: no stall of the latency's length, and the state then stands for now less the
// latency.
TEST(Pacer, DroppedTimeIsNotOwedAndNothingStalls)
{
  double ros_now = 100.0;
  Pacer pacer(Pacer::Source::Wall, 1.0, [&ros_now] { return ros_now; });
  pacer.reanchor(0.0, 0, DT);
  const auto start = Pacer::Clock::now();
  pacer.setLatency(0.1, start);
  ros_now = 110.0;
  EXPECT_GT(pacer.due(start + 10s, 0.0, 0), 9000u);  // ten seconds behind: a backlog
  // the caller took 100 steps in its batch and dropped the rest
  EXPECT_TRUE(pacer.dropped(9.8, 0.1));
  EXPECT_EQ(pacer.standsFor(0.1, 100), 109900000000);  // ROS now less the latency
  pacer.startBatch(Pacer::Clock::time_point());        // the next batch may start at once
  const auto after = Pacer::Clock::now();
  const std::uint64_t next = pacer.due(after + 5ms, 0.1, 100);
  EXPECT_GE(next, 4u);    // steps go on at once (a stall would give none for 100 ms)
  EXPECT_LE(next, 100u);  // and nothing of the dropped time is owed
}

// Wall time under a foreign /clock that has not started (ROS time 0): the first ROS time is the
// anchor, noticed once, not a re-placement.
TEST(Pacer, AForeignClocksFirstTimeAnchorsWallPacingOnce)
{
  double ros_now = 0.0;
  Pacer pacer(Pacer::Source::Wall, 1.0, [&ros_now] { return ros_now; });
  pacer.reanchor(0.0, 0, DT);
  EXPECT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::Same);
  ros_now = 50.0;
  EXPECT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::First);
  EXPECT_EQ(pacer.standsFor(0.0, 0), 50000000000);
  ros_now = 51.0;
  EXPECT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::Same);
}

// A settings change (reanchor keeping the count) before a foreign /clock's first time neither
// anchors the stamps at ROS time 0 nor stalls the steps: the first time is still noticed.
TEST(Pacer, AChangeBeforeAForeignClocksFirstTimeKeepsItsAnchoring)
{
  double ros_now = 0.0;
  Pacer pacer(Pacer::Source::Wall, 1.0, [&ros_now] { return ros_now; });
  pacer.reanchor(0.0, 0, DT);
  EXPECT_GT(pacer.due(Pacer::Clock::now() + 1s, 0.0, 0), 900u);  // wall pacing before it
  pacer.reanchor(1.0, 1000, DT, Pacer::Anchor::Keep);
  pacer.startBatch(Pacer::Clock::time_point());
  const std::uint64_t next = pacer.due(Pacer::Clock::now() + 5ms, 1.0, 1000);
  EXPECT_GE(next, 4u);  // no stall
  EXPECT_LE(next, 100u);
  ros_now = 50.0;
  EXPECT_EQ(pacer.noticeEpoch(1.0, 1000), Pacer::Epoch::First);
  EXPECT_EQ(pacer.standsFor(1.0, 1000), 50000000000);
}

// Following /clock with a dt that is not a whole number of nanoseconds: simTimeOf inverts
// standsFor exactly, however many steps (a sample is placed where the state standing for its
// stamp is).
TEST(Pacer, SimTimeOfInvertsStandsForWhenDtIsNotWholeNanoseconds)
{
  Pacer pacer = following();
  const double dt = 1.0 / 3000.0;
  pacer.reanchor(0.0, 0, dt);
  pacer.takeClock(C0);
  ASSERT_EQ(pacer.noticeEpoch(0.0, 0), Pacer::Epoch::First);
  const std::uint64_t steps = 10800000;  // an hour
  const double time = static_cast<double>(steps) * dt;
  EXPECT_NEAR(pacer.simTimeOf(pacer.standsFor(time, steps)), time, 1e-9);
}
