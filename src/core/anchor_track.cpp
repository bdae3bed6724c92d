/// @file anchor_track.cpp
/// @brief AnchorTrack: cubic Hermite interpolation of a holder's sampled path.
#include "constrained_particles/core/anchor_track.hpp"

#include <algorithm>
#include <iterator>

namespace constrained_particles
{
AnchorTrack::Append AnchorTrack::append(const AnchorSample& sample, double now, double lead,
                                        double spacing)
{
  if (!knots_.empty() &&
      !(sample.time > knots_.back().time && sample.time >= knots_.back().time + spacing))
    return Append::Unordered;
  if (!(sample.time > now && sample.time >= now + lead))
    return Append::Late;
  if (knots_.empty() || knots_.back().time < now)
  {
    // at rest at `now` (on the hold or past the last knot): set off from there, not from the past
    AnchorSample rest;
    rest.time = now;
    rest.position = motion(now).position;
    rest.orientation = knots_.empty() ? sample.orientation : knots_.back().orientation;
    knots_.clear();
    knots_.push_back(rest);
  }
  knots_.push_back(sample);
  knots_.back().tangent = Vec3::Zero();  // the last knot: at rest until a successor arrives
  // the knot before gets its central difference, unless the interval ending at it has begun
  const std::size_t k = knots_.size() - 2;
  if (k >= 1 && now <= knots_[k - 1].time)
    knots_[k].tangent = (knots_[k + 1].position - knots_[k - 1].position) /
                        (knots_[k + 1].time - knots_[k - 1].time);
  return Append::Taken;
}

void AnchorTrack::restart(const Vec3& position)
{
  knots_.clear();
  hold_ = position;
}

ImposedMotion AnchorTrack::motion(double time) const
{
  if (knots_.empty())
    return { hold_, Vec3::Zero(), Vec3::Zero() };
  if (!(time > knots_.front().time))
    return { knots_.front().position, Vec3::Zero(), Vec3::Zero() };
  if (!(time < knots_.back().time))
    return { knots_.back().position, Vec3::Zero(), Vec3::Zero() };
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
    return Eigen::Quaterniond::Identity();
  if (!(time > knots_.front().time))
    return knots_.front().orientation;
  if (!(time < knots_.back().time))
    return knots_.back().orientation;
  const auto after = std::upper_bound(knots_.begin(), knots_.end(), time,
                                      [](double t, const AnchorSample& s) { return t < s.time; });
  const AnchorSample &b = *after, &a = *(after - 1);
  return a.orientation.slerp((time - a.time) / (b.time - a.time), b.orientation);
}

void AnchorTrack::dropBefore(double time)
{
  // the interval [t_k, t_k+1] holding `time` reads knots k and k+1 (tangents are stored); the
  // knot before is kept for the next knot's central difference
  while (knots_.size() > 3 && knots_[2].time <= time)
    knots_.pop_front();
}

}  // namespace constrained_particles
