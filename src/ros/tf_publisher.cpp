/// @file tf_publisher.cpp
/// @brief TfPublisher: the particle frames on /tf.
#include "constrained_particles/ros/tf_publisher.hpp"

#include <utility>

namespace constrained_particles
{
TfPublisher::TfPublisher(ros::NodeHandle node, std::string fixed_frame, std::string frame_prefix,
                         bool sim_time_stamps)
  : fixed_frame_(std::move(fixed_frame))
  , frame_prefix_(std::move(frame_prefix))
  , sim_time_stamps_(sim_time_stamps)
{
  publisher_ = node.advertise<tf2_msgs::TFMessage>(
      "/tf", 100,
      ros::SubscriberStatusCallback(
          [this](const ros::SingleSubscriberPublisher& subscriber)
          {
            // under sim time nothing is re-sent while time stands still: a listener joining
            // then gets the last frames once, to itself only, and only if nothing was broadcast
            // lately (a broadcast since its link came up would repeat a stamp)
            std::lock_guard<std::mutex> lock(mutex_);
            if (sim_time_stamps_ && sent_ &&
                std::chrono::steady_clock::now() - last_sent_ > std::chrono::milliseconds(500))
              subscriber.publish(message_);
          }));
}

void TfPublisher::prepare(const Snapshot& snap)
{
  const int n = static_cast<int>(snap.state.positions.cols());
  const int frames = tfFrameCount(n, snap.parameters.tf_frames);
  if (scene_serial_ == snap.scene_serial &&
      message_.transforms.size() == static_cast<std::size_t>(frames))
    return;
  message_.transforms.resize(frames);
  for (int i = 0; i < frames; ++i)
  {
    geometry_msgs::TransformStamped& t = message_.transforms[i];
    t.header.frame_id = fixed_frame_;
    t.child_frame_id = frame_prefix_ + std::to_string(i);
    t.transform.rotation.w = 1.0;
  }
  scene_serial_ = snap.scene_serial;
  if (snap.parameters.tf_frames < 0 && frames < n && warned_scene_serial_ != snap.scene_serial)
  {
    warned_scene_serial_ = snap.scene_serial;
    ROS_WARN(
        "simulator: scene '%s' has %d particles; /tf carries the first %d (~tf_frames -1 "
        "caps at %d); ~particles carries them all; set ~tf_frames to N for the first N",
        snap.scene->name.c_str(), n, frames, limits::DEFAULT_TF_FRAMES);
  }
}

void TfPublisher::publish(const Snapshot& snap, const ros::Time& stamp)
{
  std::lock_guard<std::mutex> lock(mutex_);
  prepare(snap);
  const int frames = static_cast<int>(message_.transforms.size());
  if (frames == 0 || (publisher_.getNumSubscribers() == 0 && !sim_time_stamps_))
    return;
  for (int i = 0; i < frames; ++i)
  {
    geometry_msgs::TransformStamped& t = message_.transforms[i];
    t.header.stamp = stamp;
    t.transform.translation.x = snap.state.positions(0, i);
    t.transform.translation.y = snap.state.positions(1, i);
    t.transform.translation.z = snap.state.positions(2, i);
  }
  publisher_.publish(message_);
  sent_ = true;
  last_sent_ = std::chrono::steady_clock::now();
}

}  // namespace constrained_particles
