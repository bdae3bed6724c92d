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
  /// dp/dt at this knot [m/s], set by AnchorTrack
  Vec3 tangent = Vec3::Zero();
  /// The tangent is the state's velocity where the track set off or resumed: never revised.
  bool fixed = false;
};

/// The held point's motion between knots (sample times): a cubic Hermite spline (C1: position
/// and velocity continuous, acceleration piecewise linear) through every knot exactly.
///
/// Tangents (per coordinate):
/// - an inner knot k: the derivative of the parabola through knots k-1, k, k+1 (second order on
///   uneven knots: d = (h1 d0 + h0 d1) / (h0 + h1), d0 and d1 the secants of the intervals before
///   and after, h0 and h1 their lengths), limited where the samples are monotone so that no
///   interval overshoots its knots (0 beside a flat interval, at most 3 min(|d0|, |d1|) where d0
///   and d1 agree in sign: Fritsch and Carlson 1980, SIAM J. Numer. Anal. 17(2), sec. 4); where
///   they turn (d0 d1 < 0) the parabola's, as the turn lies between them;
/// - the newest knot, until its successor arrives: the parabola's one-sided derivative from the
///   last three knots, limited as Moler's pchip ends (0 against the last secant's sign, at most 3
///   times it where the secants turn), the secant with two; revised when the successor arrives if
///   the interval ending at it has not begun (an append never changes the motion from `now` on);
/// - the first knot (where the track set off from rest, or resumed): the state's velocity there.
///
/// Past the newest knot the point coasts: it goes on with the newest tangent v, slowing
/// uniformly to rest over horizon() H (p = p_n + v (s - s^2 / (2H)) at s = t - t_n, then rest at
/// p_n + v H / 2), so steps that run ahead of the samples carry the motion on smoothly; the next
/// sample then resumes from where and how fast the point coasts. With no knot it rests at hold().
///
/// Teleports: a sample that jumped (appendJump) is a knot on the path continued from the newest
/// knot at its velocity, and a jump scheduled at its time with the displacement to where the
/// holder really is; knots after it are kept in the frame before the jump. The caller carries the
/// scene along when the steps reach it (takeJump), which moves every knot with it.
class AnchorTrack
{
public:
  /// What append() did with a sample.
  enum class Append
  {
    Taken,      ///< a knot now
    Late,       ///< its time is not at least `lead` after `now` (it would rewrite the past)
    Unordered,  ///< its time is not after the last knot's (plus `spacing`): ignored
  };
  /// A teleport the steps have not reached: at `time` [s] the point moves by `displacement` [m].
  struct Jump
  {
    double time = 0.0;
    Vec3 displacement = Vec3::Zero();
  };
  /// Default horizon() [s].
  static constexpr double DEFAULT_HORIZON = 0.25;

  explicit AnchorTrack(const Vec3& hold = Vec3::Zero()) : hold_(hold)
  {
  }

  /// Adds a knot at sample.position and sample.time >= now + lead (`lead` [s] >= 0 keeps the
  /// first interval from being so short that its acceleration, ~1/h^2, explodes). Where the
  /// track has no knot after `now` (at rest, or coasting past its newest), a knot is first put at
  /// `now` where the point is, with the velocity it has, so it sets off from there instead of
  /// jumping to the path the new knot makes. `spacing` [s] >= 0: a knot closer than this to the
  /// last one is Unordered.
  Append append(const AnchorSample& sample, double now, double lead = 0.0, double spacing = 0.0);
  /// A sample the holder teleported to: taken as append() takes a sample (Late and Unordered
  /// alike), but on the path continued from the newest knot, with a Jump scheduled at its time
  /// to sample.position. A sample too late for a knot is a jump at `now` (returned Late).
  Append appendJump(const AnchorSample& sample, double now, double lead = 0.0,
                    double spacing = 0.0);
  /// The earliest jump the steps have not taken (null if none).
  const Jump* nextJump() const
  {
    return jumps_.empty() ? nullptr : &jumps_.front();
  }
  /// Takes the earliest jump: every knot and the hold move by its displacement, returned [m].
  /// Call when the steps reach its time; nextJump() must not be null.
  Vec3 takeJump();
  /// Forgets every knot and jump: the point rests at `position` until the next append (which
  /// sets off turned as the appended sample).
  void restart(const Vec3& position);
  /// The same, turned by `orientation` while it rests and where the next append sets off (a
  /// carried obstacle put at a pose).
  void restart(const Vec3& position, const Eigen::Quaterniond& orientation);
  /// restart() at the pose `from` has at `time` [s] (placed and turned): a carried obstacle at
  /// rest where it is (from = *this) or where another run's is.
  void restAt(const AnchorTrack& from, double time);
  void restAt(double time)
  {
    restAt(*this, time);
  }
  /// Forgets the knots and jumps after `now`: the point goes on from where and as fast as it
  /// moves now (coasting to rest), until the next append sets off from there.
  void resync(double now);
  /// p(t), v(t), a(t) [m, m/s, m/s^2] at sim time `time`.
  ImposedMotion motion(double time) const;
  /// The holder's orientation at `time` (slerp between knots; the rest's with none).
  Eigen::Quaterniond orientation(double time) const;
  /// The holder's angular velocity at `time` [rad/s], world frame: constant between two knots
  /// (slerp turns at a constant rate: log(q_b q_a^-1) / (t_b - t_a)), 0 outside them.
  Vec3 angularVelocity(double time) const;
  /// Drops knots no longer needed from `time` on (motion(t >= time) unchanged).
  void dropBefore(double time);
  /// True if `time` is past the newest sample's knot while it was moving: the point coasts.
  bool coasting(double time) const
  {
    return !knots_.empty() && time > knots_.back().time && !knots_.back().fixed &&
           !knots_.back().tangent.isZero();
  }
  /// Where the point rests with no knot.
  const Vec3& hold() const
  {
    return hold_;
  }
  /// The time [s] over which a coasting point comes to rest (> 0).
  double horizon() const
  {
    return horizon_;
  }
  /// The newest knot rests: its tangent 0, never revised (a still holder's pose: the point comes
  /// to rest there, not past it).
  void settle()
  {
    if (!knots_.empty())
    {
      knots_.back().tangent.setZero();
      knots_.back().fixed = true;
    }
  }
  std::size_t size() const
  {
    return knots_.size();
  }
  /// The last knot (size() > 0), in the frame before any jump not taken yet.
  const AnchorSample& last() const
  {
    return knots_.back();
  }

private:
  /// Whether a sample at `time` may be a knot (Taken), or why not.
  Append admit(double time, double now, double lead, double spacing) const;
  /// Puts a knot at `now` where the point is and as fast as it moves, dropping older knots, if
  /// none is after `now`: where an appended knot sets off from.
  void resumeAt(double now, const Eigen::Quaterniond& orientation);
  /// Every knot replaced by one at `now` where the point is, with the velocity it has (fixed).
  void startAt(double now, const Eigen::Quaterniond& orientation);
  /// Appends `knot` after the last (its time checked by the caller), with the tangents it sets.
  void pushKnot(const AnchorSample& knot, double now);
  /// The tangent of knot k from k - 1, k and k + 1 (an inner knot).
  Vec3 innerTangent(std::size_t k) const;
  /// The newest knot's provisional tangent (from up to three knots).
  Vec3 newestTangent() const;
  /// Where the newest knot's path leads at `time` >= its time, at its velocity.
  Vec3 continued(double time) const;

  std::deque<AnchorSample> knots_;
  std::deque<Jump> jumps_;
  Vec3 pending_ = Vec3::Zero();  // sum of the jumps not taken: knots are stored before them
  Vec3 hold_;
  Eigen::Quaterniond hold_orientation_ = Eigen::Quaterniond::Identity();
  bool hold_turned_ = false;  // restart() was given the orientation: an append sets off from it
  double horizon_ = DEFAULT_HORIZON;
};

}  // namespace constrained_particles
