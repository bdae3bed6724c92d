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

Points fromMsgs(const std::vector<geometry_msgs::Point>& points)
{
  Points out(3, points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    Eigen::Vector3d p;
    tf2::fromMsg(points[i], p);
    out.col(i) = p;
  }
  return out;
}

Points fromMsgs(const std::vector<geometry_msgs::Vector3>& vectors)
{
  Points out(3, vectors.size());
  for (std::size_t i = 0; i < vectors.size(); ++i)
  {
    Eigen::Vector3d v;
    tf2::fromMsg(vectors[i], v);
    out.col(i) = v;
  }
  return out;
}

}  // namespace constrained_particles
