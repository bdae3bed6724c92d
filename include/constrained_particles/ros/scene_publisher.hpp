/// @file scene_publisher.hpp
/// @brief What rviz draws of a snapshot: ~constraint_forces (the constraint-force and contact
/// arrows), ~scene (particles, links, surfaces; the accuracy window's ghosts), ~particles (a
/// point cloud), ~surface and ~view once per scene, and ~accuracy's reports.
#pragma once

#include "constrained_particles/ros/parameters.hpp"
#include "constrained_particles/ros/simulation_runner.hpp"

#include <ros/ros.h>
#include <std_msgs/Header.h>

#include <chrono>
#include <cstdint>

namespace constrained_particles
{
/// One class per topic family (turtlesim's shape): these publishers and what they last sent.
/// Used by the node's publishing thread, and publishSceneOnce also by a service under the
/// node's publishing lock.
class ScenePublisher
{
public:
  /// `node`: the private handle (~); the node's parameters as started.
  ScenePublisher(ros::NodeHandle node, const NodeParameters& parameters);
  /// The arrows, scene markers, cloud and accuracy report of `snap`, stamped `header` (each
  /// built only while its topic has a subscriber; the accuracy report once, latched).
  void publish(const Snapshot& snap, const std_msgs::Header& header);
  /// Once per scene, whoever listens (latched, so a late subscriber gets the current scene's):
  /// ~surface (the mesh over the region) and ~view (the region), stamped `stamp`.
  void publishSceneOnce(const Snapshot& snap, const ros::Time& stamp);

private:
  void publishArrows(const Snapshot& snap, const std_msgs::Header& header);
  /// ~particles: x, y, z [m] and |constraint force| [N] per particle (sensor_msgs/PointCloud2).
  void publishParticles(const Snapshot& snap, const std_msgs::Header& header);
  /// ~accuracy: the snapshot's report, once (stamped by the node's clock with ~publish_clock).
  void publishAccuracy(const Snapshot& snap, const std_msgs::Header& header);

  const NodeParameters parameters_;
  ros::Publisher arrows_, scene_, particles_, surface_, obstacles_, view_, accuracy_;
  std::uint64_t published_scene_serial_ = 0, published_accuracy_serial_ = 0;
  int published_arrows_ = 0;
  int published_contact_arrows_ = 0;  // contact arrow ids sent last: more are deleted
  int stale_arrows_ = 0;              // arrow ids up to this are deleted until stale_arrows_until_
  std::chrono::steady_clock::time_point stale_arrows_until_;
};

}  // namespace constrained_particles
