/// @file obstacle_wrenches.hpp
/// @brief ~obstacle_wrench/<shape>: the load the scene puts on each obstacle (shape_contact's and
/// segment_contact's shapes), as a force/torque sensor holding the obstacle at its origin would
/// read it.
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
/// One obstacle's load: the forces its acting contacts take (Newton's third law: minus each
/// contact's normal force along the shape's normal and its friction force) [N], and their torque
/// about the shape's origin [N m], each applied where the particle's ball touches the shape
/// (p_i - r n), or a link's capsule (x(s*) - r n, its normal force only: frictionless).
struct ObstacleWrench
{
  std::string shape;  ///< its name (Shape::name)
  Vec3 force = Vec3::Zero();
  Vec3 torque = Vec3::Zero();
};

/// Every obstacle of `model` (its shape_contact records' shapes, each once by name, in the order
/// they first appear, then any only a segment_contact names) with its load at `positions` (3 x n
/// [m]) and `contacts` (Data::contacts: a contact off takes nothing). A chain of n particles of
/// mass m resting on a plane loads it with (0, 0, -n m g). `contacts` shorter than the model's
/// contacts (another scene's): all zero. Carried shapes are where `carriers` (Data::carriers) puts
/// them at `time` [s], their torque about their origin there.
std::vector<ObstacleWrench> obstacleWrenches(const Model& model, const Points& positions,
                                             const std::vector<ContactState>& contacts,
                                             const std::vector<AnchorTrack>* carriers = nullptr,
                                             double time = 0.0);

/// The topic name of obstacle `shape` under ~obstacle_wrench: characters a ROS name may not hold
/// written '_', e.g. "obstacle_wrench/post".
std::string obstacleWrenchTopic(const std::string& shape);

/// One geometry_msgs/WrenchStamped publisher per obstacle of the scene in force, kept across
/// scene changes for the names that stay (as AnchorWrenches); each message built only while its
/// topic has a subscriber. Used by the node's publishing thread only.
class ObstacleWrenches
{
public:
  explicit ObstacleWrenches(ros::NodeHandle node);
  /// Advertises the topics of `snap`'s obstacles when its scene changed.
  void update(const Snapshot& snap);
  /// Publishes each obstacle's load from `snap`, stamped with `header` (~fixed_frame's axes).
  void publish(const Snapshot& snap, const std_msgs::Header& header);

private:
  ros::NodeHandle node_;
  std::uint64_t scene_serial_ = 0;
  std::map<std::string, ros::Publisher> by_topic_;
};

}  // namespace constrained_particles
