/// @file anchor_track.cpp
/// @brief AnchorTrack: cubic Hermite interpolation of a holder's sampled path, coasting past its
/// newest sample, and its teleports.
#include "constrained_particles/core/anchor_track.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>

namespace constrained_particles
{
AnchorTrack::Append AnchorTrack::admit(double time, double now, double lead, double spacing) const
{
  if (!knots_.empty() && !(time > knots_.back().time && time >= knots_.back().time + spacing))
    return Append::Unordered;
  if (!(time > now && time >= now + lead))
    return Append::Late;
  return Append::Taken;
}

AnchorTrack::Append AnchorTrack::append(const AnchorSample& sample, double now, double lead,
                                        double spacing)
{
  if (const Append admitted = admit(sample.time, now, lead, spacing); admitted != Append::Taken)
    return admitted;
  resumeAt(now, sample.orientation);
  AnchorSample knot = sample;
  knot.position = sample.position - pending_;  // in the frame before the jumps not taken
  pushKnot(knot, now);
  return Append::Taken;
}

AnchorTrack::Append AnchorTrack::appendJump(const AnchorSample& sample, double now, double lead,
                                            double spacing)
{
  const Append admitted = admit(sample.time, now, lead, spacing);
  if (admitted == Append::Unordered)
    return admitted;
  if (admitted == Append::Late)
  {
    // no knot after `now` (that would have made it Unordered): the jump is taken at once, from
    // wherever the point is now
    const Vec3 displacement = sample.position - pending_ - motion(now).position;
    jumps_.push_back(Jump{ now, displacement });
    pending_ += displacement;
    return Append::Late;
  }
  resumeAt(now, sample.orientation);
  AnchorSample knot = sample;
  knot.position = continued(sample.time);  // the path goes on as it went; the jump is the rest
  const Vec3 displacement = sample.position - pending_ - knot.position;
  jumps_.push_back(Jump{ sample.time, displacement });
  pending_ += displacement;
  pushKnot(knot, now);
  return Append::Taken;
}

Vec3 AnchorTrack::takeJump()
{
  const Vec3 displacement = jumps_.front().displacement;
  jumps_.pop_front();
  for (AnchorSample& knot : knots_)
    knot.position += displacement;
  hold_ += displacement;
  pending_ -= displacement;
  return displacement;
}

void AnchorTrack::resumeAt(double now, const Eigen::Quaterniond& orientation)
{
  // at rest at `now` (on the hold, or coasting past the last knot): set off from there, as fast
  // as it goes, never from the past
  if (knots_.empty() || knots_.back().time < now)
    startAt(now, knots_.empty() ? (hold_turned_ ? hold_orientation_ : orientation)
                                : knots_.back().orientation);
}

void AnchorTrack::startAt(double now, const Eigen::Quaterniond& orientation)
{
  const ImposedMotion at = motion(now);
  AnchorSample start;
  start.time = now;
  start.position = at.position;
  start.tangent = at.velocity;
  start.fixed = true;
  start.orientation = orientation;
  knots_.clear();
  knots_.push_back(start);
}

void AnchorTrack::pushKnot(const AnchorSample& knot, double now)
{
  knots_.push_back(knot);
  knots_.back().fixed = false;
  const std::size_t n = knots_.size();
  // the knot before is inner now: its parabola's tangent, unless the interval ending at it has
  // begun (the motion from `now` on stays as imposed)
  if (n >= 3 && !knots_[n - 2].fixed && now <= knots_[n - 3].time)
    knots_[n - 2].tangent = innerTangent(n - 2);
  knots_.back().tangent = newestTangent();
}

Vec3 AnchorTrack::innerTangent(std::size_t k) const
{
  const AnchorSample &a = knots_[k - 1], &b = knots_[k], &c = knots_[k + 1];
  const double h0 = b.time - a.time, h1 = c.time - b.time;
  const Vec3 d0 = (b.position - a.position) / h0, d1 = (c.position - b.position) / h1;
  Vec3 d = (h1 * d0 + h0 * d1) / (h0 + h1);
  for (int i = 0; i < 3; ++i)
  {
    const double turn = d0[i] * d1[i];
    if (turn == 0.0)
      d[i] = 0.0;  // beside a flat interval: flat, no overshoot into it
    else if (turn > 0.0)
    {
      // monotone here: at most 3 times the smaller secant keeps both intervals monotone
      const double bound = 3.0 * std::min(std::abs(d0[i]), std::abs(d1[i]));
      d[i] = std::copysign(std::min(std::abs(d[i]), bound), d1[i]);
    }
  }
  return d;
}

Vec3 AnchorTrack::newestTangent() const
{
  const std::size_t n = knots_.size();
  const AnchorSample &b = knots_[n - 2], &c = knots_[n - 1];
  const double h1 = c.time - b.time;
  const Vec3 d1 = (c.position - b.position) / h1;
  if (n < 3)
    return d1;
  const AnchorSample& a = knots_[n - 3];
  const double h0 = b.time - a.time;
  const Vec3 d0 = (b.position - a.position) / h0;
  // the parabola through the last three, at the last: d1 + (d1 - d0) h1 / (h0 + h1)
  Vec3 d = d1 + (d1 - d0) * (h1 / (h0 + h1));
  for (int i = 0; i < 3; ++i)
  {
    if (d[i] * d1[i] <= 0.0)
      d[i] = 0.0;  // against the last secant (or beside a flat one): it would turn back
    else if (d0[i] * d1[i] < 0.0 && std::abs(d[i]) > 3.0 * std::abs(d1[i]))
      d[i] = 3.0 * d1[i];
  }
  return d;
}

Vec3 AnchorTrack::continued(double time) const
{
  // from the newest knot as it moves there: resumeAt() put one at `now` if the steps were past
  // the samples, so this is at most the lead ahead
  if (knots_.empty())
    return hold_;
  return knots_.back().position + knots_.back().tangent * (time - knots_.back().time);
}

void AnchorTrack::resync(double now)
{
  if (knots_.empty())
    return;
  startAt(now, orientation(now));
  jumps_.clear();
  pending_.setZero();
}

void AnchorTrack::restart(const Vec3& position)
{
  restart(position, Eigen::Quaterniond::Identity());
  hold_turned_ = false;
}

void AnchorTrack::restart(const Vec3& position, const Eigen::Quaterniond& orientation)
{
  knots_.clear();
  jumps_.clear();
  pending_.setZero();
  hold_ = position;
  hold_orientation_ = orientation;
  hold_turned_ = true;
}

void AnchorTrack::restAt(const AnchorTrack& from, double time)
{
  const Vec3 position = from.motion(time).position;  // read before a restart of from itself
  restart(position, from.orientation(time));
}

ImposedMotion AnchorTrack::motion(double time) const
{
  if (knots_.empty())
    return { hold_, Vec3::Zero(), Vec3::Zero() };
  if (!(time > knots_.front().time) && knots_.size() > 1)
    return { knots_.front().position, knots_.front().tangent, Vec3::Zero() };
  if (!(time < knots_.back().time))
  {
    // past the newest knot: coasting, slowing uniformly to rest over the horizon
    const AnchorSample& last = knots_.back();
    const double s = std::min(time - last.time, horizon_);
    if (!(s > 0.0))
      return { last.position, last.tangent, -last.tangent / horizon_ };
    return { last.position + last.tangent * (s - s * s / (2.0 * horizon_)),
             last.tangent * (1.0 - s / horizon_),
             s < horizon_ ? Vec3(-last.tangent / horizon_) : Vec3(Vec3::Zero()) };
  }
  // the interval [t_k, t_k+1] holding `time`
  const auto after = std::upper_bound(knots_.begin(), knots_.end(), time,
                                      [](double t, const AnchorSample& s) { return t < s.time; });
  const std::size_t k = static_cast<std::size_t>(std::distance(knots_.begin(), after)) - 1;
  const AnchorSample &a = knots_[k], &b = knots_[k + 1];
  const double h = b.time - a.time, u = (time - a.time) / h;
  const Vec3 m0 = h * a.tangent, m1 = h * b.tangent;
  // Hermite basis h00, h10, h01, h11 and their first and second derivatives in u
  const double u2 = u * u, u3 = u2 * u;
  const Vec3 position = (2 * u3 - 3 * u2 + 1) * a.position + (u3 - 2 * u2 + u) * m0 +
                        (-2 * u3 + 3 * u2) * b.position + (u3 - u2) * m1;
  const Vec3 velocity = ((6 * u2 - 6 * u) * a.position + (3 * u2 - 4 * u + 1) * m0 +
                         (-6 * u2 + 6 * u) * b.position + (3 * u2 - 2 * u) * m1) /
                        h;
  const Vec3 acceleration = ((12 * u - 6) * a.position + (6 * u - 4) * m0 +
                             (-12 * u + 6) * b.position + (6 * u - 2) * m1) /
                            (h * h);
  return { position, velocity, acceleration };
}

Eigen::Quaterniond AnchorTrack::orientation(double time) const
{
  if (knots_.empty())
    return hold_orientation_;
  if (!(time > knots_.front().time))
    return knots_.front().orientation;
  if (!(time < knots_.back().time))
    return knots_.back().orientation;
  const auto after = std::upper_bound(knots_.begin(), knots_.end(), time,
                                      [](double t, const AnchorSample& s) { return t < s.time; });
  const AnchorSample &b = *after, &a = *(after - 1);
  return a.orientation.slerp((time - a.time) / (b.time - a.time), b.orientation);
}

Vec3 AnchorTrack::angularVelocity(double time) const
{
  if (knots_.size() < 2 || !(time >= knots_.front().time) || !(time < knots_.back().time))
    return Vec3::Zero();
  const auto after = std::upper_bound(knots_.begin(), knots_.end(), time,
                                      [](double t, const AnchorSample& s) { return t < s.time; });
  const AnchorSample &b = *after, &a = *(after - 1);
  // slerp(a, b, u) = (b a^-1)^u a on the shorter arc: the world-frame turn b a^-1, signed so
  Eigen::Quaterniond turn = b.orientation * a.orientation.conjugate();
  if (turn.w() < 0.0)
    turn.coeffs() = -turn.coeffs();
  const Eigen::AngleAxisd axis_angle(turn.normalized());
  return axis_angle.axis() * (axis_angle.angle() / (b.time - a.time));
}

void AnchorTrack::dropBefore(double time)
{
  // the interval [t_k, t_k+1] holding `time` reads knots k and k+1 (tangents are stored); the
  // knot before is kept for the next knot's tangent
  while (knots_.size() > 3 && knots_[2].time <= time)
    knots_.pop_front();
}

}  // namespace constrained_particles
