/// @file grab_markers.hpp
/// @brief Grab and drag (~interactive): an interactive marker on each particle, served on ~grab by
/// interactive_markers (the library rviz's InteractiveMarkers display talks to). While a user
/// holds one, its particle is pulled towards the marker by a critically damped target spring
/// (SimulationRunner::drag); on release the spring goes. Markers follow their particles while
/// nobody holds them.
#pragma once

#include "constrained_particles/ros/simulation_runner.hpp"

#include <interactive_markers/interactive_marker_server.h>
#include <ros/ros.h>
#include <visualization_msgs/InteractiveMarkerFeedback.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <string>

namespace constrained_particles
{
class GrabMarkers
{
public:
  /// Serves on `<private_nh>/grab` (update, update_full, feedback); markers in `fixed_frame`.
  GrabMarkers(const ros::NodeHandle& private_nh, SimulationRunner& runner, std::string fixed_frame);

  GrabMarkers(const GrabMarkers&) = delete;
  GrabMarkers& operator=(const GrabMarkers&) = delete;

  /// Particles that carry a marker: those with a tf frame (tfFrameCount), or with ~tf_frames 0
  /// the first limits::DEFAULT_TF_FRAMES.
  static int markerCount(int particles, int tf_frames);

  /// From the publishing thread only: shows the markers (~interactive), hides them and releases
  /// every drag (not), rebuilds them for a new scene or count, and moves those nobody holds.
  void update(const Snapshot& snap);

  /// A held particle whose holder sent nothing for this long is let go (rviz or drag.py gone
  /// without a MOUSE_UP) [s]; rviz repeats a held marker's pose (or a keep-alive) meanwhile.
  static constexpr double HOLD_TIMEOUT = 2.0;

private:
  void feedback(const visualization_msgs::InteractiveMarkerFeedbackConstPtr& feedback);

  SimulationRunner& runner_;
  std::string fixed_frame_;
  // the server calls feedback() holding its own lock: held_mutex_ is never held while calling it
  std::mutex held_mutex_;
  std::map<int, std::chrono::steady_clock::time_point> held_;  // particle -> last feedback
  std::atomic<int> shown_{ 0 };                                // markers on the server
  std::atomic<std::uint64_t> marker_scene_{ 0 };  // the scene serial the markers were made for
  // the publishing thread's own
  int particles_ = 0;  // the scene's particle count when the markers were made
  std::uint64_t snapshot_serial_ = 0;
  // last: destroyed first, so no feedback arrives while the members above go
  interactive_markers::InteractiveMarkerServer server_;
};

}  // namespace constrained_particles
