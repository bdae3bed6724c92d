/// @file anchor_follower.cpp
/// @brief AnchorFollower: holder samples onto the simulator's anchor tracks.
#include "constrained_particles/ros/anchor_follower.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace constrained_particles
{
void AnchorFollower::post(std::uint64_t serial, int track, std::vector<HolderSample> samples)
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (serial != serial_ || samples.empty())
    return;
  // bounded: a physics thread that stopped taking them (paused) holds at most this many posts
  if (inbox_.size() >= 10000)
    inbox_.erase(inbox_.begin());
  inbox_.push_back(Post{ serial, track, std::move(samples) });
}

void AnchorFollower::setModel(std::uint64_t serial, const Model& model)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    serial_ = serial;
    inbox_.clear();
  }
  status_.clear();
  for (int k : model.tracked())
  {
    const Constraint& constraint = model.scene().constraints[k];
    HolderStatus status;
    status.particle = eliminatedParticle(constraint);
    if (const auto* anchor = std::get_if<FrameAnchorConstraint>(&constraint))
      status.holder = anchor->frame.empty() ? anchor->topic : anchor->frame;
    status_.push_back(status);
  }
}

void AnchorFollower::refuseTeleport(int track, const std::string& why)
{
  if (track < 0 || track >= static_cast<int>(status_.size()))
    return;
  ++status_[track].refused;
  status_[track].last_refusal = why;
}

void AnchorFollower::discard()
{
  std::lock_guard<std::mutex> lock(mutex_);
  inbox_.clear();
}

std::vector<std::pair<int, Vec3>> AnchorFollower::apply(
    Simulator& simulator, const std::function<double(std::int64_t)>& sim_time_of,
    std::int64_t lag_ns, double max_jump, double lead)
{
  std::vector<Post> posts;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    posts.swap(inbox_);
  }
  std::vector<std::pair<int, Vec3>> jumped;
  std::vector<AnchorTrack>& tracks = simulator.tracks();
  const double now = simulator.state().time;
  for (Post& post : posts)
  {
    if (post.serial != serial_ || post.track < 0 || post.track >= static_cast<int>(tracks.size()))
      continue;
    AnchorTrack& track = tracks[post.track];
    HolderStatus& status = status_[post.track];
    for (const HolderSample& sample : post.samples)
    {
      status.last_stamp = static_cast<double>(sample.stamp_ns) * 1e-9;
      const double time = sim_time_of(sample.stamp_ns + lag_ns);
      if (!std::isfinite(time))
      {
        ++status.late;  // no clock to place it on yet
        continue;
      }
      if (time > now + static_cast<double>(lag_ns) * 1e-9 + FUTURE_LIMIT)
      {
        ++status.future;
        continue;
      }
      if (!(sample.position.cwiseAbs().maxCoeff() <= limits::COORDINATE.high) ||
          !sample.orientation.coeffs().allFinite())
      {
        ++status.out_of_range;
        continue;
      }
      // a teleport: restart at rest there (the caller projects the scene onto it)
      const Vec3 from = track.size() > 0 ? track.last().position : track.hold();
      const double distance = (sample.position - from).norm();
      if (distance > max_jump)
      {
        track.restart(sample.position);
        ++status.jumps;
        status.last_jump = distance;
        // a track that jumps twice in one post: its displacements add
        if (!jumped.empty() && jumped.back().first == post.track)
          jumped.back().second += sample.position - from;
        else
          jumped.emplace_back(post.track, sample.position - from);
        continue;
      }
      AnchorSample knot;
      knot.time = time;
      knot.position = sample.position;
      knot.orientation = sample.orientation;
      switch (track.append(knot, now, std::max(lead, MIN_SPACING), MIN_SPACING))
      {
        case AnchorTrack::Append::Taken:
          ++status.taken;
          break;
        case AnchorTrack::Append::Late:
          ++status.late;
          break;
        case AnchorTrack::Append::Unordered:
          ++status.unordered;
          break;
      }
    }
  }
  for (AnchorTrack& track : tracks)
    track.dropBefore(now);
  return jumped;
}

}  // namespace constrained_particles
