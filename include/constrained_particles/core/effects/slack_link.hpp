/// @file slack_link.hpp
/// @brief A rope segment between two particles: at most its length apart, pulling only when
/// taut. One row that the contact stage (src/core/contact.hpp) switches on and off, like a
/// surface contact's. docs/physics.md, "Contact".
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/link_constraint.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <array>
#include <cmath>

namespace constrained_particles
{
/// Particles i and j at most l apart: C = (l^2 - |p_i - p_j|^2) / 2 >= 0 [m^2], multiplier
/// lambda >= 0 (tension T = lambda |d|, pulling them together) and lambda C = 0: a link's row
/// with its sign turned, so the complementarity is a surface contact's. J = (-d, d), d = p_i -
/// p_j; Jdot v = -|v_i - v_j|^2. Its metric gap is l - |d| [m].
struct SlackLink
{
  int first = 0;      ///< particle i
  int second = 1;     ///< particle j, != i
  double length = 1;  ///< l [m]

  static constexpr const char* KIND = "slack_link";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT = true;  ///< between its particles only
  static constexpr bool UNILATERAL = true;          ///< switched on and off (contact.hpp)
  static constexpr int ROWS = 1;
  static constexpr int PARTICLES = 2;
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("first", &SlackLink::first, FieldKind::Particle, nullptr, "particle i"),
        field("second", &SlackLink::second, FieldKind::Particle, nullptr, "particle j, != i"),
        field("length", &SlackLink::length, FieldKind::Number, &limits::LINK_LENGTH,
              "l, the most they may be apart"));
  }
};

/// Particles the row touches, in block order.
inline std::array<int, 2> rowParticles(const SlackLink& link)
{
  return { { link.first, link.second } };
}

/// The row at (p, v) as if taut (the contact stage zeroes it when slack). Stateless.
inline void evaluateRows(const SlackLink& link, const EffectContext& /*context*/,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  const int i = link.first, j = link.second;
  const LinkDelta d = linkDelta(positions.data() + 3 * i, positions.data() + 3 * j);
  out.jacobian[0] = Vec3(-d.x, -d.y, -d.z);
  out.jacobian[1] = Vec3(d.x, d.y, d.z);
  out.value[0] = -linkValue(d.squared, link.length);
  out.jdot_v[0] = -linkJdotV(velocities.data() + 3 * i, velocities.data() + 3 * j);
  out.violation[0] = linkViolation(d.squared, link.length);
}

/// Geometric stiffness (stability.hpp): a link's.
inline void addGeometricStiffness(const SlackLink& link, const EffectContext& context,
                                  const Points& positions, const double* multipliers,
                                  double* stiffness)
{
  addGeometricStiffness(LinkConstraint{ link.first, link.second, link.length }, context, positions,
                        multipliers, stiffness);
}

/// Taut or over: the rate it stretches, max(0, d.(v_i - v_j)) / |d| [m/s]; slack, 0.
inline void violationRates(const SlackLink& link, const EffectContext& /*context*/,
                           const Points& positions, const Points& velocities, double* rates)
{
  const Vec3 d = positions.col(link.first) - positions.col(link.second);
  const double distance = d.norm();
  rates[0] = distance < link.length || distance == 0.0
                 ? 0.0
                 : std::max(0.0, d.dot(velocities.col(link.first) - velocities.col(link.second)) /
                                     distance);
}

/// How far over its length it is, max(0, |d| - l) [m]: its position error, taut or not.
inline double overstretch(const SlackLink& link, const Points& positions)
{
  return std::max(0.0,
                  (positions.col(link.first) - positions.col(link.second)).norm() - link.length);
}

/// @throws InvalidInput naming the bad field
inline void validate(const SlackLink& link, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(link, num_particles, num_surfaces, prefix, allow_unset);
  requireDistinctParticles(link.first, link.second, prefix);
}

}  // namespace constrained_particles
