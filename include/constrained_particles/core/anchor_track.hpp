/// @file anchor_track.hpp
/// @brief A held point's path through time, from poses sampled outside the core (a tf frame, a
/// pose topic): what a frame_anchor imposes on its particle (MuJoCo's mocap bodies, whose poses
/// the user writes into mjData between steps).
#pragma once

#include "constrained_particles/core/effects/row_block.hpp"

#include <Eigen/Geometry>

#include <cstddef>
#include <deque>

namespace constrained_particles
{
/// One pose of a holder: where the held point is and how the holder is turned, at a time.
struct AnchorSample
{
  double time = 0.0;             ///< sim time [s]
  Vec3 position = Vec3::Zero();  ///< the held point (frame origin plus its offset) [m], fixed frame
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< the holder's frame
  /// dp/dt at this knot [m/s], set by AnchorTrack (0 until its successor arrives in time)
  Vec3 tangent = Vec3::Zero();
};

/// The held point's motion between knots (sample times): a cubic Hermite spline whose tangents
/// are the central differences of the neighbouring knots (Catmull-Rom on non-uniform times;
/// Fritsch and Carlson 1980, eq. 2), 0 at the first and last knot. Position and velocity are
/// continuous (C1), the acceleration piecewise linear; the spline passes through every knot
/// exactly. Before the first knot and after the last the point rests there, so a holder that
/// stops (its broadcaster dies) brings the point to rest smoothly; with no knot at all it rests
/// at hold(). An append never changes the motion from `now` on: a knot's tangent becomes the
/// central difference when its successor arrives only if the interval before it has not begun
/// (else it stays 0: the point comes to rest there, then sets off again).
class AnchorTrack
{
public:
  /// What append() did with a sample.
  enum class Append
  {
    Taken,      ///< a knot now
    Late,       ///< its time is not after `now` (it would rewrite the past): ignored
    Unordered,  ///< its time is not after the last knot's: ignored
  };

  explicit AnchorTrack(const Vec3& hold = Vec3::Zero()) : hold_(hold)
  {
  }

  /// Adds a knot at sample.time >= now + lead (`lead` [s] >= 0 keeps the first interval from
  /// being so short that its acceleration, ~1/h^2, explodes). Where the track stood still at
  /// `now` (no knot after it), a knot is first put at `now` where the point rests, so it sets off
  /// from there instead of jumping to the path the new knot makes.
  /// `spacing` [s] >= 0: a knot closer than this to the last one is Unordered (the same reason).
  Append append(const AnchorSample& sample, double now, double lead = 0.0, double spacing = 0.0);
  /// Forgets every knot: the point rests at `position` until the next append (a teleport).
  void restart(const Vec3& position);
  /// p(t), v(t), a(t) [m, m/s, m/s^2] at sim time `time`.
  ImposedMotion motion(double time) const;
  /// The holder's orientation at `time` (slerp between knots; identity with none).
  Eigen::Quaterniond orientation(double time) const;
  /// Drops knots no longer needed from `time` on (motion(t >= time) unchanged).
  void dropBefore(double time);
  /// Where the point rests with no knot.
  const Vec3& hold() const
  {
    return hold_;
  }
  std::size_t size() const
  {
    return knots_.size();
  }
  /// The last knot (size() > 0).
  const AnchorSample& last() const
  {
    return knots_.back();
  }

private:
  std::deque<AnchorSample> knots_;
  Vec3 hold_;
};

}  // namespace constrained_particles
