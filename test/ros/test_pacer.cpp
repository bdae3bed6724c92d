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
  bool new_epoch = false;
  EXPECT_EQ(pacer.due(now, 0.0, 0, DT, new_epoch), 0u);  // no clock yet
  EXPECT_EQ(pacer.standsFor(0.0), -1);
  pacer.takeClock(C0);
  EXPECT_EQ(pacer.due(now, 0.0, 0, DT, new_epoch), 0u);
  EXPECT_TRUE(new_epoch);  // the first clock
  EXPECT_EQ(pacer.standsFor(0.0), C0);
  pacer.setLatency(0.05, now);
  pacer.takeClock(C0 + 80000000);  // 80 ms on: 30 steps are due behind a 50 ms latency
  EXPECT_EQ(pacer.due(now + 1s, 0.0, 0, DT, new_epoch), 30u);
  EXPECT_FALSE(new_epoch);
  EXPECT_EQ(pacer.standsFor(0.030), C0 + 30000000);
  EXPECT_DOUBLE_EQ(pacer.simTimeOf(C0 + 30000000), 0.030);
}

// A clock that goes back (a bag played again) is a new epoch, anchored at it.
TEST(Pacer, AClockThatGoesBackStartsANewEpoch)
{
  Pacer pacer = following();
  auto now = Pacer::Clock::now();
  bool new_epoch = false;
  pacer.takeClock(C0);
  pacer.due(now, 0.0, 0, DT, new_epoch);
  pacer.takeClock(C0 + 2000000000);
  now += 1s;
  EXPECT_EQ(pacer.due(now, 0.0, 0, DT, new_epoch), 2000u);
  EXPECT_EQ(pacer.epoch(), 0u);
  pacer.takeClock(C0 + 5000000);  // back to the bag's start
  now += 1s;
  EXPECT_EQ(pacer.due(now, 2.0, 2000, DT, new_epoch), 0u);
  EXPECT_TRUE(new_epoch);
  EXPECT_EQ(pacer.epoch(), 1u);
  EXPECT_EQ(pacer.standsFor(2.0), C0 + 5000000);  // the state now stands for the new clock
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
  pacer.reanchor(5.0, 5000);
  EXPECT_EQ(pacer.standsFor(5.0), 100000000000);
  EXPECT_EQ(pacer.standsFor(7.0), 101000000000);  // 2 s of sim time is 1 s at 2x
  EXPECT_NEAR(pacer.simTimeOf(101000000000), 7.0, 1e-12);
}

// Behind is the share of the wanted sim time not taken, dropped or never reached: a window that
// reached half of it, with nothing dropped, lags by half.
TEST(Pacer, BehindWhenTheWindowFallsShortWithNothingDropped)
{
  Pacer pacer(Pacer::Source::Wall, 1.0, [] { return 0.0; });
  pacer.beginWindow(0.0);
  const auto start = Pacer::Clock::now();
  EXPECT_TRUE(pacer.updateRate(start + 1100ms, 0.55, DT, false));
  EXPECT_FALSE(pacer.behind());  // one window: a busy moment
  EXPECT_TRUE(pacer.updateRate(start + 2200ms, 1.1, DT, false));
  EXPECT_TRUE(pacer.behind());
  EXPECT_NEAR(pacer.achievedRealTimeFactor(), 0.5, 1e-9);
  EXPECT_TRUE(pacer.updateRate(start + 3300ms, 2.2, DT, false));
  EXPECT_FALSE(pacer.behind());  // a window at the wanted rate clears it
}
