/// @file anchor_follower.hpp
/// @brief Holder poses from other threads (the node's tf sampler, pose topics) onto the
/// simulator's anchor tracks: the stamp-to-sim-time mapping, the lag, teleports and counts.
/// Needs no ROS master.
#pragma once

#include "constrained_particles/core/simulator.hpp"

#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace constrained_particles
{
/// One pose of a holder as it arrived, stamped on the node's ROS clock.
struct HolderSample
{
  std::int64_t stamp_ns = 0;     ///< its stamp [ns] on the node's clock (ROS time)
  Vec3 position = Vec3::Zero();  ///< the held point (holder origin plus offset), fixed frame [m]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< the holder's frame
};

/// What became of one holder's samples since its model was set (AnchorFollower::status()).
struct HolderStatus
{
  int particle = 0;             ///< the particle it holds
  std::string holder;           ///< its tf frame, or its topic
  std::uint64_t taken = 0;      ///< samples that became knots of its track
  std::uint64_t late = 0;       ///< arrived after their time (stamp + lag) had passed: ignored
  std::uint64_t unordered = 0;  ///< not after the last knot (repeated, or out of order): ignored
  std::uint64_t jumps = 0;      ///< teleports: farther than ~anchor_max_jump from the last knot
  std::uint64_t future = 0;     ///< stamped over FUTURE_LIMIT ahead of the scene's clock: ignored
  std::uint64_t out_of_range = 0;  ///< a position outside limits::COORDINATE: ignored
  std::uint64_t refused = 0;       ///< teleports the scene could not be projected onto
  std::string last_refusal;        ///< why the last one could not
  double last_jump = 0.0;          ///< the last teleport's distance [m]
  double last_stamp = -1.0;        ///< the newest sample's stamp [s] (-1: none yet)
};

/// Takes holder samples from any thread and appends them, on the physics thread, to the
/// simulator's tracks (Simulator::tracks()): a sample stamped s is the held point at sim time
/// simTime(s + lag), so samples arrive before the steps reach them and the spline between them
/// (AnchorTrack) is known where it is used.
class AnchorFollower
{
public:
  /// A sample whose time is this far [s] past the scene's time plus the lag is not of its clock
  /// (a holder on another clock, a wrong stamp): ignored and counted, never a frozen holder.
  static constexpr double FUTURE_LIMIT = 5.0;
  /// Knots closer than this [s] are not taken (half FrameAnchors' 10 ms grid): the spline's
  /// acceleration grows as 1/h^2 of its intervals, and a knot this close adds nothing.
  static constexpr double MIN_SPACING = 0.005;
  /// Thread-safe, not waited for: samples of the holder with track index `track`
  /// (Model::tracked() order) of the model with serial `serial` (Snapshot::tracks_serial);
  /// samples for another model are dropped.
  void post(std::uint64_t serial, int track, std::vector<HolderSample> samples);
  /// Physics thread: a new model (a scene change, an attachment, a detachment) with serial
  /// `serial`; counts start again and posts for other serials are dropped.
  void setModel(std::uint64_t serial, const Model& model);
  /// Physics thread: drops what was posted (while paused or faulted nothing is followed).
  void discard();
  /// Physics thread: appends what was posted to `simulator`'s tracks, sample s at sim time
  /// `sim_time_of(s.stamp_ns + lag_ns)` (NaN: no mapping yet, dropped), at least `lead` [s]
  /// after the scene's time. A sample farther than `max_jump` [m] from the last knot (or the
  /// rest point) restarts its track there: the jumps are returned, track and summed displacement
  /// [m], for the caller to carry the scene along and project it (like ~set_state).
  std::vector<std::pair<int, Vec3>> apply(Simulator& simulator,
                                          const std::function<double(std::int64_t)>& sim_time_of,
                                          std::int64_t lag_ns, double max_jump, double lead);
  /// Physics thread: the teleport of holder `track` could not be projected (`why`): counted.
  void refuseTeleport(int track, const std::string& why);
  /// Each holder's counts, in track order.
  const std::vector<HolderStatus>& status() const
  {
    return status_;
  }

private:
  struct Post
  {
    std::uint64_t serial;
    int track;
    std::vector<HolderSample> samples;
  };
  std::mutex mutex_;  // guards inbox_ and serial_
  std::vector<Post> inbox_;
  std::uint64_t serial_ = 0;
  std::vector<HolderStatus> status_;  // physics thread
};

}  // namespace constrained_particles
