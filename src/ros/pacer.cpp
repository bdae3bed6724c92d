/// @file pacer.cpp
/// @brief Pacer: when steps are due, which time a state stands for, the latency and the rate.
#include "constrained_particles/ros/pacer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace constrained_particles
{
namespace
{
std::int64_t nanoseconds(double s)
{
  return std::llround(s * 1e9);
}
}  // namespace

bool BehindMonitor::update(double lag)
{
  lagging_windows_ = lag > SET ? lagging_windows_ + 1 : 0;
  if (lagging_windows_ >= WINDOWS)
    behind_ = true;
  else if (lag < CLEAR)
    behind_ = false;
  return behind_;
}

Pacer::Pacer(Source source, double real_time_factor, std::function<double()> ros_now)
  : source_(source), real_time_factor_(real_time_factor), ros_now_(std::move(ros_now))
{
  latency_set_ = window_wall_ = anchor_wall_ = Clock::now();
}

void Pacer::takeClock(std::int64_t clock_ns)
{
  clock_now_ns_ = clock_ns;
  clock_moved_ = true;  // after the clock: the loop that sees the flag sees the clock
}

double Pacer::target(Clock::time_point now) const
{
  const double since = seconds(now - anchor_wall_);
  if (source_ == Source::PublishClock)  // the clock is sim time: the latency is in its seconds
    return anchor_sim_ + real_time_factor_ * since - latency_;
  return anchor_sim_ + real_time_factor_ * (since - latency_);
}

Pacer::Epoch Pacer::noticeEpoch(double time, std::uint64_t steps)
{
  if (source_ == Source::Wall)
  {
    // under a foreign /clock ROS time starts at 0: the anchor is its first time, not 0
    if (ros_anchored_ || nanoseconds(ros_now_()) <= 0)
      return Epoch::Same;
    reanchor(time, steps, dt_);
    return Epoch::First;
  }
  if (source_ != Source::FollowClock)
    return Epoch::Same;
  const std::int64_t clock = clock_now_ns_;
  if (clock < 0)
    return Epoch::Same;  // no /clock yet: nothing to follow
  const bool first = anchor_clock_ns_ < 0;
  // one that went back by more than a step (a bag played again): a new epoch from it
  if (!first && clock >= epoch_clock_ns_ - dt_ns_)
  {
    epoch_clock_ns_ = std::max(epoch_clock_ns_, clock);
    return Epoch::Same;
  }
  if (!first)
    ++epoch_;
  anchor_clock_ns_ = epoch_clock_ns_ = clock;
  anchor_sim_ = time;
  anchor_steps_ = steps;
  return first ? Epoch::First : Epoch::Back;
}

std::uint64_t Pacer::due(Clock::time_point now, double time, std::uint64_t steps)
{
  if (seconds(now - last_batch_start_) < BATCH_PERIOD)
    return 0;  // a clock that moved stays flagged: the loop wakes when the period ends
  double due = 0.0;
  if (source_ == Source::FollowClock)
  {
    clock_moved_ = false;  // taken: a clock arriving from here on wakes the loop again
    const std::int64_t clock = clock_now_ns_;
    if (clock < 0 || anchor_clock_ns_ < 0)
      return 0;  // no /clock yet: nothing to follow
    // whole steps since the anchor, in integer nanoseconds: exact for clocks near the epoch and
    // for any increment; the latency held back
    const std::int64_t since = clock - nanoseconds(latency_) - anchor_clock_ns_;
    due = since < 0
              ? 0.0
              : static_cast<double>(since / dt_ns_) - static_cast<double>(steps - anchor_steps_);
  }
  else
    due = std::floor((target(now) - time) / dt_ + 1e-9);
  if (!(due >= 1.0))
    return 0;
  last_batch_start_ = now;
  return static_cast<std::uint64_t>(std::min(due, 1e15));
}

void Pacer::beginWindow(double time)
{
  window_wall_ = Clock::now();
  window_sim_ = time;
  window_valid_ = true;
}

Pacer::Clock::time_point Pacer::nextDue(Clock::time_point now, double time, double dt,
                                        bool running) const
{
  const Clock::time_point period = last_batch_start_ + wallDuration(BATCH_PERIOD);
  if (source_ == Source::FollowClock)  // a clock that moves wakes the loop itself
    return running && clock_moved_ ? period : Clock::time_point::max();
  if (!running)
    return Clock::time_point::max();
  const double ahead = time + dt - anchor_sim_;
  const double since = source_ == Source::PublishClock ? (ahead + latency_) / real_time_factor_
                                                       : ahead / real_time_factor_ + latency_;
  return std::max(std::max(anchor_wall_ + wallDuration(since), period), now);
}

bool Pacer::dropped(double sim_seconds, double time)
{
  window_dropped_ += sim_seconds;
  // pacing restarts from the state, which stands for now less the latency (no stall for it
  // again): the time it could not take is not owed
  const Clock::time_point now = Clock::now();
  if (source_ != Source::Wall)
  {
    // ~publish_clock's stamps are the sim time's own: only the target moves
    anchor_wall_ = now;
    anchor_sim_ = time + latency_;
    return false;
  }
  anchor_wall_ = now - wallDuration(latency_);
  anchor_sim_ = time;
  anchor_ros_ns_ = nanoseconds(ros_now_()) - nanoseconds(latency_);
  return true;
}

void Pacer::reanchor(double time, std::uint64_t steps, double dt, Anchor anchor)
{
  const Clock::time_point now = Clock::now();
  const std::int64_t ros_now = nanoseconds(ros_now_());
  if (anchor == Anchor::Keep)
  {
    // the state goes on standing for the time it stood for (at the step before the change):
    // stamps and samples keep their places, and the backlog behind the clock is kept
    const std::int64_t stamp = standsFor(time, steps);
    if (source_ == Source::Wall && ros_now <= 0)
      anchor_wall_ = now;  // no ROS time yet (a foreign /clock): anchored at its first
    else if (source_ == Source::Wall)
    {
      anchor_ros_ns_ = stamp;
      anchor_wall_ = now - wallDuration(static_cast<double>(ros_now - stamp) * 1e-9);
    }
    else if (source_ == Source::FollowClock)
    {
      anchor_clock_ns_ = anchor_clock_ns_ >= 0 ? stamp : -1;
      anchor_wall_ = now;
    }
    else
      anchor_wall_ = now;
  }
  else
  {
    anchor_wall_ = now;
    anchor_ros_ns_ = ros_now;
    if (source_ == Source::FollowClock)
    {
      anchor_clock_ns_ = clock_now_ns_;
      epoch_clock_ns_ = std::max<std::int64_t>(epoch_clock_ns_, anchor_clock_ns_);
    }
  }
  anchor_sim_ = time;
  anchor_steps_ = steps;
  if (source_ == Source::Wall)
  {
    ros_anchored_ = ros_now > 0;
    if (!ros_anchored_)
      anchor_ros_ns_ = 0;
  }
  dt_ = dt;
  dt_ns_ = std::max<std::int64_t>(1, nanoseconds(dt));
}

void Pacer::restart(double time_before, double dt)
{
  base_ += time_before + TIME_JUMP;
  reanchor(0.0, 0, dt);
  window_valid_ = false;
}

void Pacer::setLatency(double wanted, Clock::time_point now)
{
  // a rise at once (a stall); a fall gradually while holders need one, so the outputs come
  // evenly; at once when none does (the scene just catches up with its clock)
  if (wanted >= latency_ || wanted <= 0.0)
    latency_ = wanted;
  else
    latency_ = std::max(wanted, latency_ - LATENCY_RELEASE_RATE * seconds(now - latency_set_));
  latency_set_ = now;
}

std::int64_t Pacer::standsFor(double time, std::uint64_t steps) const
{
  switch (source_)
  {
    case Source::FollowClock:
      return anchor_clock_ns_ < 0
                 ? -1
                 : anchor_clock_ns_ + static_cast<std::int64_t>(steps - anchor_steps_) * dt_ns_;
    case Source::PublishClock:
      return nanoseconds(base_ + time);
    case Source::Wall:
      break;
  }
  return anchor_ros_ns_ + nanoseconds((time - anchor_sim_) / real_time_factor_);
}

std::int64_t Pacer::stampAt(double time, std::uint64_t steps, bool resting) const
{
  if (!resting || source_ == Source::PublishClock)
    return standsFor(time, steps);
  return source_ == Source::FollowClock ? newestClock() : nanoseconds(ros_now_());
}

double Pacer::simTimeOf(std::int64_t stamp_ns) const
{
  switch (source_)
  {
    case Source::FollowClock:
      // in steps of dt_ns_, each dt of sim time: standsFor's inverse when dt is not whole ns
      return anchor_clock_ns_ < 0 ? std::numeric_limits<double>::quiet_NaN()
                                  : anchor_sim_ + static_cast<double>(stamp_ns - anchor_clock_ns_) *
                                                      (dt_ / static_cast<double>(dt_ns_));
    case Source::PublishClock:
      return static_cast<double>(stamp_ns) * 1e-9 - base_;
    case Source::Wall:
      break;
  }
  return anchor_sim_ + real_time_factor_ * static_cast<double>(stamp_ns - anchor_ros_ns_) * 1e-9;
}

bool Pacer::updateRate(Clock::time_point now, double time, std::uint64_t steps, bool idle,
                       bool paused)
{
  const double dt = dt_;
  const double wall = seconds(now - window_wall_);
  if (wall < RATE_WINDOW)
    return false;
  if (window_valid_)
    achieved_ = idle ? 0.0 : std::max(0.0, time - window_sim_) / wall;
  double lag = 0.0;
  const std::int64_t clock = clock_now_ns_;
  if (!idle && !paused && source_ == Source::FollowClock)
  {
    // following /clock nothing is dropped: behind is the backlog past the latency, against the
    // clock's advance in the window
    if (anchor_clock_ns_ >= 0 && window_clock_ns_ >= 0 && clock > window_clock_ns_)
      lag = std::max(0.0,
                     static_cast<double>(clock - standsFor(time, steps)) * 1e-9 - latency_ - dt) /
            (static_cast<double>(clock - window_clock_ns_) * 1e-9);
  }
  else if (!idle && !paused)
  {
    // the share of the wanted sim time that was not taken: dropped to keep up, or never reached
    const double wanted = real_time_factor_ * wall;
    lag = window_dropped_ / wanted;
    if (window_valid_)
      lag = std::max(lag, 1.0 - (time - window_sim_) / wanted);
  }
  behind_ = monitor_.update(lag);
  window_wall_ = now;
  window_sim_ = time;
  window_dropped_ = 0.0;
  window_clock_ns_ = clock;
  window_valid_ = true;
  return true;
}

}  // namespace constrained_particles
