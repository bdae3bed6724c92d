#include "constrained_particles/ros/grab_markers.hpp"

#include "constrained_particles/ros/markers.hpp"

#include <algorithm>
#include <cstdlib>

namespace constrained_particles
{
namespace
{
using visualization_msgs::InteractiveMarker;
using visualization_msgs::InteractiveMarkerControl;
using visualization_msgs::InteractiveMarkerFeedback;

geometry_msgs::Pose poseAt(const Points& positions, int i)
{
  geometry_msgs::Pose pose;
  pose.position.x = positions(0, i);
  pose.position.y = positions(1, i);
  pose.position.z = positions(2, i);
  pose.orientation.w = 1.0;
  return pose;
}

/// "3" -> 3; -1 for anything that is not a marker name of ours.
int particleOf(const std::string& name)
{
  if (name.empty() || name.size() > 9 ||
      !std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return -1;
  return std::atoi(name.c_str());
}

}  // namespace

GrabMarkers::GrabMarkers(const ros::NodeHandle& private_nh, SimulationRunner& runner,
                         std::string fixed_frame)
  : runner_(runner), fixed_frame_(std::move(fixed_frame)), server_(private_nh.resolveName("grab"))
{
}

int GrabMarkers::markerCount(int particles, int tf_frames)
{
  return tf_frames == 0 ? std::min(particles, limits::DEFAULT_TF_FRAMES)
                        : tfFrameCount(particles, tf_frames);
}

void GrabMarkers::update(const Snapshot& snap)
{
  const std::uint64_t scene = marker_scene_;
  // holders gone without a MOUSE_UP: let go
  {
    const auto now = std::chrono::steady_clock::now();
    std::lock_guard<std::mutex> lock(held_mutex_);
    for (auto it = held_.begin(); it != held_.end();)
      if (now - it->second > std::chrono::duration<double>(HOLD_TIMEOUT))
      {
        runner_.release(scene, it->first);
        it = held_.erase(it);
      }
      else
        ++it;
  }
  // nothing non-finite reaches a marker (the node's publish() says why it skipped the state)
  if (snap.serial == snapshot_serial_ || !isFinite(snap.state))
    return;
  snapshot_serial_ = snap.serial;
  const Points& p = snap.state.positions;
  const int n = static_cast<int>(p.cols());
  if (!snap.parameters.interactive)
  {
    if (shown_ > 0)
    {
      shown_ = 0;
      server_.clear();
      server_.applyChanges();
      runner_.release(0, -1);
      std::lock_guard<std::mutex> lock(held_mutex_);
      held_.clear();
    }
    return;
  }
  const int count = markerCount(n, snap.parameters.tf_frames);
  if (snap.scene_serial != scene || count != shown_ || n != particles_)
  {
    // a new scene, or another count: markers made anew, and whatever was held let go (rviz
    // loses the marker it held, so no MOUSE_UP would come)
    shown_ = 0;
    marker_scene_ = snap.scene_serial;
    runner_.release(0, -1);
    {
      std::lock_guard<std::mutex> lock(held_mutex_);
      held_.clear();
    }
    server_.clear();
    const double size = particleSize(*snap.model);
    for (int i = 0; i < count; ++i)
    {
      InteractiveMarker marker;
      marker.header.frame_id = fixed_frame_;  // stamp 0: rviz draws it at the latest frame
      marker.name = std::to_string(i);
      marker.pose = poseAt(p, i);
      marker.scale = static_cast<float>(2.0 * size);
      InteractiveMarkerControl control;
      control.name = "drag";
      // drag in the plane facing the camera, the way a mouse moves
      control.interaction_mode = InteractiveMarkerControl::MOVE_3D;
      control.always_visible = true;
      visualization_msgs::Marker handle;
      handle.type = visualization_msgs::Marker::SPHERE;
      handle.scale.x = handle.scale.y = handle.scale.z = 1.3 * size;
      handle.color.r = 1.0f;
      handle.color.g = 1.0f;
      handle.color.b = 0.3f;
      handle.color.a = 0.35f;
      handle.pose.orientation.w = 1.0;
      control.markers.push_back(handle);
      marker.controls.push_back(control);
      server_.insert(marker, [this](const InteractiveMarkerFeedback::ConstPtr& f) { feedback(f); });
    }
    particles_ = n;
    server_.applyChanges();
    shown_ = count;
    return;
  }
  std::map<int, std::chrono::steady_clock::time_point> held;
  {
    std::lock_guard<std::mutex> lock(held_mutex_);
    held = held_;
  }
  for (int i = 0; i < count; ++i)
    if (held.count(i) == 0)
      server_.setPose(std::to_string(i), poseAt(p, i));
  server_.applyChanges();
}

void GrabMarkers::feedback(const InteractiveMarkerFeedback::ConstPtr& f)
{
  const int particle = particleOf(f->marker_name);
  if (particle < 0 || particle >= shown_)
    return;
  const std::uint64_t scene = marker_scene_;
  if (f->event_type == InteractiveMarkerFeedback::MOUSE_UP)
  {
    {
      std::lock_guard<std::mutex> lock(held_mutex_);
      held_.erase(particle);
    }
    runner_.release(scene, particle);
    return;
  }
  if (f->event_type == InteractiveMarkerFeedback::KEEP_ALIVE)
  {
    // still held: the pull goes on
    std::lock_guard<std::mutex> lock(held_mutex_);
    if (auto it = held_.find(particle); it != held_.end())
      it->second = std::chrono::steady_clock::now();
    return;
  }
  if (f->event_type != InteractiveMarkerFeedback::MOUSE_DOWN &&
      f->event_type != InteractiveMarkerFeedback::POSE_UPDATE)
    return;
  if (!f->header.frame_id.empty() && f->header.frame_id != fixed_frame_)
  {
    ROS_WARN_THROTTLE(5.0, "~grab: feedback in frame '%s' ignored; markers are in '%s'",
                      f->header.frame_id.c_str(), fixed_frame_.c_str());
    return;
  }
  const Vec3 target(f->pose.position.x, f->pose.position.y, f->pose.position.z);
  if (!target.allFinite())
    return;
  {
    std::lock_guard<std::mutex> lock(held_mutex_);
    held_[particle] = std::chrono::steady_clock::now();
  }
  runner_.drag(scene, particle, target);
}

}  // namespace constrained_particles
