/// @file simulator_node.hpp
/// @brief The ROS interface of the simulator: tf frames, ~state, markers, services and
/// dynamic_reconfigure around a core Simulator.
#pragma once

#include "constrained_particles/SimulatorConfig.h"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/ros/anchor_wrenches.hpp"
#include "constrained_particles/ros/obstacle_wrenches.hpp"
#include "constrained_particles/ros/frame_anchors.hpp"
#include "constrained_particles/ros/compare_methods_server.hpp"
#include "constrained_particles/ros/grab_markers.hpp"
#include "constrained_particles/ros/markers.hpp"
#include "constrained_particles/ros/parameters.hpp"
#include "constrained_particles/ros/reconfigure_server.hpp"
#include "constrained_particles/ros/scene_publisher.hpp"
#include "constrained_particles/ros/simulation_runner.hpp"
#include "constrained_particles/ros/tf_publisher.hpp"
#include "constrained_particles/ros/wrench_commands.hpp"

#include <constrained_particles/ApplyForce.h>
#include <constrained_particles/Attach.h>
#include <constrained_particles/ClearForces.h>
#include <constrained_particles/Detach.h>
#include <constrained_particles/ListScenes.h>
#include <constrained_particles/Reset.h>
#include <constrained_particles/SetChain.h>
#include <constrained_particles/SetState.h>
#include <constrained_particles/SetObstacle.h>
#include <constrained_particles/SetSurface.h>
#include <constrained_particles/Step.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Empty.h>
#include <tf2_msgs/TFMessage.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>

namespace constrained_particles
{
/// The ROS face of a SimulationRunner: services and dynamic_reconfigure become runner requests
/// (answered once applied between batches); tf, ~state, /clock, markers, /diagnostics and the
/// status line are published from the runner's latest snapshot on wall-clock timers, so nothing
/// here waits for a step. Callbacks run on a multi-threaded spinner: a long ~step occupies one
/// thread while ~pause, publishing and diagnostics go on.
class SimulatorNode
{
public:
  /// Reads the private parameters, loads the scene and starts stepping.
  /// @throws InvalidInput naming a bad parameter (nothing is started)
  explicit SimulatorNode(const ros::NodeHandle& private_nh);
  ~SimulatorNode();

  SimulatorNode(const SimulatorNode&) = delete;
  SimulatorNode& operator=(const SimulatorNode&) = delete;

  /// Stops stepping and refuses waiting requests; false if a step still runs after `timeout`.
  bool shutdown(std::chrono::milliseconds timeout);

  /// Why the node gave up after it started (another node took /clock: see the constructor's
  /// clock check), or empty; then it has asked ROS to shut down and should exit with status 1.
  std::string refusal() const;

  /// Publishes tf, ~state, /clock and the subscribed marker topics from the latest snapshot,
  /// only if its stamp (stampFor) has advanced past the last one sent, so no stamp is ever sent
  /// twice, whichever clock the stamps come from.
  void publish();

private:
  /// The clock a message about `snap` is stamped with: its sim time (Snapshot::stamp) with
  /// ~publish_clock; with ~follow_clock the /clock time its state stands for
  /// (Snapshot::stamp_ns, 0 before the first /clock); on wall time the ROS time it stands for
  /// (never after `now`; `now` while paused or faulted); under a foreign /clock, `now`.
  ros::Time stampOf(const Snapshot& snap, const ros::Time& now) const;
  /// Why nothing goes out before a /clock: CLOCK_WAIT_MESSAGE, or FOLLOW_WAIT_MESSAGE.
  const char* waitMessage() const;
  /// The stamp of what publish() sends for `snap` (stampOf). Empty when nothing may go out: the
  /// stamp has not advanced past the last one sent (tf2 drops a repeat: TF_REPEATED_DATA); it
  /// is 0 because /use_sim_time is set and no /clock has arrived (then says so once, and in
  /// /diagnostics), or on wall time because the runner has not paced its first batch (quietly);
  /// or, following /clock, it is ahead of the newest clock (a state of the epoch
  /// before the clock went back: a tf2 listener would keep it as its newest for a whole loop).
  /// Following /clock, a new epoch (Snapshot::epoch) starts a new timeline; otherwise a stamp
  /// earlier than the last one sent (a foreign clock restarted) does, with a warning. Caller
  /// holds publish_mutex_.
  std::optional<ros::Time> stampFor(const Snapshot& snap, const ros::Time& now);
  /// ~publish_clock, for CLOCK_CHECK_PERIOD after advertising: gives way (refusal(), shutdown)
  /// to another live /clock publisher whose name sorts first.
  void checkClockCallback(const ros::WallTimerEvent& event);
  /// ScenePublisher::publishSceneOnce for the latest snapshot, from a service that changed the
  /// scene (left to publish() while no stamp may go out: see stampFor).
  void publishNewScene();
  /// Shows the settings, gravity and damping in force in dynamic_reconfigure.
  void pushReconfigure();
  /// Advertises service `name` (~name) answered by `callback`.
  template <typename Request, typename Response>
  void serve(const char* name, bool (SimulatorNode::*callback)(Request&, Response&));

  bool resetCallback(Reset::Request& request, Reset::Response& response);
  bool listScenesCallback(ListScenes::Request& request, ListScenes::Response& response);
  bool setSurfaceCallback(SetSurface::Request& request, SetSurface::Response& response);
  bool setObstacleCallback(SetObstacle::Request& request, SetObstacle::Response& response);
  bool setChainCallback(SetChain::Request& request, SetChain::Response& response);
  bool setStateCallback(SetState::Request& request, SetState::Response& response);
  bool pauseCallback(std_srvs::Empty::Request& request, std_srvs::Empty::Response& response);
  bool unpauseCallback(std_srvs::Empty::Request& request, std_srvs::Empty::Response& response);
  bool stepCallback(Step::Request& request, Step::Response& response);
  bool applyForceCallback(ApplyForce::Request& request, ApplyForce::Response& response);
  bool clearForcesCallback(ClearForces::Request& request, ClearForces::Response& response);
  bool attachCallback(Attach::Request& request, Attach::Response& response);
  bool detachCallback(Detach::Request& request, Detach::Response& response);
  /// Applies the fields of a dynamic_reconfigure request that differ from what the server showed
  /// (so a request built on a stale view cannot undo a ~reset); false (and nothing changed) if
  /// any value is bad. `in_force` gets the settings then in force.
  bool reconfigureCallback(const SimulatorConfig& shown, const SimulatorConfig& requested,
                           SimulatorConfig& in_force);
  void statusCallback(const ros::WallTimerEvent& event);
  /// Publishes the node's health (health.hpp) and the core's reports since the last call on
  /// /diagnostics.
  void diagnosticsCallback(const ros::WallTimerEvent& event);

  ros::NodeHandle nh_;
  NodeParameters parameters_;  // as started; what changes at run time is in the snapshots
  // publishing, diagnostics and /tf's connect callback on a queue and thread of their own: any
  // number of service calls waiting for the runner cannot hold them up
  ros::CallbackQueue publish_queue_;
  ros::NodeHandle publish_nh_;
  ros::AsyncSpinner publish_spinner_;
  std::unique_ptr<SimulationRunner> runner_;
  // the topic families, one class each (they read runner_'s snapshots: they go first)
  std::unique_ptr<CompareMethodsServer> compare_methods_;
  std::unique_ptr<GrabMarkers> grab_markers_;
  std::unique_ptr<WrenchCommands> wrench_commands_;
  std::unique_ptr<AnchorWrenches> anchor_wrenches_;      // publish() only
  std::unique_ptr<ObstacleWrenches> obstacle_wrenches_;  // publish() only
  std::unique_ptr<FrameAnchors> frame_anchors_;
  std::unique_ptr<TfPublisher> tf_publisher_;
  std::unique_ptr<ScenePublisher> scene_publisher_;

  std::mutex publish_mutex_;  // publish() only: timer callbacks may overlap on the spinner
  std::optional<ros::Time> last_stamp_;            // the stamp of the last /tf and ~state sent
  std::uint64_t last_epoch_ = 0;                   // its Snapshot::epoch
  ros::Time last_clock_;                           // ~publish_clock: the last /clock sent
  std::atomic<std::int64_t> clock_sent_ns_{ -1 };  // the same in ns, for the holders' sampling
  // stamps are sim time (~publish_clock or /use_sim_time): they may stand still, so /tf and
  // ~state go out (latched) whoever listens, and a late /tf subscriber gets the last frames
  bool sim_time_stamps_ = false;
  // /use_sim_time and no /clock yet: nothing stamped goes out (WARN in /diagnostics)
  std::atomic<bool> waiting_for_clock_{ false };
  std::string logged_fault_;      // diagnostics timer: the fault last logged
  bool logged_fallback_ = false;  // diagnostics timer: the energy fallback's warning logged
  ros::Publisher clock_publisher_, state_publisher_, diagnostics_publisher_;
  std::vector<ros::ServiceServer> services_;
  ros::WallTimer publish_timer_, status_timer_, diagnostics_timer_;
  // ~publish_clock: /clock's publishers checked again for a while after advertising
  ros::WallTimer clock_check_timer_;
  ros::Subscriber clock_subscriber_;  // ~follow_clock: each /clock to the runner
  std::chrono::steady_clock::time_point clock_check_until_;
  mutable std::mutex refusal_mutex_;
  std::string refusal_;
  std::unique_ptr<ReconfigureServer<SimulatorConfig>> reconfigure_server_;
};

}  // namespace constrained_particles
