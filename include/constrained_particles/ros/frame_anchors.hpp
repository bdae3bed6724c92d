/// @file frame_anchors.hpp
/// @brief The node's side of frame anchors: samples each holder (a tf frame, or a
/// geometry_msgs/PoseStamped topic) and posts the poses to the runner, which never waits for tf.
#pragma once

#include "constrained_particles/ros/simulation_runner.hpp"

#include <geometry_msgs/PoseStamped.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace constrained_particles
{
/// Samples holders for SimulationRunner::postHolderSamples. A tf frame is looked up in
/// ~fixed_frame every SAMPLE_PERIOD of its stamps, up to the newest tf holds (tf2 interpolates
/// linearly between broadcasts; AnchorTrack's spline runs through these samples), on a timer of
/// its own: tf2's listener fills its buffer on its own thread, and the runner only reads what was
/// posted. A PoseStamped topic's poses are taken at their stamps, resolved into ~fixed_frame
/// through tf at that stamp. A frame not (yet) in tf holds its particle where it is, logged once
/// and a WARN in /diagnostics naming it, until it appears.
class FrameAnchors
{
public:
  /// Grid of the tf samples [s] (a 30 Hz broadcaster gives about 3 per broadcast interval).
  static constexpr double SAMPLE_PERIOD = 0.01;
  /// A holder whose newest sample is this much older than ~anchor_lag [s] is reported stopped
  /// (WARN): a moving or resting tf frame is broadcast all along.
  static constexpr double STALE_AFTER = 1.0;

  /// `frame_prefix` the node's particle frames' (~frame_prefix): a holder may not be one.
  FrameAnchors(ros::NodeHandle node, SimulationRunner& runner, std::string fixed_frame,
               std::string frame_prefix);
  /// Starts tf2's listener if it is not listening yet (only a node with a holder listens: every
  /// /tf message a listener takes is one more way for tf2 to fail).
  void listen();

  /// Follows the holders of `snap`'s model (a new Snapshot::tracks_serial: new subscriptions).
  void update(const Snapshot& snap);
  /// Diagnostics rows (key, value) for every holder; true if one wants a WARN, with `warning`
  /// saying which and why.
  bool report(const Snapshot& snap,
              const std::function<void(const std::string&, const std::string&)>& add,
              std::string& warning);
  /// tf, for the anchor wrenches' frames.
  tf2_ros::Buffer& buffer()
  {
    return buffer_;
  }

private:
  struct Holder
  {
    int track = 0;
    int particle = 0;
    std::string frame, topic;
    Vec3 offset = Vec3::Zero();
    std::int64_t next_ns = -1;    // the next grid stamp to sample [ns], -1: from the newest
    std::int64_t posted_ns = -1;  // the newest stamp posted [ns]
    bool found = false;           // the frame was in tf at the last look
    bool warned = false;          // its absence was logged
    std::string missing;          // why it is not followed now (tf's words), '' if it is
    std::uint64_t non_finite = 0, untransformable = 0;
    std::uint64_t logged_jumps = 0;                   // teleports already logged
    std::uint64_t logged_refused = 0;                 // refused teleports already logged
    std::uint64_t logged_future = 0;                  // samples ahead of the clock already reported
    std::uint64_t logged_dropped = 0;                 // dropped samples already reported
    std::string refused;                              // why it is never followed ('' if it may be)
    std::vector<geometry_msgs::PoseStamped> pending;  // poses tf could not resolve yet
    ros::Subscriber subscriber;
  };
  void sample(const ros::WallTimerEvent&);
  void sampleFrame(Holder& holder);
  void poseCallback(int track, const geometry_msgs::PoseStamped::ConstPtr& msg);
  /// A pose in `holder`'s topic resolved into ~fixed_frame and posted; false if tf cannot yet
  /// (its stamp newer than tf's newest: kept to try again).
  bool takePose(Holder& holder, const geometry_msgs::PoseStamped& msg, bool last_try);
  /// The held point and orientation of a transform of the holder's frame into ~fixed_frame.
  static HolderSample toSample(const geometry_msgs::Transform& transform, const Vec3& offset,
                               std::int64_t stamp_ns);
  /// As above, of the holder's pose in ~fixed_frame.
  static HolderSample toSample(const Eigen::Isometry3d& pose, const Vec3& offset,
                               std::int64_t stamp_ns);

  // the timer and the pose callbacks on a queue and thread of their own: service calls waiting
  // for the runner on the node's queue cannot hold up the sampling
  ros::CallbackQueue queue_;
  ros::NodeHandle node_;
  SimulationRunner& runner_;
  std::string fixed_frame_;
  std::string frame_prefix_;
  tf2_ros::Buffer buffer_;
  std::mutex listener_mutex_;                             // guards listener_'s creation
  std::unique_ptr<tf2_ros::TransformListener> listener_;  // its own thread; made by listen()
  std::mutex mutex_;          // guards below: timer, pose callbacks and publish()
  std::uint64_t serial_ = 0;  // Snapshot::tracks_serial followed
  std::vector<Holder> holders_;
  ros::WallTimer timer_;
  ros::AsyncSpinner spinner_;  // last: stopped (destroyed) first
};

}  // namespace constrained_particles
