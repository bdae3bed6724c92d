/// @file test_frame_anchor.cpp
/// @brief AnchorTrack's interpolation, and a chain held by a frame_anchor whose holder is sampled
/// like a tf broadcaster would: exact at the samples, links exact, its work the energy gained.
#include "test_helpers.hpp"

#include "constrained_particles/core/simulator.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace constrained_particles;
using constrained_particles::testing::stateOf;

namespace
{
// a holder moving on a horizontal circle of radius 0.2 m at 0.5 Hz, 1 m up
Vec3 circle(double t)
{
  const double angle = 2.0 * M_PI * 0.5 * t;
  return Vec3(0.2 * std::cos(angle), 0.2 * std::sin(angle), 1.0);
}

// n particles of `mass` [kg] on links of `link` [m], particle 0 held by a frame anchor on `frame`
// (or, with `topic`, on a pose topic), under gravity
Scene heldChain(int n, double mass, double link, const std::string& frame,
                const std::string& topic = "")
{
  Scene scene = constrained_particles::testing::pinnedChain(std::vector<double>(n, mass), link);
  FrameAnchorConstraint anchor;
  anchor.particle = 0;
  anchor.frame = frame;
  anchor.topic = topic;
  scene.constraints.back() = anchor;
  return scene;
}

AnchorSample sampleAt(double t, const Vec3& p)
{
  AnchorSample sample;
  sample.time = t;
  sample.position = p;
  return sample;
}
}  // namespace

TEST(AnchorTrack, PassesThroughEveryKnotWithContinuousVelocity)
{
  EXPECT_EQ(AnchorTrack(Vec3(1.0, 2.0, 3.0)).motion(5.0).position,
            Vec3(1.0, 2.0, 3.0));  // no knot: rests at its hold
  AnchorTrack track(circle(0.0));
  const double period = 1.0 / 30.0;
  for (int k = 1; k <= 30; ++k)
    ASSERT_EQ(track.append(sampleAt(k * period, circle(k * period)), 0.0),
              AnchorTrack::Append::Taken);
  // a knot at now = 0 where it rested, then the samples
  ASSERT_EQ(track.size(), 31u);
  EXPECT_EQ(track.motion(0.0).position, circle(0.0));
  for (int k = 1; k <= 30; ++k)
    EXPECT_LE((track.motion(k * period).position - circle(k * period)).norm(), 1e-15) << k;
  // C1 across a knot: the velocity just before and just after agree; the acceleration is finite
  for (int k = 2; k < 29; ++k)
  {
    const double t = k * period;
    EXPECT_LE((track.motion(t - 1e-9).velocity - track.motion(t + 1e-9).velocity).norm(), 1e-6);
    EXPECT_TRUE(track.motion(t + 1e-9).acceleration.allFinite());
  }
  // between knots it follows the circle to the spline's accuracy (about (omega h)^3 r / 8 / ...)
  double worst = 0.0;
  for (double t = 3 * period; t < 27 * period; t += period / 7)
    worst = std::max(worst, (track.motion(t).position - circle(t)).norm());
  EXPECT_LT(worst, 2e-4);  // r (omega h)^3 / 24 is 3e-5 m: a cubic's error, not a line's 1e-3
  EXPECT_GT(worst, 0.0);
  // after the last knot it rests there, arriving at rest (the last tangent is 0)
  EXPECT_EQ(track.motion(2.0).position, circle(1.0));
  EXPECT_EQ(track.motion(2.0).velocity, Vec3::Zero());
  EXPECT_LE(track.motion(1.0 - 1e-9).velocity.norm(), 1e-6);
}

TEST(AnchorTrack, RefusesThePastAndDisorder)
{
  AnchorTrack track;
  EXPECT_EQ(track.append(sampleAt(0.5, Vec3::Ones()), 1.0), AnchorTrack::Append::Late);
  EXPECT_EQ(track.size(), 0u);
  EXPECT_EQ(track.append(sampleAt(1.5, Vec3::Ones()), 1.0), AnchorTrack::Append::Taken);
  EXPECT_EQ(track.append(sampleAt(1.5, Vec3::Zero()), 1.0), AnchorTrack::Append::Unordered);
  EXPECT_EQ(track.append(sampleAt(1.2, Vec3::Zero()), 1.0), AnchorTrack::Append::Unordered);
  // the set-off knot at now = 1.0 where it rested (the origin), then the sample
  EXPECT_EQ(track.size(), 2u);
  EXPECT_EQ(track.motion(1.0).position, Vec3::Zero());
  EXPECT_EQ(track.motion(1.5).position, Vec3::Ones());
  // past the last knot: a new sample sets off from where it rests now, not from 1.5 s
  EXPECT_EQ(track.append(sampleAt(3.0, Vec3(2.0, 0.0, 0.0)), 2.5), AnchorTrack::Append::Taken);
  EXPECT_EQ(track.motion(2.5).position, Vec3::Ones());
  EXPECT_EQ(track.motion(2.5).velocity, Vec3::Zero());
  EXPECT_EQ(track.motion(3.0).position, Vec3(2.0, 0.0, 0.0));
}

TEST(AnchorTrack, DroppingOldKnotsKeepsTheMotionAfter)
{
  AnchorTrack track;
  const double period = 0.01;
  for (int k = 1; k <= 100; ++k)
    track.append(sampleAt(k * period, circle(k * period)), 0.0);
  AnchorTrack kept = track;
  const double now = 0.503;
  kept.dropBefore(now);
  EXPECT_EQ(kept.size(), 52u);  // 0.49 and 0.50 for the interval [0.50, 0.51], then the rest
  for (double t = now; t < 1.2; t += 0.0007)
  {
    EXPECT_EQ(kept.motion(t).position, track.motion(t).position) << t;
    EXPECT_EQ(kept.motion(t).velocity, track.motion(t).velocity) << t;
    EXPECT_EQ(kept.motion(t).acceleration, track.motion(t).acceleration) << t;
  }
}

// A chain of 5 hanging from a frame anchor whose holder circles, sampled at 30 Hz ahead of the
// steps (as the node does with its lag): the held particle is at each sample exactly at its
// time, the links hold, and the energy gained is the work of the holder's reaction.
TEST(FrameAnchor, ChainFollowsTheSampledHolderExactly)
{
  constexpr int n = 5;
  const Scene scene = heldChain(n, 0.1, 0.2, "hand");
  Points p(3, n);
  for (int i = 0; i < n; ++i)
    p.col(i) = circle(0.0) - Vec3(0.0, 0.0, 0.2 * i);
  StepSettings settings;
  settings.dt = 1e-4;
  Simulator simulator(scene, stateOf(p, Points::Zero(3, n)), settings);
  ASSERT_EQ(simulator.model().tracked().size(), 1u);
  const double period = 1.0 / 30.0, lead = 0.1;
  int sampled = 0;  // samples given so far, at k * period
  double worst_at_samples = 0.0, worst_link = 0.0, work = 0.0;
  Points forces;
  Eigen::VectorXd multipliers;
  auto power = [&]
  {
    simulator.constraintForces(forces, multipliers);
    return Vec3(multipliers.tail<3>()).dot(simulator.state().velocities.col(0));
  };
  const double e0 = simulator.diagnostics().totalEnergy();
  double previous = power();
  int checked = 0;
  for (int step = 0; step < 30000; ++step)
  {
    const double now = simulator.state().time;
    while ((sampled + 1) * period <= now + lead)
    {
      ++sampled;
      ASSERT_EQ(
          simulator.tracks()[0].append(sampleAt(sampled * period, circle(sampled * period)), now),
          AnchorTrack::Append::Taken);
    }
    simulator.tracks()[0].dropBefore(now);
    simulator.step();
    const double t = simulator.state().time;
    const double current = power();
    work += 0.5 * settings.dt * (previous + current);
    previous = current;
    // steps land on samples every 100 steps (0.1 s = 3 periods)
    const double k = std::round(t / period);
    if (std::abs(k * period - t) < 1e-9 && t > 0.05)
    {
      worst_at_samples = std::max(
          worst_at_samples, (Vec3(simulator.state().positions.col(0)) - circle(k * period)).norm());
      ++checked;
    }
    for (int i = 0; i + 1 < n; ++i)
      worst_link = std::max(
          worst_link,
          std::abs(
              (simulator.state().positions.col(i) - simulator.state().positions.col(i + 1)).norm() -
              0.2));
  }
  EXPECT_GE(checked, 25);
  EXPECT_LE(worst_at_samples, 1e-9);  // the step clock t = sum of dt rounds off ~1e-12 s
  EXPECT_LE(worst_link, 1e-9);
  EXPECT_LE(simulator.diagnostics().max_position_error, 1e-9);
  const double gained = simulator.diagnostics().totalEnergy() - e0;
  EXPECT_GT(std::abs(gained), 1e-3);  // the holder does work
  EXPECT_NEAR(gained, work, 1e-4 * (std::abs(work) + 1e-3));
  // a reset rests the holder where its particle starts, without the old run's knots
  simulator.reset();
  EXPECT_EQ(simulator.tracks()[0].size(), 0u);
  EXPECT_EQ(simulator.tracks()[0].hold(), Vec3(simulator.state().positions.col(0)));
}

// At rest from a still holder, the reaction holds the chain's weight: (0, 0, n m g) on the
// particle, so the holder feels (0, 0, -n m g).
TEST(FrameAnchor, HangingChainAtRestWeighsOnItsHolder)
{
  constexpr int n = 4;
  const double m = 0.25;
  const Scene scene = heldChain(n, m, 0.3, "", "/gripper_pose");
  Points p(3, n);
  for (int i = 0; i < n; ++i)
    p.col(i) = Vec3(0.1, 0.0, 1.0 - 0.3 * i);
  StepSettings settings;
  Simulator simulator(scene, stateOf(p, Points::Zero(3, n)), settings);
  simulator.step(10);
  Points forces;
  Eigen::VectorXd multipliers;
  simulator.constraintForces(forces, multipliers);
  const Vec3 reaction = simulator.model().eliminatedReaction(multipliers, 0);
  const double weight = n * m * 9.81;
  EXPECT_LE((reaction - Vec3(0.0, 0.0, weight)).norm(), 1e-9 * weight) << reaction.transpose();
}

// Whatever arrives, an append never changes the motion from `now` on: what the steps already
// imposed stays imposed (a knot whose interval has begun keeps its tangent 0).
TEST(AnchorTrack, AnAppendNeverChangesTheMotionFromNowOn)
{
  AnchorTrack track(circle(0.0));
  std::uint32_t seed = 7;
  auto uniform = [&seed](double low, double high)
  {
    seed = seed * 1664525u + 1013904223u;
    return low + (high - low) * (seed >> 8) / 16777216.0;
  };
  double now = 0.0, next = 0.0;
  int taken = 0;
  for (int k = 0; k < 400; ++k)
  {
    now += uniform(0.0, 0.02);
    next = std::max(next, now - 0.01) + uniform(0.001, 0.03);  // sometimes behind now: late
    const ImposedMotion before = track.motion(now);
    if (track.append(sampleAt(next, circle(next)), now, 1e-3) == AnchorTrack::Append::Taken)
      ++taken;
    const ImposedMotion after = track.motion(now);
    EXPECT_EQ(after.position, before.position) << k;
    EXPECT_EQ(after.velocity, before.velocity) << k;
    track.dropBefore(now);
  }
  EXPECT_GT(taken, 100);
}

// Simulator::setConstraints (an attachment made or ended): the state is kept, the track of a
// particle held before and after is kept, a refusal changes nothing.
TEST(FrameAnchor, SetConstraintsKeepsTheStateAndTheTracksByParticle)
{
  constexpr int n = 4;
  const Scene scene = heldChain(n, 0.1, 0.2, "hand");
  Points p(3, n);
  for (int i = 0; i < n; ++i)
    p.col(i) = Vec3(0.0, 0.0, 1.0 - 0.2 * i);
  Simulator simulator(scene, stateOf(p, Points::Zero(3, n)), StepSettings{});
  simulator.tracks()[0].append(sampleAt(0.5, Vec3(0.05, 0.0, 1.0)), 0.0);
  simulator.step(20);
  const State before = simulator.state();
  // hold the last particle too, at a frame: particle 0's track is the same one
  std::vector<Constraint> constraints = simulator.model().scene().constraints;
  FrameAnchorConstraint grab;
  grab.particle = n - 1;
  grab.frame = "gripper";
  constraints.push_back(grab);
  simulator.setConstraints(constraints);
  EXPECT_EQ(simulator.model().tracked().size(), 2u);
  EXPECT_EQ(simulator.tracks()[0].size(), 2u);  // the rest knot at 0 and the sample
  EXPECT_EQ(simulator.tracks()[1].hold(), Vec3(before.positions.col(n - 1)));
  EXPECT_LE((simulator.state().positions - before.positions).norm(), 1e-12);
  EXPECT_EQ(simulator.state().time, before.time);
  // a record that cannot be: refused, nothing changed
  std::vector<Constraint> bad = constraints;
  bad.push_back(grab);  // the same particle twice
  const State kept = simulator.state();
  EXPECT_THROW(simulator.setConstraints(bad), InvalidInput);
  EXPECT_EQ(simulator.model().tracked().size(), 2u);
  EXPECT_EQ(simulator.state().positions, kept.positions);
  // let go of it again: its velocity is kept
  constraints.pop_back();
  simulator.step(10);
  const State held = simulator.state();
  simulator.setConstraints(constraints);
  EXPECT_EQ(simulator.model().tracked().size(), 1u);
  EXPECT_LE((simulator.state().velocities - held.velocities).norm(), 1e-12);
}
