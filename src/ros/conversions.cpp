#include "constrained_particles/ros/conversions.hpp"

#include <tf2_eigen/tf2_eigen.h>

namespace constrained_particles
{
std::vector<geometry_msgs::Point> toPointMsgs(const Points& points)
{
  std::vector<geometry_msgs::Point> out(points.cols());
  for (int i = 0; i < points.cols(); ++i)
    out[i] = tf2::toMsg(Eigen::Vector3d(points.col(i)));
  return out;
}

std::vector<geometry_msgs::Vector3> toVectorMsgs(const Points& vectors)
{
  std::vector<geometry_msgs::Vector3> out(vectors.cols());
  for (int i = 0; i < vectors.cols(); ++i)
    tf2::toMsg(Eigen::Vector3d(vectors.col(i)), out[i]);
  return out;
}

namespace
{
// Point and Vector3 alike: tf2::fromMsg has an overload for each
template <typename Message>
Points fromMessages(const std::vector<Message>& messages)
{
  Points out(3, messages.size());
  for (std::size_t i = 0; i < messages.size(); ++i)
  {
    Eigen::Vector3d value;
    tf2::fromMsg(messages[i], value);
    out.col(i) = value;
  }
  return out;
}

}  // namespace

Points fromMsgs(const std::vector<geometry_msgs::Point>& points)
{
  return fromMessages(points);
}

Points fromMsgs(const std::vector<geometry_msgs::Vector3>& vectors)
{
  return fromMessages(vectors);
}

}  // namespace constrained_particles
