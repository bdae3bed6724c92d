/// @file runner_queue.hpp
/// @brief Requests from any thread applied by one (the runner's physics thread) between its
/// batches, each answered once applied (turtlesim's queue-and-apply shape); the owner's wait and
/// its wake-ups. Needs no ROS master.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>

namespace constrained_particles
{
/// How a request ended.
struct RunnerReply
{
  bool success = false;
  std::string message;             ///< what was done, or why not (naming the field)
  std::string field;               ///< the refused field, when one was named
  double sim_time = 0;             ///< sim time once applied [s]
  std::uint64_t steps_taken = 0;   ///< ~step: steps taken (fewer if interrupted or faulted)
  double max_displacement = 0;     ///< teleport, attach: largest move of a particle [m]
  double max_velocity_change = 0;  ///< ~set_obstacle: largest change of a velocity [m/s]
  std::int64_t stamp_ns = -1;      ///< attach: the stamp of the state the hold began at [ns]
  /// Batches of steps that ended between queueing and applying the request: at most 1, the one
  /// under way (a request waits for no more than one batch).
  std::uint64_t batches_waited = 0;
};

RunnerReply refusedReply(const std::string& message, const std::string& field = "");
RunnerReply acceptedReply(const std::string& message);

class RunnerQueue
{
public:
  using Clock = std::chrono::steady_clock;
  struct Request
  {
    std::function<RunnerReply()> apply;
    std::promise<RunnerReply> reply;
    std::uint64_t queued_at_batch = 0;
  };

  /// Any thread: queues `apply` for the owner, wakes it and waits for the reply (refused once
  /// the queue stops).
  RunnerReply submit(std::function<RunnerReply()> apply);
  /// Any thread: waits for a reply given later (a ~step's, an attach's), polled so that it is
  /// refused once the queue stops.
  RunnerReply await(std::future<RunnerReply>& future) const;
  /// The owner: every request queued, and the batches counted so far.
  std::deque<std::shared_ptr<Request>> take(std::uint64_t& batches);
  /// The owner: one more batch of steps ended (RunnerReply::batches_waited).
  void countBatch();
  /// Any thread: wakes the owner's wait, after posting what `ready` checks (under the lock, so
  /// never between its check and its wait).
  void wake();
  /// The owner: waits until `until`, a request, stop() or `ready()`, checked under the lock.
  void wait(Clock::time_point until, const std::function<bool()>& ready);
  /// Any thread: stops (the owner's loop ends; submit and await refuse).
  void stop();
  bool stopping() const
  {
    return stopping_;
  }

private:
  mutable std::mutex mutex_;  // guards the queue and the wake-up
  std::condition_variable wake_;
  std::deque<std::shared_ptr<Request>> queue_;
  std::uint64_t batches_ = 0;
  std::atomic<bool> stopping_{ false };
};

}  // namespace constrained_particles
