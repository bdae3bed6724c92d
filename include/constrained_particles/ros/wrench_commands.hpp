/// @file wrench_commands.hpp
/// @brief ~wrench_command: a controller's stream of forces on particles (docs/node.md, "Grab,
/// drag and push"), checked and handed to the runner; what it dropped, for /diagnostics.
#pragma once

#include "constrained_particles/ros/simulation_runner.hpp"

#include <geometry_msgs/WrenchStamped.h>
#include <ros/ros.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>

namespace constrained_particles
{
/// Subscribes ~wrench_command (geometry_msgs/WrenchStamped). `header.frame_id` names a particle
/// frame (`<~frame_prefix><i>`); the force [N] is in that frame, whose axes are ~fixed_frame's
/// (particle frames carry no rotation; REP 103). It acts from the next batch of steps until a
/// newer command for that particle, or ~wrench_timeout after the last one
/// (SimulationRunner::commandWrench). Torque is ignored (a particle has none), with one note in
/// the log the first time it is not zero. A bad message (unknown frame, non-finite or outside
/// limits::FORCE) is dropped and counted, the reason logged (throttled) and kept for /diagnostics.
class WrenchCommands
{
public:
  /// `node` the private handle (~); `runner` must outlive this.
  WrenchCommands(ros::NodeHandle node, SimulationRunner& runner, std::string frame_prefix);
  /// The message a subscriber hands over (public: tests call it without a master).
  void take(const geometry_msgs::WrenchStamped& message);
  /// Commands taken and dropped so far, and why the last was dropped ('' if none was).
  std::uint64_t taken() const
  {
    return taken_;
  }
  std::uint64_t dropped() const
  {
    return dropped_;
  }
  std::string lastDropReason() const;
  /// Commands dropped (here or by the runner) since the last call: /diagnostics warns while
  /// they keep coming (a controller sending to a wrong frame). Called by one thread.
  std::uint64_t newDrops(const Snapshot& snap);
  /// /diagnostics keys: commands taken and dropped (here, or by the runner: made for a scene a
  /// change replaced, Snapshot::stale_commands), and the last reason dropped here.
  void report(const Snapshot& snap,
              const std::function<void(const std::string&, const std::string&)>& add) const;

private:
  SimulationRunner& runner_;
  std::string frame_prefix_;
  ros::Subscriber subscriber_;
  std::atomic<std::uint64_t> taken_{ 0 }, dropped_{ 0 };
  std::atomic<bool> torque_noted_{ false };
  std::uint64_t drops_reported_ = 0;  // newDrops()' count at its last call
  mutable std::mutex reason_mutex_;   // the subscriber and /diagnostics' timer run on two threads
  std::string last_drop_reason_;
};

}  // namespace constrained_particles
