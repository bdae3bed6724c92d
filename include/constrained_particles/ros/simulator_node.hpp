/// @file simulator_node.hpp
/// @brief The ROS interface of the simulator: tf frames, ~state, markers, services and
/// dynamic_reconfigure around a core Simulator.
#pragma once

#include "constrained_particles/SimulatorConfig.h"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/ros/markers.hpp"
#include "constrained_particles/ros/parameters.hpp"
#include "constrained_particles/ros/reconfigure_server.hpp"

#include <constrained_particles/ListScenes.h>
#include <constrained_particles/Reset.h>
#include <constrained_particles/SetChain.h>
#include <constrained_particles/SetState.h>
#include <constrained_particles/SetSurface.h>
#include <constrained_particles/Step.h>
#include <ros/ros.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>

namespace constrained_particles
{
/// Steps the simulation in its own thread at a fixed dt paced against wall time by
/// real_time_factor, and publishes at publish_rate from the ROS callback queue. One mutex
/// serialises stepping, services, reconfiguration and the snapshot taken for publishing.
class SimulatorNode
{
public:
  /// Reads the private parameters and starts stepping.
  /// @throws InvalidInput naming a bad parameter
  explicit SimulatorNode(const ros::NodeHandle& private_nh);
  ~SimulatorNode();

  SimulatorNode(const SimulatorNode&) = delete;
  SimulatorNode& operator=(const SimulatorNode&) = delete;

  /// Publishes tf, ~state and the subscribed marker topics once.
  void publish();

private:
  using Clock = std::chrono::steady_clock;

  /// A copy of what publishing needs, taken under the lock.
  struct Snapshot
  {
    std::string scenario;
    State state;
    Points constraint_forces;
    Eigen::VectorXd multipliers;
    Diagnostics diagnostics;
    double step_time = 0;
    double real_time_factor = 0;
    bool behind = false;
    std::uint8_t status = 0;
    std::string status_message;
    bool scene_changed = false;
    std::shared_ptr<const Model> model;  ///< only when scene markers are wanted
  };

  void physicsLoop();
  /// Restarts wall-time pacing from the current sim time. Caller holds mutex_.
  void reanchorLocked();
  /// Loads a scene by name or path, applies its solver settings, and resets to it.
  /// Caller holds mutex_. @throws InvalidInput naming `field`; nothing changes
  void loadSceneLocked(const std::string& name_or_path, const std::string& field);
  /// A scene's step settings: the defaults, then its `solver` section, then chosen_step_.
  StepSettings settingsFor(const SceneDescription& scene) const;
  /// Rebuilds the simulator from `description` (which becomes the current scene) and resets.
  /// Caller holds mutex_. @throws InvalidInput; nothing changes
  void rebuildLocked(const SceneDescription& description, const StepSettings& settings);
  /// Shows the current settings, gravity and damping in dynamic_reconfigure. Caller must not
  /// hold mutex_ (the reconfigure callback takes it).
  void pushReconfigure();
  /// Steps `count` times, timing them and checking the result is finite. Caller holds mutex_.
  void stepLocked(int count);

  bool resetCallback(Reset::Request& request, Reset::Response& response);
  bool listScenesCallback(ListScenes::Request& request, ListScenes::Response& response);
  bool setSurfaceCallback(SetSurface::Request& request, SetSurface::Response& response);
  bool setChainCallback(SetChain::Request& request, SetChain::Response& response);
  bool setStateCallback(SetState::Request& request, SetState::Response& response);
  bool pauseCallback(std_srvs::Empty::Request& request, std_srvs::Empty::Response& response);
  bool unpauseCallback(std_srvs::Empty::Request& request, std_srvs::Empty::Response& response);
  bool stepCallback(Step::Request& request, Step::Response& response);
  /// Applies a dynamic_reconfigure request; false (and nothing changed) if any value is bad.
  bool reconfigureCallback(const SimulatorConfig& config);
  void statusCallback(const ros::WallTimerEvent& event);
  /// Publishes the node's health on /diagnostics, after updating the achieved real-time factor.
  void diagnosticsCallback(const ros::WallTimerEvent& event);
  /// Achieved real-time factor and whether stepping fell behind, over the time since the last
  /// call. Caller holds mutex_.
  void updateRateLocked();
  /// Stops stepping, puts back the last good state and logs why. Caller holds mutex_.
  void faultLocked(const std::string& reason);

  ros::NodeHandle nh_;
  NodeParameters parameters_;
  // the step settings the user chose (start-up parameters, then dynamic_reconfigure changes):
  // they win over every scene's `solver` settings; what neither sets takes its default
  SolverSpec chosen_step_;

  std::mutex mutex_;  // guards everything from here to the publishers
  std::unique_ptr<Simulator> simulator_;
  std::shared_ptr<const Model> published_model_;  // copy of the model for scene markers
  SceneDescription scene_;  // the current scene, with the changes services made to it
  bool paused_ = false;
  bool faulted_ = false;  // stepping stopped until ~reset (fault_reason_ says why)
  std::string fault_reason_;
  State last_good_state_;       // before the last batch of steps
  bool scene_changed_ = true;   // scene markers need their mesh rebuilt
  double step_time_ = 0.0;      // wall time of the last physics step [s]
  int behind_events_ = 0;       // batches that fell behind wall time since the last rate update
  bool behind_ = false;         // fell behind in the last second
  double achieved_rtf_ = 0.0;   // sim seconds per wall second over the last second
  double rate_sim_time_ = 0.0;  // sim time at the last rate update [s]
  Clock::time_point rate_wall_;
  Clock::time_point anchor_wall_;
  double anchor_sim_time_ = 0.0;
  std::condition_variable wake_physics_;
  std::atomic<bool> running_{ true };
  std::thread physics_thread_;

  int published_arrows_ = 0;  // publishing thread only
  SurfaceMeshCache mesh_cache_;
  ros::Publisher clock_publisher_;  // /clock, with ~publish_clock

  ros::Publisher state_publisher_, force_marker_publisher_, scene_marker_publisher_,
      diagnostics_publisher_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::vector<ros::ServiceServer> services_;
  ros::WallTimer publish_timer_, status_timer_, diagnostics_timer_;
  std::unique_ptr<ReconfigureServer<SimulatorConfig>> reconfigure_server_;
};

}  // namespace constrained_particles
