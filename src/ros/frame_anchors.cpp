/// @file frame_anchors.cpp
/// @brief FrameAnchors: holder poses from tf and PoseStamped topics to the runner.
#include "constrained_particles/ros/frame_anchors.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <cmath>
#include <utility>

namespace constrained_particles
{
namespace
{
constexpr std::int64_t SAMPLE_PERIOD_NS = 10000000;  // FrameAnchors::SAMPLE_PERIOD
constexpr std::int64_t MAX_BACKLOG_NS = 1000000000;  // a holder found late: from 1 s back at most
}  // namespace

FrameAnchors::FrameAnchors(ros::NodeHandle node, SimulationRunner& runner, std::string fixed_frame,
                           std::string frame_prefix)
  : node_(std::move(node))
  , runner_(runner)
  , fixed_frame_(std::move(fixed_frame))
  , frame_prefix_(std::move(frame_prefix))
  , buffer_(ros::Duration(10.0))
  , spinner_(1, &queue_)
{
  static_assert(SAMPLE_PERIOD == 0.01, "SAMPLE_PERIOD_NS is SAMPLE_PERIOD in ns");
  node_.setCallbackQueue(&queue_);
  timer_ = node_.createWallTimer(ros::WallDuration(SAMPLE_PERIOD), &FrameAnchors::sample, this);
  spinner_.start();
}

void FrameAnchors::listen()
{
  std::lock_guard<std::mutex> lock(listener_mutex_);
  if (!listener_)
    listener_ = std::make_unique<tf2_ros::TransformListener>(buffer_);
}

void FrameAnchors::update(const Snapshot& snap)
{
  std::vector<Holder> old;  // destroyed after the lock: a subscriber's end waits for its callback
  std::lock_guard<std::mutex> lock(mutex_);
  if (snap.tracks_serial == serial_)
    return;
  serial_ = snap.tracks_serial;
  old.swap(holders_);
  const Model& model = *snap.model;
  for (std::size_t k = 0; k < model.tracked().size(); ++k)
  {
    const auto* anchor =
        std::get_if<FrameAnchorConstraint>(&model.scene().constraints[model.tracked()[k]]);
    if (!anchor)
      continue;
    Holder holder;
    holder.track = static_cast<int>(k);
    holder.particle = anchor->particle;
    holder.frame = anchor->frame;
    holder.topic = anchor->topic;
    holder.offset = anchor->offset;
    holders_.push_back(std::move(holder));
  }
  // subscriptions last: their callbacks take the lock and find the holders in place
  for (Holder& holder : holders_)
  {
    if (!holder.frame.empty() && holder.frame.rfind(frame_prefix_, 0) == 0)
      holder.refused = "frame '" + holder.frame + "' is one of this node's particle frames " +
                       "(~frame_prefix '" + frame_prefix_ + "'): it would follow itself";
    std::string error;
    if (!holder.topic.empty() && !ros::names::validate(holder.topic, error))
      holder.refused = "topic '" + holder.topic + "' is not a valid ROS name (" + error + ")";
    if (!holder.refused.empty())
    {
      ROS_WARN("simulator: frame_anchor on particle %d: %s: the particle is held where it is",
               holder.particle, holder.refused.c_str());
      continue;
    }
    listen();  // a frame, or a pose in another frame, is resolved through tf
    if (!holder.topic.empty())
    {
      const int track = holder.track;
      holder.subscriber = node_.subscribe<geometry_msgs::PoseStamped>(
          holder.topic, 100,
          [this, track](const geometry_msgs::PoseStamped::ConstPtr& msg)
          { poseCallback(track, msg); });
    }
  }
}

HolderSample FrameAnchors::toSample(const geometry_msgs::Transform& transform, const Vec3& offset,
                                    std::int64_t stamp_ns)
{
  // tf2_eigen does the message-to-Eigen conversion of the frame's pose
  return toSample(tf2::transformToEigen(transform), offset, stamp_ns);
}

HolderSample FrameAnchors::toSample(const Eigen::Isometry3d& pose, const Vec3& offset,
                                    std::int64_t stamp_ns)
{
  HolderSample sample;
  sample.stamp_ns = stamp_ns;
  sample.position = pose * offset;
  sample.orientation = Eigen::Quaterniond(pose.rotation());
  return sample;
}

void FrameAnchors::sample(const ros::WallTimerEvent&)
{
  std::lock_guard<std::mutex> lock(mutex_);
  for (Holder& holder : holders_)
  {
    if (!holder.frame.empty() && holder.refused.empty())
      sampleFrame(holder);
    // poses tf could not resolve at their stamp yet: again, the oldest given up after 1 s
    std::vector<geometry_msgs::PoseStamped> pending;
    pending.swap(holder.pending);
    const ros::Time now = ros::Time::now();
    for (const geometry_msgs::PoseStamped& pose : pending)
      if (!takePose(holder, pose, std::abs((now - pose.header.stamp).toSec()) > 1.0))
        holder.pending.push_back(pose);
  }
}

void FrameAnchors::sampleFrame(Holder& holder)
{
  geometry_msgs::TransformStamped newest;
  try
  {
    // time 0: the newest transform tf can give, stamped with its time (0: a static chain)
    newest = buffer_.lookupTransform(fixed_frame_, holder.frame, ros::Time(0));
  }
  catch (const std::exception& e)  // tf2::TransformException, or tf2's range errors
  {
    holder.found = false;
    holder.missing = e.what();
    if (!holder.warned)
      ROS_WARN(
          "simulator: frame_anchor on particle %d: frame '%s' is not in tf (%s): the "
          "particle is held where it is until the frame appears",
          holder.particle, holder.frame.c_str(), e.what());
    holder.warned = true;
    return;
  }
  if (!holder.found && holder.warned)
    ROS_INFO("simulator: frame_anchor on particle %d: frame '%s' has appeared: following it",
             holder.particle, holder.frame.c_str());
  holder.found = true;
  holder.missing.clear();
  const bool fixed = newest.header.stamp.isZero();
  const std::int64_t newest_ns = fixed ? static_cast<std::int64_t>(ros::Time::now().toNSec())
                                       : static_cast<std::int64_t>(newest.header.stamp.toNSec());
  if (newest_ns <= 0)
    return;  // a static frame under /use_sim_time before the first /clock: no time to put it at
  // a first look, a long gap, or a clock that went back (a bag played again): from the newest
  if (holder.next_ns < 0 || holder.next_ns < newest_ns - MAX_BACKLOG_NS ||
      newest_ns < holder.next_ns - 2 * SAMPLE_PERIOD_NS)
    holder.next_ns = newest_ns / SAMPLE_PERIOD_NS * SAMPLE_PERIOD_NS;
  std::vector<HolderSample> samples;
  // grid stamps half an interval short of the newest at most: a frame that stops then gets its
  // last pose as a sample of its own (below), never closer than that to a grid sample
  for (; holder.next_ns <= newest_ns - (fixed ? 0 : SAMPLE_PERIOD_NS / 2);
       holder.next_ns += SAMPLE_PERIOD_NS)
  {
    geometry_msgs::TransformStamped at = newest;
    if (!fixed)
    {
      try
      {
        ros::Time stamp;
        stamp.fromNSec(static_cast<std::uint64_t>(holder.next_ns));
        at = buffer_.lookupTransform(fixed_frame_, holder.frame, stamp);
      }
      catch (const std::exception&)  // tf2::TransformException, or tf2's range errors
      {
        break;  // not inside what tf holds (yet): the next tick tries again
      }
    }
    const HolderSample sample = toSample(at.transform, holder.offset, holder.next_ns);
    if (!sample.position.allFinite() || !sample.orientation.coeffs().allFinite())
    {
      ++holder.non_finite;
      continue;
    }
    samples.push_back(sample);
  }
  // the newest pose itself (a broadcast), where it is half an interval past the last sample:
  // a frame that stops then rests exactly at its last pose, never between it and a grid point
  if (!fixed && (samples.empty() ? holder.posted_ns : samples.back().stamp_ns) <=
                    newest_ns - SAMPLE_PERIOD_NS / 2)
  {
    const HolderSample last = toSample(newest.transform, holder.offset, newest_ns);
    if (last.position.allFinite() && last.orientation.coeffs().allFinite())
    {
      samples.push_back(last);
      const std::int64_t after = newest_ns + SAMPLE_PERIOD_NS / 2;
      holder.next_ns = (after + SAMPLE_PERIOD_NS - 1) / SAMPLE_PERIOD_NS * SAMPLE_PERIOD_NS;
    }
  }
  if (!samples.empty())
  {
    holder.posted_ns = samples.back().stamp_ns;
    runner_.postHolderSamples(serial_, holder.track, std::move(samples));
  }
}

void FrameAnchors::poseCallback(int track, const geometry_msgs::PoseStamped::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  for (Holder& holder : holders_)
    if (holder.track == track && !holder.topic.empty())
    {
      geometry_msgs::PoseStamped pose = *msg;
      if (pose.header.stamp.isZero())
        pose.header.stamp = ros::Time::now();  // no stamp: it stands for its arrival
      if (takePose(holder, pose, false))
        continue;
      if (holder.pending.size() < 100)
        holder.pending.push_back(pose);
      else
        ++holder.untransformable;  // tf far behind: the oldest waiting are enough
    }
}

bool FrameAnchors::takePose(Holder& holder, const geometry_msgs::PoseStamped& msg, bool last_try)
{
  geometry_msgs::Transform pose;
  pose.translation.x = msg.pose.position.x;
  pose.translation.y = msg.pose.position.y;
  pose.translation.z = msg.pose.position.z;
  pose.rotation = msg.pose.orientation;
  const Eigen::Quaterniond q(msg.pose.orientation.w, msg.pose.orientation.x, msg.pose.orientation.y,
                             msg.pose.orientation.z);
  if (!q.coeffs().allFinite() || std::abs(q.norm() - 1.0) > 1e-3 ||
      !std::isfinite(pose.translation.x + pose.translation.y + pose.translation.z))
  {
    ++holder.non_finite;  // a NaN or an unnormalised quaternion: dropped and counted
    return true;
  }
  Eigen::Isometry3d in_fixed = tf2::transformToEigen(pose);
  const std::string& frame = msg.header.frame_id;
  if (!frame.empty() && frame != fixed_frame_)
  {
    try
    {
      in_fixed =
          tf2::transformToEigen(buffer_.lookupTransform(fixed_frame_, frame, msg.header.stamp)) *
          in_fixed;
    }
    catch (const tf2::ExtrapolationException& e)
    {
      if (!last_try)
        return false;  // tf has not reached its stamp yet: kept to try again
      ++holder.untransformable;
      holder.missing = e.what();
      return true;
    }
    catch (const std::exception& e)  // tf2 throws std::runtime_error for stamps it cannot hold
    {
      ++holder.untransformable;
      holder.missing = e.what();
      return true;
    }
  }
  holder.missing.clear();
  runner_.postHolderSamples(
      serial_, holder.track,
      { toSample(in_fixed, holder.offset, static_cast<std::int64_t>(msg.header.stamp.toNSec())) });
  return true;
}

bool FrameAnchors::report(const Snapshot& snap,
                          const std::function<void(const std::string&, const std::string&)>& add,
                          std::string& warning)
{
  std::lock_guard<std::mutex> lock(mutex_);
  bool warn = false;
  for (Holder& holder : holders_)
  {
    const std::string name =
        "frame_anchor " + std::to_string(holder.particle) + " (" +
        (holder.frame.empty() ? "topic " + holder.topic : "frame " + holder.frame) + ")";
    const bool counted =
        snap.tracks_serial == serial_ && holder.track < static_cast<int>(snap.holders.size());
    std::string value;
    if (!holder.refused.empty())
      value = "not followed: " + holder.refused;
    else if (!holder.missing.empty())
      value = "not followed: " + holder.missing;
    else if (counted && snap.holders[holder.track].last_stamp < 0.0)
      value = "waiting for its first pose: the particle rests where it is";
    else if (const double silent =
                 counted ? ros::Time::now().toSec() - snap.holders[holder.track].last_stamp : 0.0;
             silent > STALE_AFTER + snap.anchor_lag)
      value = "its newest pose is stamped " + formatValue(std::round(silent * 10.0) / 10.0) +
              " s ago (its publisher stopped, or stamps on another clock?): the particle rests "
              "at the last";
    if (!value.empty())
    {
      warning += (warning.empty() ? "" : "; ") + name + " " + value;
      warn = true;
    }
    else
      value = "following";
    if (counted)
    {
      const HolderStatus& s = snap.holders[holder.track];
      value += "; samples taken " + std::to_string(s.taken) + ", late " + std::to_string(s.late) +
               " (raise ~anchor_lag if these grow), out of order " + std::to_string(s.unordered) +
               ", ahead of the clock " + std::to_string(s.future) + ", out of range " +
               std::to_string(s.out_of_range) + ", teleports " + std::to_string(s.jumps) +
               (s.jumps > 0 ? " (last " + formatValue(s.last_jump) + " m)" : std::string()) +
               ", teleports refused " + std::to_string(s.refused);
      if (s.future > holder.logged_future)
      {
        warning += (warning.empty() ? "" : "; ") + name + ": " +
                   std::to_string(s.future - holder.logged_future) +
                   " samples stamped over 5 s ahead of the simulation's clock (is the holder on "
                   "another clock?)";
        warn = true;
      }
      holder.logged_future = s.future;
      // samples dropped since the last report, for any reason: a WARN while they keep coming
      const std::uint64_t dropped =
          s.late + s.out_of_range + holder.non_finite + holder.untransformable;
      if (dropped > holder.logged_dropped)
      {
        warning += (warning.empty() ? "" : "; ") + name + ": " +
                   std::to_string(dropped - holder.logged_dropped) +
                   " samples dropped in the last second (late, out of range, non-finite or "
                   "untransformable: see its counts)";
        warn = true;
      }
      holder.logged_dropped = dropped;
      if (s.refused > holder.logged_refused)
      {
        ROS_WARN(
            "simulator: frame_anchor on particle %d: the scene cannot follow its holder's "
            "teleport (%s): the particle rests where it is",
            holder.particle, s.last_refusal.c_str());
        warning += (warning.empty() ? "" : "; ") + name + ": a teleport it cannot follow";
        warn = true;
      }
      holder.logged_refused = s.refused;
      if (s.jumps > holder.logged_jumps)
        ROS_WARN(
            "simulator: frame_anchor on particle %d: its holder '%s' jumped %s m between two "
            "samples (more than ~anchor_max_jump): the scene was projected onto its new pose, "
            "like ~set_state, instead of following it",
            holder.particle, (holder.frame.empty() ? holder.topic : holder.frame).c_str(),
            formatValue(s.last_jump).c_str());
      holder.logged_jumps = s.jumps;
    }
    value += ", non-finite " + std::to_string(holder.non_finite) + ", untransformable " +
             std::to_string(holder.untransformable);
    add(name, value);
  }
  return warn;
}

}  // namespace constrained_particles
