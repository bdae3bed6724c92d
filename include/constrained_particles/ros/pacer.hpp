/// @file pacer.hpp
/// @brief When the runner steps, and which time a state stands for: the wall clock at a
/// real-time factor, lockstep with /clock (~follow_clock), or the node's own clock
/// (~publish_clock); the latency it keeps behind that clock for holders' samples to arrive; the
/// achieved real-time factor and whether it is behind. Needs no ROS master (Drake's Simulator
/// paces the same way: the integration is another object's).
#pragma once

#include "constrained_particles/core/types.hpp"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>

namespace constrained_particles
{
/// A steady-clock duration in seconds.
inline double seconds(std::chrono::steady_clock::duration d)
{
  return std::chrono::duration<double>(d).count();
}

/// seconds() the other way: `s` seconds as a steady-clock duration.
inline std::chrono::steady_clock::duration wallDuration(double s)
{
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(s));
}

/// Whether stepping is behind its real-time factor, with hysteresis: a single slow window of a
/// busy machine does not turn it on, a single fast one does not turn it off.
class BehindMonitor
{
public:
  /// On after WINDOWS consecutive windows that each fell more than SET short of the wanted sim
  /// time.
  static constexpr double SET = 0.05;
  static constexpr int WINDOWS = 2;
  /// Off after a window that fell less than CLEAR short (between CLEAR and SET it stays).
  static constexpr double CLEAR = 0.01;

  /// Takes one window's shortfall (1 - achieved / wanted sim time, 0 while paused); returns
  /// `behind`.
  bool update(double lag);

private:
  int lagging_windows_ = 0;
  bool behind_ = false;
};

/// The runner's clocks. The stamp a state at sim time t stands for (standsFor):
/// - wall (the default): the ROS time anchored at the last (re)start (under a foreign /clock,
///   its first time) plus (t - t0) / rate;
/// - ~follow_clock: the /clock anchored at the first clock (or a reset, teleport, unpause, or a
///   clock that went back: a new epoch) plus the steps since, each dt in whole nanoseconds;
/// - ~publish_clock: the node's own clock, base + t, the base moving forward at every reset,
///   teleport and fault (TIME_JUMP) so that it never repeats or goes back.
/// Steps are due up to the stamp (now - latency): a scene whose holders are sampled outside runs
/// that far behind the newest clock, so the holders' samples up to a state's stamp have arrived
/// when the steps reach it, and every output stamped t shows the scene as it is at t. Never a
/// state ahead of the clock.
class Pacer
{
public:
  using Clock = std::chrono::steady_clock;
  enum class Source
  {
    Wall,
    FollowClock,
    PublishClock,
  };
  /// How a reanchor moves the clock's anchor (~follow_clock): to the newest clock (a reset,
  /// teleport or unpause: the scene goes on from the clock's time now), or kept at the clock time
  /// the state stands for (a settings change: the count since the anchor is kept).
  enum class Anchor
  {
    Now,
    Keep,
  };
  /// Shortest wall time between the starts of two paced batches [s]: steps due sooner wait for
  /// the next batch, so a small scene at a high real-time factor takes them together.
  static constexpr double BATCH_PERIOD = 0.001;
  /// Forward jump of the ~publish_clock base at each reset, scene change, teleport or fault [s].
  static constexpr double TIME_JUMP = 1e-3;
  /// Window over which the achieved real-time factor and the shortfall are measured [s].
  static constexpr double RATE_WINDOW = 1.0;
  /// How fast a latency that is no longer needed is given back [s per s]: the scene then runs
  /// this much faster than its clock until it is nearer (a rise is taken at once: a stall).
  static constexpr double LATENCY_RELEASE_RATE = 0.25;

  /// `ros_now` the node's ROS time [s] (wall, or /clock under /use_sim_time).
  Pacer(Source source, double real_time_factor, std::function<double()> ros_now);

  Source source() const
  {
    return source_;
  }
  void setRealTimeFactor(double real_time_factor)
  {
    real_time_factor_ = real_time_factor;
  }

  // --- any thread ---
  /// The newest /clock [ns] (~follow_clock).
  void takeClock(std::int64_t clock_ns);
  /// The newest /clock [ns], -1 before the first.
  std::int64_t newestClock() const
  {
    return clock_now_ns_;
  }
  /// A /clock arrived since the physics thread last took it (due()).
  bool clockMoved() const
  {
    return clock_moved_;
  }

  // --- the physics thread ---
  /// Starts the first rate window at the state's `time`.
  void beginWindow(double time);
  /// What noticeEpoch() found.
  enum class Epoch
  {
    Same,
    First,  ///< the first /clock (or, on wall time under /use_sim_time, the first ROS time)
    Back,   ///< /clock went back (a bag played again): a new epoch
  };
  /// Anchors the state at (time, steps) to the first clock, or to one that went back: called
  /// every loop, paused or not. The caller rests its holders (Back: their samples stood for the
  /// old epoch, and their first pose then carries the scene to them).
  Epoch noticeEpoch(double time, std::uint64_t steps);
  /// Steps due at wall time `now` for the state at (time, steps), at most 1e15; 0 if none (or
  /// the batch period has not passed).
  std::uint64_t due(Clock::time_point now, double time, std::uint64_t steps);
  /// Marks the start of a batch that steps (the batch period counts from it); a zero time point
  /// lets the next batch start at once.
  void startBatch(Clock::time_point start)
  {
    last_batch_start_ = start;
  }
  /// When an idle loop should wake for the next due step (wall pacing) or a clock that came
  /// within the batch period.
  Clock::time_point nextDue(Clock::time_point now, double time, double dt, bool running) const;
  /// The sim time [s] wall pacing wanted stepped in a batch and could not take: dropped and
  /// counted, the scene's time slowed instead of building a backlog. `time` the state's. On wall
  /// time the state then stands for a later ROS time than before (stamps jump forward): true,
  /// and the caller moves its holders' samples onto the new mapping.
  bool dropped(double sim_seconds, double time);
  /// Restarts pacing from the state at (time, steps), stepped by `dt` [s] from here on.
  void reanchor(double time, std::uint64_t steps, double dt, Anchor anchor = Anchor::Now);
  /// A reset to a new scene after `time_before` [s] of the old: the stamp base moves on by it
  /// plus TIME_JUMP (stamps never go back), pacing restarts at t = 0 with step `dt` [s].
  void restart(double time_before, double dt);
  /// A teleport or fault at the same sim time: the ~publish_clock base moves on by TIME_JUMP.
  void jump()
  {
    base_ += TIME_JUMP;
  }

  /// The latency [s] kept behind the clock: at once when it rises or goes to 0 (no holder left),
  /// given back at LATENCY_RELEASE_RATE when it falls.
  void setLatency(double wanted, Clock::time_point now);
  double latency() const
  {
    return latency_;
  }

  /// The stamp [ns] of the ROS time the state at sim time `time` [s] and step count `steps`
  /// stands for (-1: no clock yet). Following /clock it is counted in whole steps from the
  /// anchor in integer nanoseconds (exactly the clock a step was due at, never after it, however
  /// long the run: the sim time is a sum of dt and drifts by its rounding).
  std::int64_t standsFor(double time, std::uint64_t steps) const;
  /// The stamp [ns] of a state that may be `resting` (paused or faulted: it stands for the clock
  /// now, the newest /clock or on wall time the ROS time now; the node's own clock as ever).
  std::int64_t stampAt(double time, std::uint64_t steps, bool resting) const;
  /// The sim time [s] that stands for ROS time `stamp_ns` (NaN: no clock yet): standsFor's
  /// inverse.
  double simTimeOf(std::int64_t stamp_ns) const;
  /// ~publish_clock: the node's clock [s] is base() + sim time.
  double base() const
  {
    return base_;
  }
  /// Clock epochs (~follow_clock): one more each time the clock went back.
  std::uint64_t epoch() const
  {
    return epoch_;
  }

  /// Closes the rate window if RATE_WINDOW passed: the achieved real-time factor (0 if
  /// `idle`: faulted, or paused without a ~step running) and the shortfall against the wanted
  /// one (the clock's advance under ~follow_clock; none while `paused`). True if a window closed.
  bool updateRate(Clock::time_point now, double time, std::uint64_t steps, bool idle, bool paused);
  double achievedRealTimeFactor() const
  {
    return achieved_;
  }
  bool behind() const
  {
    return behind_;
  }

private:
  /// Sim time [s] the state should reach at `now`: the wall target, or the clock's, less the
  /// latency.
  double target(Clock::time_point now) const;

  const Source source_;
  double real_time_factor_;
  std::function<double()> ros_now_;
  std::atomic<std::int64_t> clock_now_ns_{ -1 };
  std::atomic<bool> clock_moved_{ false };
  // the anchor: sim time and steps then, and the wall, ROS and /clock times it stands for
  double anchor_sim_ = 0.0;
  std::uint64_t anchor_steps_ = 0;
  Clock::time_point anchor_wall_;
  std::int64_t anchor_ros_ns_ = 0;
  std::int64_t anchor_clock_ns_ = -1;  // -1: no clock yet
  std::int64_t epoch_clock_ns_ = -1;   // the newest clock of this epoch
  std::int64_t dt_ns_ = 1000000;       // the step [ns] since the anchor
  double dt_ = 1e-3;                   // the same [s], unrounded
  bool ros_anchored_ = false;          // wall: anchored at a ROS time (> 0: not before a /clock)
  double base_ = 0.0;                  // ~publish_clock: stamp - sim time [s]
  std::uint64_t epoch_ = 0;
  double latency_ = 0.0;  // [s]
  Clock::time_point latency_set_;
  Clock::time_point last_batch_start_;
  // the rate window
  Clock::time_point window_wall_;
  double window_sim_ = 0.0, window_dropped_ = 0.0;
  std::int64_t window_clock_ns_ = -1;
  bool window_valid_ = false;
  double achieved_ = 0.0;
  BehindMonitor monitor_;
  bool behind_ = false;
};

}  // namespace constrained_particles
