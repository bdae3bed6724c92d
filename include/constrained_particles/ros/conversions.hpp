/// @file conversions.hpp
/// @brief Core types to and from ROS messages (through tf2_eigen).
#pragma once

#include "constrained_particles/core/types.hpp"

#include <geometry_msgs/Point.h>
#include <geometry_msgs/Vector3.h>

#include <vector>

namespace constrained_particles
{
/// Columns of `points` [m] as geometry_msgs/Point.
std::vector<geometry_msgs::Point> toPointMsgs(const Points& points);
/// Columns of `vectors` as geometry_msgs/Vector3.
std::vector<geometry_msgs::Vector3> toVectorMsgs(const Points& vectors);
/// geometry_msgs/Point list as a 3 x n array.
Points fromMsgs(const std::vector<geometry_msgs::Point>& points);
/// geometry_msgs/Vector3 list as a 3 x n array.
Points fromMsgs(const std::vector<geometry_msgs::Vector3>& vectors);

}  // namespace constrained_particles
