/// @file point_on_plane.hpp
/// @brief A particle held on a fixed plane: one row on one particle.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <array>
#include <cmath>
#include <vector>

namespace constrained_particles
{
/// Particle i on the plane through q with normal n:  C = n^.(p_i - q) [m], n^ = n / |n|.
/// J = n^ at i (constant), so Jdot v = 0. The metric error is |C|.
struct PointOnPlaneConstraint
{
  int particle = 0;              ///< particle i
  Vec3 point{ NAN, NAN, NAN };   ///< q, a point of the plane [m]; unset: its start
  Vec3 normal{ 0.0, 0.0, 1.0 };  ///< n, normal to the plane (normalised), non-zero

  static constexpr const char* KIND = "point_on_plane";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr int ROWS = 1;                     ///< one row of J
  static constexpr int PARTICLES = 1;                ///< on particle i
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &PointOnPlaneConstraint::particle, FieldKind::Particle, nullptr,
              "particle i"),
        field("point", &PointOnPlaneConstraint::point, FieldKind::Vector, &limits::COORDINATE,
              "q, a point of the plane (default: where the particle starts)", true),
        field("normal", &PointOnPlaneConstraint::normal, FieldKind::Direction, &limits::DIRECTION,
              "n, normal to the plane"));
  }
};

/// Particles the row touches.
inline std::array<int, 1> rowParticles(const PointOnPlaneConstraint& constraint)
{
  return { { constraint.particle } };
}

/// C, J, Jdot v and |C| at positions p [m]. Stateless.
inline void evaluateRows(const PointOnPlaneConstraint& constraint, const EffectContext& /*context*/,
                         const Points& positions, const Points& /*velocities*/, RowBlock out)
{
  const Vec3 n = constraint.normal.normalized();
  out.jacobian[0] = n;
  out.value[0] = n.dot(positions.col(constraint.particle) - constraint.point);
  out.jdot_v[0] = 0.0;
  out.violation[0] = std::abs(out.value[0]);
}

/// Geometric stiffness (stability.hpp): C is linear in p, none.
inline void addGeometricStiffness(const PointOnPlaneConstraint& /*constraint*/,
                                  const EffectContext& /*context*/, const Points& /*positions*/,
                                  const double* /*multipliers*/, double* /*stiffness*/)
{
}

/// |n^ . v_i| [m/s].
inline void violationRates(const PointOnPlaneConstraint& constraint,
                           const EffectContext& /*context*/, const Points& /*positions*/,
                           const Points& velocities, double* rates)
{
  rates[0] = std::abs(constraint.normal.normalized().dot(velocities.col(constraint.particle)));
}

/// An unset point is where the particle starts: it starts on the plane.
inline void fillFromStart(PointOnPlaneConstraint& constraint,
                          const std::vector<Surface>& /*surfaces*/, Points& positions,
                          Points& /*velocities*/)
{
  if (isUnset(constraint.point))
    constraint.point = positions.col(constraint.particle);
}

/// @throws InvalidInput naming the bad field
inline void validate(const PointOnPlaneConstraint& constraint, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(constraint, num_particles, num_surfaces, prefix, allow_unset);
}

}  // namespace constrained_particles
