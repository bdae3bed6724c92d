/// @file anchor_wrenches.hpp
/// @brief ~anchor_wrench/<particle frame>: the force the scene exerts on each particle's holder
/// (a pin, a driven anchor), as a force/torque sensor in the holder would read it.
#pragma once

#include "constrained_particles/ros/simulation_runner.hpp"

#include <geometry_msgs/WrenchStamped.h>
#include <ros/ros.h>
#include <std_msgs/Header.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace constrained_particles
{
/// The holder's wrench of held particle i: the force the scene exerts on its holder,
/// -r = f_i + (J^T lambda)_i - m_i a_i(t) [N] (r: Model::eliminatedReaction, the force the
/// holder exerts on the particle, so m a = f + J^T lambda + r), torque 0 (particles). A chain of
/// n particles of mass m hanging at rest from a pin reads (0, 0, -n m g).
Vec3 holderForce(const Model& model, const Eigen::VectorXd& multipliers, int eliminated_index);

/// The topic name of particle frame `frame` under ~anchor_wrench: the frame with every character
/// a ROS name may not hold ([A-Za-z0-9_/] only) written '_', e.g. "anchor_wrench/particle_0".
std::string anchorWrenchTopic(const std::string& frame);

/// `prefix` + "/" + `name` as a ROS name: every character a name may not hold ([A-Za-z0-9_/]
/// only) written '_', each part starting with a letter ('_' put before one that does not).
std::string wrenchTopic(const std::string& prefix, const std::string& name);

/// One geometry_msgs/WrenchStamped publisher per held particle of the scene in force: when the
/// scene changes, topics it still has keep their publishers (and their subscribers), new ones
/// are advertised and vanished ones end. Each message built only while its topic has a
/// subscriber. Used by the node's publishing thread only.
class AnchorWrenches
{
public:
  /// `node` the private handle (~), `frame_prefix` the particle frames' (~frame_prefix).
  AnchorWrenches(ros::NodeHandle node, std::string frame_prefix);
  /// Advertises the topics of `snap`'s held particles (a new scene or holders: see the class),
  /// so that subscribers connect before anything is published (the first /clock's wrench).
  void update(const Snapshot& snap);
  /// Publishes every held particle's holderForce() from `snap`, stamped with `header` (frame:
  /// ~fixed_frame, whose axes the force is in; a frame_anchor's in its holder's tf frame,
  /// turned by the holder's orientation at the state's time, Snapshot::holder_orientations).
  void publish(const Snapshot& snap, const std_msgs::Header& header);

private:
  ros::NodeHandle node_;
  std::string frame_prefix_;
  std::uint64_t scene_serial_ = 0;                  // the scene the publishers are for
  std::uint64_t tracks_serial_ = 0;                 // and its holders (an ~attach changes them)
  std::map<std::string, ros::Publisher> by_topic_;  // every held particle's, by topic name
  std::vector<ros::Publisher*> publishers_;         // one per Model::eliminated() record
};

}  // namespace constrained_particles
