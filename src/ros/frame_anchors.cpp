/// @file frame_anchors.cpp
/// @brief FrameAnchors: holder poses from tf broadcasts and PoseStamped topics to the runner.
#include "constrained_particles/ros/frame_anchors.hpp"

#include <ros/names.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>
#include <utility>

namespace constrained_particles
{
namespace
{
constexpr std::int64_t GIVE_UP_NS = 1000000000;  // a stamp tf cannot resolve for 1 s: dropped
constexpr std::size_t HISTORY_LIMIT = 2048;      // broadcasts kept per frame at most

std::string stripped(const std::string& frame)
{
  return !frame.empty() && frame.front() == '/' ? frame.substr(1) : frame;
}
}  // namespace

std::string holderRefusal(const std::string& frame, const std::string& topic,
                          const std::string& frame_prefix)
{
  if (!frame.empty() && frame.rfind(frame_prefix, 0) == 0)
    return "is one of this node's particle frames (~frame_prefix '" + frame_prefix +
           "'): it would follow itself";
  std::string error;
  if (!topic.empty() && !ros::names::validate(topic, error))
    return "is not a valid ROS name (" + error + ")";
  return std::string();
}

FrameAnchors::FrameAnchors(ros::NodeHandle node, SimulationRunner& runner, std::string fixed_frame,
                           std::string frame_prefix, std::function<std::int64_t()> clock_ns)
  : node_(std::move(node))
  , runner_(runner)
  , fixed_frame_(std::move(fixed_frame))
  , frame_prefix_(std::move(frame_prefix))
  , clock_ns_(std::move(clock_ns))
  , buffer_(ros::Duration(10.0))
  , spinner_(1, &queue_)
{
  node_.setCallbackQueue(&queue_);
  // started with the first holder: a node without one wakes for nothing
  timer_ = node_.createWallTimer(ros::WallDuration(RETRY_PERIOD), &FrameAnchors::retry, this, false,
                                 false);
  spinner_.start();
}

FrameAnchors::~FrameAnchors()
{
  spinner_.stop();  // no callback runs while the members go
}

void FrameAnchors::listen()
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (tf_subscriber_)
    return;
  // tf2_ros::TransformListener's own subscriptions, whose callbacks also note each stamp
  ros::NodeHandle root;
  root.setCallbackQueue(&queue_);
  tf_subscriber_ = root.subscribe<tf2_msgs::TFMessage>(
      "/tf", 100,
      [this](const ros::MessageEvent<tf2_msgs::TFMessage const>& event)
      { tfCallback(event, false); },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  tf_static_subscriber_ = root.subscribe<tf2_msgs::TFMessage>(
      "/tf_static", 100,
      [this](const ros::MessageEvent<tf2_msgs::TFMessage const>& event)
      { tfCallback(event, true); });
}

void FrameAnchors::tfCallback(const ros::MessageEvent<tf2_msgs::TFMessage const>& event,
                              bool is_static)
{
  const ros::Time now = ros::Time::now();
  std::lock_guard<std::mutex> lock(mutex_);
  if (now < last_update_)
  {
    // as tf2_ros's listener does: a clock that went back (a bag played again) clears tf
    ROS_WARN("simulator: ROS time went back by %.3f s: tf cleared, holders sampled anew",
             (last_update_ - now).toSec());
    buffer_.clear();
    restartSampling();
  }
  last_update_ = now;
  // arrival on the node's stamp clock: what a holder's latency is measured against
  const std::int64_t arrival = clock_ns_();
  const tf2_msgs::TFMessage& message = *event.getConstMessage();
  const std::string authority = event.getPublisherName();
  std::vector<std::pair<std::string, std::int64_t>> broadcasts;
  for (const geometry_msgs::TransformStamped& transform : message.transforms)
  {
    try
    {
      buffer_.setTransform(transform, authority, is_static);
    }
    catch (const tf2::TransformException& e)
    {
      ROS_ERROR("simulator: tf refused the transform from %s to %s: %s",
                transform.child_frame_id.c_str(), transform.header.frame_id.c_str(), e.what());
      continue;
    }
    const std::string child = stripped(transform.child_frame_id);
    parent_[child] = stripped(transform.header.frame_id);
    const auto stamp = static_cast<std::int64_t>(transform.header.stamp.toNSec());
    if (is_static || stamp <= 0)
      continue;
    std::deque<Broadcast>& history = history_[child];
    history.push_back(Broadcast{ stamp, arrival });
    while (!history.empty() && (history.front().stamp_ns < stamp - std::llround(HISTORY * 1e9) ||
                                history.size() > HISTORY_LIMIT))
      history.pop_front();
    broadcasts.emplace_back(child, stamp);
  }
  for (Holder& holder : holders_)
  {
    if (holder.frame.empty() || !holder.refused.empty())
      continue;
    const std::set<std::string> chain = chainOf(holder.frame);
    bool moved = false;
    for (const auto& [child, stamp] : broadcasts)
      if (chain.count(child) > 0)
      {
        moved = true;
        if (stamp > std::max(holder.s.posted_ns, holder.since_ns))
          holder.s.waiting.emplace(stamp, arrival);
      }
    if (moved)
      holder.s.newest_arrival_ns = arrival;
    if (is_static)
      lookFor(holder, arrival);  // a static chain may be complete now
    sampleWaiting(holder, arrival);
  }
}

std::set<std::string> FrameAnchors::chainOf(const std::string& frame) const
{
  // each frame's ancestors; those of both are above the path between them
  auto ancestors = [this](std::string f)
  {
    std::vector<std::string> up{ f };
    for (int depth = 0; depth < 64; ++depth)
    {
      const auto parent = parent_.find(f);
      if (parent == parent_.end())
        break;
      f = parent->second;
      up.push_back(f);
    }
    return up;
  };
  const std::vector<std::string> from = ancestors(frame), to = ancestors(fixed_frame_);
  const std::set<std::string> above(to.begin(), to.end());
  std::set<std::string> chain;
  // a frame moves the holder in the fixed frame if its transform to its parent is on the path
  for (const std::string& f : from)
  {
    if (above.count(f) > 0)
      break;
    chain.insert(f);
  }
  const std::set<std::string> below(from.begin(), from.end());
  for (const std::string& f : to)
  {
    if (below.count(f) > 0)
      break;
    chain.insert(f);
  }
  return chain;
}

void FrameAnchors::sampleWaiting(Holder& holder, std::int64_t now_ns)
{
  std::vector<HolderSample> samples;
  for (auto it = holder.s.waiting.begin(); it != holder.s.waiting.end();)
  {
    const std::int64_t stamp = it->first, arrival = it->second;
    if (stamp <= holder.s.posted_ns)
    {
      it = holder.s.waiting.erase(it);
      continue;
    }
    geometry_msgs::TransformStamped at;
    try
    {
      ros::Time time;
      time.fromNSec(static_cast<std::uint64_t>(stamp));
      at = buffer_.lookupTransform(fixed_frame_, holder.frame, time);
    }
    catch (const tf2::ExtrapolationException&)
    {
      // a parent not broadcast that far yet: this and later stamps wait, a second at most
      if (now_ns - arrival > GIVE_UP_NS)
      {
        ++holder.s.untransformable;
        it = holder.s.waiting.erase(it);
        continue;
      }
      break;
    }
    catch (const std::exception& e)  // tf2::TransformException, or tf2's range errors
    {
      ++holder.s.untransformable;
      holder.missing = e.what();
      it = holder.s.waiting.erase(it);
      continue;
    }
    it = holder.s.waiting.erase(it);
    // tf2_eigen does the message-to-Eigen conversion of the frame's pose; it could be used from
    // now, when tf could resolve it (its parents' broadcasts may have come later than it)
    const HolderSample sample = toSample(tf2::transformToEigen(at.transform), holder.offset, stamp,
                                         std::max(arrival, now_ns));
    if (!sample.position.allFinite() || !sample.orientation.coeffs().allFinite())
    {
      ++holder.s.non_finite;
      continue;
    }
    samples.push_back(sample);
    holder.s.posted_ns = stamp;
  }
  if (!samples.empty())
    runner_.postHolderSamples(serial_, holder.track, std::move(samples));
}

void FrameAnchors::lookFor(Holder& holder, std::int64_t now_ns)
{
  geometry_msgs::TransformStamped newest;
  try
  {
    // time 0: the newest transform tf can give, stamped with its time (0: a static chain)
    newest = buffer_.lookupTransform(fixed_frame_, holder.frame, ros::Time(0));
  }
  catch (const std::exception& e)  // tf2::TransformException, or tf2's range errors
  {
    holder.s.found = false;
    holder.missing = e.what();
    if (!holder.s.warned)
      ROS_WARN(
          "simulator: %s: frame '%s' is not in tf (%s): %s is held where it is until the "
          "frame appears",
          holder.label.c_str(), holder.frame.c_str(), e.what(), holder.moved.c_str());
    holder.s.warned = true;
    return;
  }
  if (!holder.s.found && holder.s.warned)
    ROS_INFO("simulator: %s: frame '%s' has appeared: following it", holder.label.c_str(),
             holder.frame.c_str());
  holder.s.found = true;
  holder.missing.clear();
  if (!newest.header.stamp.isZero())
  {
    holder.s.still = false;
    return;
  }
  // a chain all on /tf_static: its one pose, now, is its whole path; posted again each second,
  // so a holder kept across an attach, a detach or a clock gone back has one in its new track
  if (now_ns <= 0)
    return;  // under /use_sim_time before the first /clock: no time to put it at
  if (holder.s.still && holder.s.still_posted_ns >= 0 && now_ns >= holder.s.still_posted_ns &&
      now_ns - holder.s.still_posted_ns < GIVE_UP_NS)
    return;
  holder.s.still = true;
  holder.s.still_posted_ns = now_ns;
  HolderSample sample =
      toSample(tf2::transformToEigen(newest.transform), holder.offset, now_ns, now_ns);
  sample.still = true;
  if (sample.position.allFinite() && sample.orientation.coeffs().allFinite())
    runner_.postHolderSamples(serial_, holder.track, { sample });
}

void FrameAnchors::retry(const ros::WallTimerEvent&)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const std::int64_t now_ns = clock_ns_();
  for (Holder& holder : holders_)
  {
    if (!holder.frame.empty() && holder.refused.empty())
    {
      lookFor(holder, now_ns);
      sampleWaiting(holder, now_ns);
    }
    // poses tf could not resolve at their stamp yet: again, the oldest given up after 1 s
    std::vector<geometry_msgs::PoseStamped> pending;
    pending.swap(holder.pending);
    for (const geometry_msgs::PoseStamped& pose : pending)
      if (!takePose(holder, pose,
                    now_ns - static_cast<std::int64_t>(pose.header.stamp.toNSec()) > GIVE_UP_NS))
        holder.pending.push_back(pose);
  }
}

void FrameAnchors::restartSampling()
{
  history_.clear();
  for (Holder& holder : holders_)
  {
    holder.s.waiting.clear();
    holder.s.posted_ns = -1;
    holder.since_ns = -1;
    holder.s.still = false;
    holder.s.still_posted_ns = -1;
    holder.pending.clear();
  }
}

void FrameAnchors::update(const Snapshot& snap)
{
  std::vector<Holder> old;  // destroyed after the lock: a subscriber's end waits for its callback
  bool any = false;
  {
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
      holder.name = holderOf(*anchor);
      holder.label = "frame_anchor on particle " + std::to_string(anchor->particle);
      holder.moved = "the particle";
      holder.offset = anchor->offset;
      if (k < snap.holders.size())
        holder.since_ns = snap.holders[k].since_ns;
      // a holder the runner kept (another was attached or let go): its sampling goes on
      for (Holder& was : old)
        if (was.particle == holder.particle && was.frame == holder.frame &&
            was.topic == holder.topic && was.offset == holder.offset && k < snap.holders.size() &&
            snap.holders[k].taken > 0)
        {
          holder.s = std::move(was.s);
        }
      // an attachment's frame: its broadcasts since the state it took hold at
      if (holder.since_ns >= 0 && holder.s.posted_ns < 0 && !holder.frame.empty())
        for (const std::string& frame : chainOf(holder.frame))
          if (const auto history = history_.find(frame); history != history_.end())
            for (const Broadcast& b : history->second)
              if (b.stamp_ns > holder.since_ns)
                holder.s.waiting.emplace(b.stamp_ns, b.arrival_ns);
      holders_.push_back(std::move(holder));
    }
    // the carried obstacles' holders, after the anchors' (their samples: the frame's origin)
    for (std::size_t c = 0; c < model.carriers().size(); ++c)
    {
      const Shape& shape = model.carriers()[c];
      Holder holder;
      holder.track = static_cast<int>(model.tracked().size() + c);
      holder.particle = -1;
      holder.frame = shape.frame;
      holder.topic = shape.topic;
      holder.name = holderOf(shape);
      holder.label = "obstacle '" + shape.name + "'";
      holder.moved = "the obstacle";
      const std::size_t k = static_cast<std::size_t>(holder.track);
      for (Holder& was : old)
        if (was.particle < 0 && was.label == holder.label && was.frame == holder.frame &&
            was.topic == holder.topic && k < snap.holders.size() && snap.holders[k].taken > 0)
          holder.s = std::move(was.s);
      holders_.push_back(std::move(holder));
    }
    for (Holder& holder : holders_)
    {
      if (const std::string why = holderRefusal(holder.frame, holder.topic, frame_prefix_);
          !why.empty())
        holder.refused =
            (holder.frame.empty() ? "topic '" + holder.topic : "frame '" + holder.frame) + "' " +
            why;
      if (!holder.refused.empty())
        ROS_WARN("simulator: %s: %s: %s is held where it is", holder.label.c_str(),
                 holder.refused.c_str(), holder.moved.c_str());
      else
        any = true;
    }
    // subscriptions last: their callbacks take the lock and find the holders in place
    for (Holder& holder : holders_)
      if (holder.refused.empty() && !holder.topic.empty())
      {
        const int track = holder.track;
        holder.subscriber = node_.subscribe<geometry_msgs::PoseStamped>(
            holder.topic, 100,
            [this, track](const geometry_msgs::PoseStamped::ConstPtr& msg)
            { poseCallback(track, msg); });
      }
  }
  if (any)
  {
    listen();  // a frame, or a pose in another frame, is resolved through tf
    timer_.start();
  }
  else
    timer_.stop();
}

HolderSample FrameAnchors::toSample(const Eigen::Isometry3d& pose, const Vec3& offset,
                                    std::int64_t stamp_ns, std::int64_t arrival_ns)
{
  HolderSample sample;
  sample.stamp_ns = stamp_ns;
  sample.arrival_ns = arrival_ns;
  sample.position = pose * offset;
  sample.orientation = Eigen::Quaterniond(pose.rotation());
  return sample;
}

void FrameAnchors::poseCallback(int track, const geometry_msgs::PoseStamped::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  for (Holder& holder : holders_)
    if (holder.track == track && !holder.topic.empty())
    {
      geometry_msgs::PoseStamped pose = *msg;
      const std::int64_t arrival = clock_ns_();
      if (pose.header.stamp.isZero())  // no stamp: it stands for its arrival
        pose.header.stamp.fromNSec(static_cast<std::uint64_t>(std::max<std::int64_t>(arrival, 0)));
      holder.s.newest_arrival_ns = arrival;
      if (takePose(holder, pose, false))
        continue;
      if (holder.pending.size() < 100)
        holder.pending.push_back(pose);
      else
        ++holder.s.untransformable;  // tf far behind: the oldest waiting are enough
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
    ++holder.s.non_finite;  // a NaN or an unnormalised quaternion: dropped and counted
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
      ++holder.s.untransformable;
      holder.missing = e.what();
      return true;
    }
    catch (const std::exception& e)  // tf2 throws std::runtime_error for stamps it cannot hold
    {
      ++holder.s.untransformable;
      holder.missing = e.what();
      return true;
    }
  }
  holder.missing.clear();
  runner_.postHolderSamples(
      serial_, holder.track,
      { toSample(in_fixed, holder.offset, static_cast<std::int64_t>(msg.header.stamp.toNSec()),
                 holder.s.newest_arrival_ns) });
  return true;
}

bool FrameAnchors::waitForFrame(const std::string& frame, double timeout)
{
  listen();
  // polled on the wall clock: a sim-time timeout would never end under a stopped /clock
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(timeout));
  for (;;)
  {
    std::string error;
    if (buffer_.canTransform(fixed_frame_, frame, ros::Time(0), &error))
      return true;
    if (std::chrono::steady_clock::now() >= deadline)
      return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

SimulationRunner::PoseLookup FrameAnchors::poseLookup(const std::string& frame)
{
  return [this, frame](std::int64_t stamp_ns) -> std::optional<Eigen::Isometry3d>
  {
    try
    {
      ros::Time time;  // time 0: tf's newest
      if (stamp_ns >= 0)
        time.fromNSec(static_cast<std::uint64_t>(stamp_ns));
      return tf2::transformToEigen(buffer_.lookupTransform(fixed_frame_, frame, time));
    }
    catch (const std::exception&)  // not at that stamp (yet), or never
    {
      return std::nullopt;
    }
  };
}

bool FrameAnchors::report(const Snapshot& snap,
                          const std::function<void(const std::string&, const std::string&)>& add,
                          std::string& warning)
{
  std::lock_guard<std::mutex> lock(mutex_);
  bool warn = false;
  const std::int64_t now_ns = clock_ns_();
  auto say = [&warning, &warn](const std::string& what)
  {
    warning += (warning.empty() ? "" : "; ") + what;
    warn = true;
  };
  for (Holder& holder : holders_)
  {
    const std::string name =
        (holder.particle >= 0 ? "frame_anchor " + std::to_string(holder.particle) : holder.label) +
        " (" + (holder.frame.empty() ? "topic " + holder.topic : "frame " + holder.frame) + ")";
    const std::string& moved = holder.moved;
    const bool counted =
        snap.tracks_serial == serial_ && holder.track < static_cast<int>(snap.holders.size());
    const HolderStatus* s = counted ? &snap.holders[holder.track] : nullptr;
    std::string value;
    if (!holder.refused.empty())
      value = "not followed: " + holder.refused + "; " + moved + " is held where it is";
    else if (!holder.missing.empty())
      value = "not followed: " + holder.missing + "; " + moved + " is held where it is";
    else if (holder.s.newest_arrival_ns < 0 && !holder.s.still)
      value = "waiting for its first pose: " + moved + " rests where it is";
    else if (const double silent = static_cast<double>(now_ns - holder.s.newest_arrival_ns) * 1e-9;
             !holder.s.still && silent > STALE_AFTER)
      value = "its newest pose arrived " + formatValue(std::round(silent * 10.0) / 10.0) +
              " s ago (its publisher stopped?): " + moved + " coasted to rest after the last";
    if (!value.empty())
      say(name + " " + value);
    else
      value = holder.s.still ? "following (a static frame: " + moved + " is held still)"
                             : std::string("following");
    if (snap.faulted)
      value += " (stepping is stopped: its poses are not taken)";
    if (s)
    {
      value += "; latency needed " + formatValue(s->needed_latency) + " s; samples taken " +
               std::to_string(s->taken) + ", late " + std::to_string(s->late) + ", out of order " +
               std::to_string(s->unordered) + ", ahead of the clock " + std::to_string(s->future) +
               ", out of range " + std::to_string(s->out_of_range) + ", teleports " +
               std::to_string(s->jumps) +
               (s->jumps > 0 ? " (last " + formatValue(s->last_jump) + " m)" : std::string()) +
               ", teleports refused " + std::to_string(s->refused) + ", overruns " +
               std::to_string(s->overruns) + ", re-placed after the clock went back " +
               std::to_string(s->replaced);
      if (s->future > holder.s.logged_future)
        say(name + ": " + std::to_string(s->future - holder.s.logged_future) +
            " samples stamped over 5 s ahead of the simulation's clock (is the holder on "
            "another clock?)");
      holder.s.logged_future = s->future;
      // samples dropped since the last report, for any reason: a WARN while they keep coming
      const std::uint64_t dropped =
          s->late + s->out_of_range + holder.s.non_finite + holder.s.untransformable;
      if (dropped > holder.s.logged_dropped)
        say(name + ": " + std::to_string(dropped - holder.s.logged_dropped) +
            " samples dropped in the last second (late, out of range, non-finite or "
            "untransformable: see its counts)");
      holder.s.logged_dropped = dropped;
      if (s->overruns > holder.s.logged_overruns)
        say(name + ": the steps ran past its newest pose " +
            std::to_string(s->overruns - holder.s.logged_overruns) + " times in the last second (" +
            moved +
            " coasted on; the latency grows to cover "
            "its arrivals)");
      holder.s.logged_overruns = s->overruns;
      if (s->refused > holder.s.logged_refused)
      {
        ROS_WARN(
            "simulator: %s: the scene cannot follow its holder's teleport (%s): %s rests "
            "where it is",
            holder.label.c_str(), s->last_refusal.c_str(), moved.c_str());
        say(name + ": a teleport it cannot follow");
      }
      holder.s.logged_refused = s->refused;
      if (s->jumps > holder.s.logged_jumps)
        ROS_WARN(
            "simulator: %s: its holder '%s' jumped %s m between two samples (over "
            "~anchor_max_jump or ~anchor_max_speed): a teleport, %s",
            holder.label.c_str(), holder.name.c_str(), formatValue(s->last_jump).c_str(),
            holder.particle >= 0 ? "the scene carried along with it"
                                 : "the obstacle put there at once (what it meets is "
                                   "projected out)");
      holder.s.logged_jumps = s->jumps;
    }
    value += ", non-finite " + std::to_string(holder.s.non_finite) + ", untransformable " +
             std::to_string(holder.s.untransformable);
    add(name, value);
  }
  if (snap.releases.size() < logged_releases_)
    logged_releases_ = 0;  // a new scene: none let go yet
  for (std::size_t k = 0; k < snap.releases.size(); ++k)
  {
    const Release& r = snap.releases[k];
    const std::string name =
        "hold let go: particle " + std::to_string(r.particle) + " (" + r.holder + ")";
    const std::string value = "at t = " + formatValue(r.time) + " s: " + r.why;
    if (k >= logged_releases_)
      ROS_WARN("simulator: %s %s; the particle is free (~attach it again, or ~reset)", name.c_str(),
               value.c_str());
    say(name + " " + value);
    add(name, value);
  }
  logged_releases_ = snap.releases.size();
  return warn;
}

}  // namespace constrained_particles
