/// @file surface_constraint.hpp
/// @brief A particle on a height field, one constraint row.
#pragma once

#include "constrained_particles/core/constraint_row.hpp"
#include "constrained_particles/core/effect_fields.hpp"

#include <cmath>

namespace constrained_particles
{
/// Particle i on the height field z = Z(x, y):  C = Z(x_i, y_i) - z_i  [m].
/// J = (Z_x, Z_y, -1) at i;  Jdot v = Z_xx vx^2 + 2 Z_xy vx vy + Z_yy vy^2.
struct SurfaceConstraint
{
  int particle = 0;  ///< particle index
  int surface = 0;   ///< index into Scene::surfaces

  static constexpr const char* KIND = "surface";
  static constexpr bool ELIMINATED = false;  ///< one row of J
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &SurfaceConstraint::particle, FieldKind::Particle, "", "particle i"),
        field("surface", &SurfaceConstraint::surface, FieldKind::Surface, "",
              "the height field it slides on"));
  }
};

/// Particles the row touches (-1 = unused slot).
inline std::array<int, 2> rowParticles(const SurfaceConstraint& constraint)
{
  return { { constraint.particle, -1 } };
}

/// Evaluates C, J and Jdot v at positions p [m] and velocities v [m/s] into `row`. Stateless.
inline void evaluateRow(const SurfaceConstraint& constraint, const Surfaces& surfaces,
                        const Points& positions, const Points& velocities, ConstraintRow& row)
{
  const int i = constraint.particle;
  const double* p = positions.data() + 3 * i;
  const double* v = velocities.data() + 3 * i;
  const SurfaceSample s = evaluateSurface(surfaces[constraint.surface], p[0], p[1]);
  row.particle = { { i, -1 } };
  row.gradient = Vec3(s.zx, s.zy, -1.0);
  row.value = s.z - p[2];
  row.jdot_v = s.zxx * v[0] * v[0] + 2.0 * s.zxy * v[0] * v[1] + s.zyy * v[1] * v[1];
  row.metric_error = std::abs(row.value);
}

/// C alone [m], for finite-difference checks.
inline double constraintValue(const SurfaceConstraint& constraint, const Surfaces& surfaces,
                              const Points& positions)
{
  const Vec3 p = positions.col(constraint.particle);
  return evaluateSurface(surfaces[constraint.surface], p.x(), p.y()).z - p.z();
}

/// |dC/dt| [m/s] of an evaluated row.
inline double metricRate(const SurfaceConstraint& constraint, const ConstraintRow& row,
                         const Points& velocities)
{
  return std::abs(row.gradient.dot(velocities.col(constraint.particle)));
}

/// @throws InvalidInput naming the bad field
inline void validate(const SurfaceConstraint& constraint, int num_particles, int num_surfaces,
                     const std::string& prefix)
{
  validateFields(constraint, num_particles, num_surfaces, prefix);
}

}  // namespace constrained_particles
