/// @file scene_publisher.cpp
/// @brief ScenePublisher: the arrows, markers, cloud, surface, view and accuracy of a snapshot.
#include "constrained_particles/ros/scene_publisher.hpp"

#include "constrained_particles/Accuracy.h"
#include "constrained_particles/SceneView.h"
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/ros/markers.hpp"

#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_eigen/tf2_eigen.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
ScenePublisher::ScenePublisher(ros::NodeHandle node, const NodeParameters& parameters)
  : parameters_(parameters)
{
  arrows_ = node.advertise<visualization_msgs::MarkerArray>("constraint_forces", 10);
  scene_ = node.advertise<visualization_msgs::MarkerArray>("scene", 1, true);
  particles_ = node.advertise<sensor_msgs::PointCloud2>("particles", 2);
  // latched and sent once per scene whoever listens: a late subscriber gets the current scene's
  surface_ = node.advertise<visualization_msgs::MarkerArray>("surface", 1, true);
  obstacles_ = node.advertise<visualization_msgs::MarkerArray>("obstacles", 1, true);
  view_ = node.advertise<SceneView>("view", 1, true);
  accuracy_ = node.advertise<Accuracy>("accuracy", 10, true);
}

void ScenePublisher::publish(const Snapshot& snap, const std_msgs::Header& header)
{
  const int n = static_cast<int>(snap.state.positions.cols());
  if (arrows_.getNumSubscribers() > 0)
    publishArrows(snap, header);
  if (scene_.getNumSubscribers() > 0)
  {
    scene_.publish(sceneMarkers(header, *snap.model, snap.state.positions, snap.multipliers));
    // ghosts only where the shadow's sample is at this snapshot's time: the distance is the error
    if (snap.reference_positions && snap.reference_positions->cols() == n &&
        snap.reference_positions->allFinite())
      scene_.publish(referenceMarkers(header, *snap.model, snap.state.positions,
                                      *snap.reference_positions,
                                      std::max(0.2, 3.0 / snap.parameters.publish_rate)));
  }
  if (particles_.getNumSubscribers() > 0)
    publishParticles(snap, header);
  if (topicCarriedShapes(*snap.model) && obstacles_.getNumSubscribers() > 0)
  {
    // a shape on a pose topic moves with its track: drawn again where it is now, alone (the same
    // ids, so no DELETEALL: each replaces its last)
    visualization_msgs::MarkerArray moved =
        obstacleMarkers(header, *snap.model, snap.region.low, snap.region.high, &snap.carriers,
                        snap.state.time, true);
    moved.markers.erase(moved.markers.begin());
    obstacles_.publish(moved);
  }
  publishAccuracy(snap, header);
}

void ScenePublisher::publishArrows(const Snapshot& snap, const std_msgs::Header& header)
{
  const int n = static_cast<int>(snap.state.positions.cols());
  // rviz keeps only the newest array (queue 1, so arrows never lag): a count's drop is deleted
  // in every array for a second, not once
  const auto now = std::chrono::steady_clock::now();
  if (n < published_arrows_)
  {
    stale_arrows_ = std::max(stale_arrows_, published_arrows_);
    stale_arrows_until_ = now + std::chrono::seconds(1);
  }
  if (now > stale_arrows_until_)
    stale_arrows_ = 0;
  const double scale = arrowScale(parameters_.force_scale, snap.constraint_forces,
                                  snap.region.radius(), arrowForceFloor(*snap.model));
  visualization_msgs::MarkerArray arrows =
      constraintForceMarkers(header, snap.state.positions, snap.constraint_forces, scale,
                             std::max(published_arrows_, stale_arrows_));
  // the contacts' normal and friction forces beside the totals (they are in them)
  const visualization_msgs::MarkerArray contact_arrows =
      contactForceMarkers(header, *snap.model, snap.state.positions, snap.contacts, scale,
                          published_contact_arrows_, &snap.carriers, snap.state.time);
  // two ids a contact: a particle contact's normal and friction arrows, a link capsule's normal
  // (slack links have none)
  published_contact_arrows_ = static_cast<int>(2 * snap.model->numContacts());
  arrows.markers.insert(arrows.markers.end(), contact_arrows.markers.begin(),
                        contact_arrows.markers.end());
  arrows_.publish(arrows);
  published_arrows_ = n;
}

void ScenePublisher::publishSceneOnce(const Snapshot& snap, const ros::Time& stamp)
{
  if (published_scene_serial_ >= snap.scene_serial)
    return;
  published_scene_serial_ = snap.scene_serial;
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = parameters_.fixed_frame;
  const RegionSpec& region = snap.region;
  surface_.publish(
      surfaceMarkers(header, *snap.model, region.low, region.high, parameters_.mesh_cells));
  obstacles_.publish(obstacleMarkers(header, *snap.model, region.low, region.high, &snap.carriers,
                                     snap.state.time));
  SceneView view;
  view.header = header;
  view.scenario = snap.scene->name;
  view.low = tf2::toMsg(Eigen::Vector3d(region.low));
  view.high = tf2::toMsg(Eigen::Vector3d(region.high));
  view.center = tf2::toMsg(Eigen::Vector3d(region.center()));
  view.radius = region.radius();
  view.particle_size = particleSize(*snap.model);
  view_.publish(view);
}

void ScenePublisher::publishParticles(const Snapshot& snap, const std_msgs::Header& header)
{
  const int n = static_cast<int>(snap.state.positions.cols());
  sensor_msgs::PointCloud2 cloud;
  cloud.header = header;
  // sensor_msgs' modifier and iterators lay out and fill the fields (the well-kept way to)
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(
      4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, "force", 1, sensor_msgs::PointField::FLOAT32);
  modifier.resize(static_cast<std::size_t>(n));
  cloud.height = 1;
  cloud.width = static_cast<std::uint32_t>(n);
  cloud.is_dense = true;
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z"),
      force(cloud, "force");
  for (int i = 0; i < n; ++i, ++x, ++y, ++z, ++force)
  {
    *x = static_cast<float>(snap.state.positions(0, i));
    *y = static_cast<float>(snap.state.positions(1, i));
    *z = static_cast<float>(snap.state.positions(2, i));
    *force = static_cast<float>(snap.constraint_forces.col(i).norm());
  }
  particles_.publish(cloud);
}

void ScenePublisher::publishAccuracy(const Snapshot& snap, const std_msgs::Header& header)
{
  const std::shared_ptr<const AccuracyReport>& a = snap.accuracy;
  if (!a || a->serial == published_accuracy_serial_)
    return;
  published_accuracy_serial_ = a->serial;
  Accuracy msg;
  msg.header = header;
  if (parameters_.publish_clock)
    msg.header.stamp = ros::Time(a->stamp);
  msg.scenario = snap.scene->name;
  msg.window_start = a->window_start;
  msg.window = a->window;
  msg.integrator = a->integrator;
  msg.stabilization = stabilizationName(a->stabilization);
  msg.dt = a->dt;
  msg.sample_times = a->sample_times;
  msg.position_errors = a->position_errors;
  msg.position_error = a->position_error;
  msg.error_growth_rate = a->error_growth_rate;
  msg.live_cpu_time_per_sim_second = a->live_cpu_per_sim_second;
  msg.reference_cpu_time_per_sim_second = a->reference_cpu_per_sim_second;
  msg.windows = static_cast<std::uint32_t>(a->windows);
  msg.skipped_windows = static_cast<std::uint32_t>(a->skipped);
  msg.abandoned_windows = static_cast<std::uint32_t>(a->abandoned);
  // nothing non-finite leaves the node
  bool finite = std::isfinite(msg.position_error) && std::isfinite(msg.error_growth_rate);
  for (const double e : msg.position_errors)
    finite = finite && std::isfinite(e);
  if (finite)
    accuracy_.publish(msg);
  else
    ROS_WARN_THROTTLE(5.0, "simulator: a non-finite accuracy window was not published");
}

}  // namespace constrained_particles
