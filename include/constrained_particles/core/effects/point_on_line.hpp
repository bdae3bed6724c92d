/// @file point_on_line.hpp
/// @brief A particle held on a fixed straight line: two rows on one particle.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <vector>

namespace constrained_particles
{
/// Particle i on the line through q along d:  C = (e_1.(p_i - q), e_2.(p_i - q)) [m], with e_1,
/// e_2 a fixed orthonormal pair perpendicular to d (lineNormals()). J = e_1, e_2 at i (constant),
/// so Jdot v = 0. The metric error of each row is |C_r|.
struct PointOnLineConstraint
{
  int particle = 0;                 ///< particle i
  Vec3 point{ NAN, NAN, NAN };      ///< q, a point of the line [m]; unset: its start
  Vec3 direction{ 1.0, 0.0, 0.0 };  ///< d, along the line (normalised), non-zero

  static constexpr const char* KIND = "point_on_line";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr int ROWS = 2;       ///< two rows of J: the two directions off the line
  static constexpr int PARTICLES = 1;  ///< both on particle i
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &PointOnLineConstraint::particle, FieldKind::Particle, nullptr,
              "particle i"),
        field("point", &PointOnLineConstraint::point, FieldKind::Vector, &limits::COORDINATE,
              "q, a point of the line (default: where the particle starts)", true),
        field("direction", &PointOnLineConstraint::direction, FieldKind::Direction,
              &limits::DIRECTION, "d, along the line"));
  }
};

/// e_1, e_2: unit vectors perpendicular to d and to each other, e_1 built from the coordinate
/// axis least aligned with d (so it never degenerates).
inline std::array<Vec3, 2> lineNormals(const Vec3& direction)
{
  const Vec3 d = direction.normalized();
  int least = 0;
  for (int axis = 1; axis < 3; ++axis)
    if (std::abs(d[axis]) < std::abs(d[least]))
      least = axis;
  const Vec3 e1 = d.cross(Vec3::Unit(least)).normalized();
  return { { e1, d.cross(e1) } };
}

/// Particles the rows touch.
inline std::array<int, 1> rowParticles(const PointOnLineConstraint& constraint)
{
  return { { constraint.particle } };
}

/// C, J, Jdot v and |C| at positions p [m]. Stateless.
inline void evaluateRows(const PointOnLineConstraint& constraint, const EffectContext& /*context*/,
                         const Points& positions, const Points& /*velocities*/, RowBlock out)
{
  const std::array<Vec3, 2> e = lineNormals(constraint.direction);
  const Vec3 offset = positions.col(constraint.particle) - constraint.point;
  for (int r = 0; r < 2; ++r)
  {
    out.jacobian[r] = e[r];
    out.value[r] = e[r].dot(offset);
    out.jdot_v[r] = 0.0;
    out.violation[r] = std::abs(out.value[r]);
  }
}

/// Geometric stiffness (stability.hpp): C is linear in p, none.
inline void addGeometricStiffness(const PointOnLineConstraint& /*constraint*/,
                                  const EffectContext& /*context*/, const Points& /*positions*/,
                                  const double* /*multipliers*/, double* /*stiffness*/)
{
}

/// |e_r . v_i| [m/s].
inline void violationRates(const PointOnLineConstraint& constraint,
                           const EffectContext& /*context*/, const Points& /*positions*/,
                           const Points& velocities, double* rates)
{
  const std::array<Vec3, 2> e = lineNormals(constraint.direction);
  for (int r = 0; r < 2; ++r)
    rates[r] = std::abs(e[r].dot(velocities.col(constraint.particle)));
}

/// An unset point is where the particle starts: it starts on the line.
inline void fillFromStart(PointOnLineConstraint& constraint,
                          const std::vector<Surface>& /*surfaces*/, Points& positions,
                          Points& /*velocities*/)
{
  if (isUnset(constraint.point))
    constraint.point = positions.col(constraint.particle);
}

/// @throws InvalidInput naming the bad field
inline void validate(const PointOnLineConstraint& constraint, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(constraint, num_particles, num_surfaces, prefix, allow_unset);
}

}  // namespace constrained_particles
