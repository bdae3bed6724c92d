/// @file frame_anchors.hpp
/// @brief The node's side of frame anchors: each holder sampled at its own broadcasts (a tf
/// frame's, or a geometry_msgs/PoseStamped topic's) and posted to the runner, which never waits
/// for tf; the holders' /diagnostics.
#pragma once

#include "constrained_particles/ros/simulation_runner.hpp"

#include <geometry_msgs/PoseStamped.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>

#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

namespace constrained_particles
{
/// Why a holder on tf frame `frame` or PoseStamped topic `topic` cannot be followed by a node
/// whose particle frames start with `frame_prefix`, said of the frame or topic ("is one of this
/// node's particle frames ...": it would follow itself; "is not a valid ROS name ..."), or empty
/// if it can.
std::string holderRefusal(const std::string& frame, const std::string& topic,
                          const std::string& frame_prefix);

/// Samples holders for SimulationRunner::postHolderSamples.
///
/// tf: FrameAnchors subscribes to /tf and /tf_static itself and inserts every transform into
/// tf2's Buffer exactly as tf2_ros::TransformListener does (tf2 keeps the transforms and resolves
/// a chain at a stamp; its listener hides which stamps arrived, and those are the samples). A
/// holder frame is sampled at the stamp of every broadcast of a frame between it and
/// ~fixed_frame (its own, and its parents'), its pose there resolved by tf2 (exact for the frame
/// broadcast, the others interpolated at that stamp), never on a grid of its own. A chain all on
/// /tf_static is one still sample. A PoseStamped topic's poses are samples at their stamps,
/// resolved into ~fixed_frame through tf at that stamp. ROS time going back (a bag played again)
/// clears the buffer, as tf2_ros's listener does, and the sampling starts again.
class FrameAnchors
{
public:
  /// The timer's period [s]: poses whose parents tf could not resolve yet are tried again, and
  /// frames not yet in tf looked for.
  static constexpr double RETRY_PERIOD = 0.01;
  /// A moving holder whose newest broadcast arrived this long ago [s] is reported stopped (WARN).
  static constexpr double STALE_AFTER = 1.0;
  /// Broadcast stamps kept per frame for holders attached later [s].
  static constexpr double HISTORY = 2.0;

  /// `frame_prefix` the node's particle frames' (~frame_prefix): a holder may not be one.
  /// `clock_ns`: the node's stamp clock now [ns] (ROS time, or with ~publish_clock the /clock it
  /// publishes), what a sample's arrival is measured on.
  FrameAnchors(ros::NodeHandle node, SimulationRunner& runner, std::string fixed_frame,
               std::string frame_prefix, std::function<std::int64_t()> clock_ns);
  ~FrameAnchors();
  /// Subscribes to /tf and /tf_static if not yet (only a node with a holder, or asked to
  /// attach, listens: every /tf message it takes is one more way for tf2 to fail).
  void listen();

  /// Follows the holders of `snap`'s model (a new Snapshot::tracks_serial: new subscriptions).
  void update(const Snapshot& snap);
  /// Diagnostics rows (key, value) for every holder and every hold let go; true if one wants a
  /// WARN, with `warning` saying which and why.
  bool report(const Snapshot& snap,
              const std::function<void(const std::string&, const std::string&)>& add,
              std::string& warning);
  /// Waits (wall time) up to `timeout` [s] for `frame` to be in tf; true if it is.
  bool waitForFrame(const std::string& frame, double timeout);
  /// `frame`'s pose in ~fixed_frame at a stamp (-1: the newest), looked up without waiting (for
  /// ~attach).
  SimulationRunner::PoseLookup poseLookup(const std::string& frame);

private:
  struct Broadcast
  {
    std::int64_t stamp_ns, arrival_ns;
  };
  struct Holder
  {
    int track = 0;      // anchors' tracks first, then the carried obstacles' (HolderSession)
    int particle = 0;   // -1: it carries an obstacle
    std::string label;  // "frame_anchor on particle 3", "obstacle 'finger'"
    std::string moved;  // what it moves: "the particle", "the obstacle"
    std::string frame, topic;
    std::string name;  // the holder: its frame, or its topic (holderOf)
    Vec3 offset = Vec3::Zero();
    std::int64_t since_ns = -1;  // samples wanted after this stamp [ns] (an attach's)
    /// What goes on while the runner keeps the holder (an attach or detach of another)
    struct Sampling
    {
      std::int64_t posted_ns = -1;                   // the newest stamp posted [ns]
      std::map<std::int64_t, std::int64_t> waiting;  // stamps to sample -> their arrival [ns]
      bool found = false;                            // the frame was in tf at the last look
      bool warned = false;                           // its absence was logged
      bool still = false;                 // its chain is all on /tf_static: one sample is its path
      std::int64_t still_posted_ns = -1;  // when its still sample was last posted [ns]
      std::int64_t newest_arrival_ns = -1;  // when its newest broadcast arrived (ROS time) [ns]
      std::uint64_t non_finite = 0, untransformable = 0;
      std::uint64_t logged_jumps = 0;     // teleports already logged
      std::uint64_t logged_refused = 0;   // refused teleports already logged
      std::uint64_t logged_future = 0;    // samples ahead of the clock already reported
      std::uint64_t logged_dropped = 0;   // dropped samples already reported
      std::uint64_t logged_overruns = 0;  // overruns already reported
    } s;
    std::string missing;  // why it is not followed now (tf's words), '' if it is
    std::string refused;  // why it is never followed ('' if it may be)
    std::vector<geometry_msgs::PoseStamped> pending;  // poses tf could not resolve yet
    ros::Subscriber subscriber;
  };
  void tfCallback(const ros::MessageEvent<tf2_msgs::TFMessage const>& event, bool is_static);
  void retry(const ros::WallTimerEvent&);
  /// The frames whose motion moves `frame` in ~fixed_frame: those between them in tf's tree.
  std::set<std::string> chainOf(const std::string& frame) const;
  /// The holder's waiting stamps that tf can resolve at `now_ns`, posted in order with that time
  /// as their arrival (when they could be used); one waiting over a second is given up and
  /// counted.
  void sampleWaiting(Holder& holder, std::int64_t now_ns);
  /// A holder frame's state in tf now: found, still (a static chain: posted once), or missing.
  void lookFor(Holder& holder, std::int64_t now_ns);
  void poseCallback(int track, const geometry_msgs::PoseStamped::ConstPtr& msg);
  /// A pose in `holder`'s topic resolved into ~fixed_frame and posted; false if tf cannot yet
  /// (its stamp newer than tf's newest: kept to try again).
  bool takePose(Holder& holder, const geometry_msgs::PoseStamped& msg, bool last_try);
  /// Forgets every sample in flight: ROS time went back.
  void restartSampling();
  /// The held point and orientation of the holder's pose in ~fixed_frame.
  static HolderSample toSample(const Eigen::Isometry3d& pose, const Vec3& offset,
                               std::int64_t stamp_ns, std::int64_t arrival_ns);

  // the tf and pose callbacks and the timer on a queue and thread of their own: service calls
  // waiting for the runner on the node's queue cannot hold up the sampling
  ros::CallbackQueue queue_;
  ros::NodeHandle node_;
  SimulationRunner& runner_;
  std::string fixed_frame_;
  std::string frame_prefix_;
  std::function<std::int64_t()> clock_ns_;
  tf2_ros::Buffer buffer_;
  std::mutex mutex_;  // guards below: the callbacks, the timer, update() and report()
  ros::Subscriber tf_subscriber_, tf_static_subscriber_;
  ros::Time last_update_;                                 // ROS time at the last /tf message
  std::map<std::string, std::string> parent_;             // child frame -> its parent
  std::map<std::string, std::deque<Broadcast>> history_;  // child frame -> recent broadcasts
  std::uint64_t serial_ = 0;                              // Snapshot::tracks_serial followed
  std::vector<Holder> holders_;
  std::size_t logged_releases_ = 0;  // holds let go already logged (Snapshot::releases)
  ros::WallTimer timer_;
  ros::AsyncSpinner spinner_;  // last: stopped (destroyed) first
};

}  // namespace constrained_particles
