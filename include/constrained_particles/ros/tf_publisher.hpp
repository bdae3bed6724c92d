/// @file tf_publisher.hpp
/// @brief /tf for the particle frames: `<frame_prefix><i>` in ~fixed_frame, one message per
/// publish, its frame names made once per scene and frame count.
#pragma once

#include "constrained_particles/ros/simulation_runner.hpp"

#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>

#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace constrained_particles
{
/// Our own /tf publisher (tf2_ros::TransformBroadcaster is a thin wrapper of one) so that the
/// message is built only with subscribers and reuses its frame names; queue as tf2_ros's.
class TfPublisher
{
public:
  /// `sim_time_stamps`: stamps may stand still (~publish_clock or /use_sim_time), so frames go
  /// out whoever listens and a listener joining gets the last ones once.
  TfPublisher(ros::NodeHandle node, std::string fixed_frame, std::string frame_prefix,
              bool sim_time_stamps);
  /// The particles of `snap` as frames stamped `stamp` (with a one-line warning when ~tf_frames
  /// -1 caps them).
  void publish(const Snapshot& snap, const ros::Time& stamp);

private:
  /// The message's frames for `snap`'s scene and ~tf_frames (names once per scene and count).
  void prepare(const Snapshot& snap);

  std::string fixed_frame_, frame_prefix_;
  bool sim_time_stamps_;
  std::mutex mutex_;  // the message: publish() and a joining subscriber's callback
  tf2_msgs::TFMessage message_;
  bool sent_ = false;                                // a message went out
  std::chrono::steady_clock::time_point last_sent_;  // wall time it went
  std::uint64_t scene_serial_ = 0, warned_scene_serial_ = 0;
  ros::Publisher publisher_;
};

}  // namespace constrained_particles
