/// @file surface_constraint.hpp
/// @brief A particle on a height field, one constraint row.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <algorithm>
#include <array>
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
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr int ROWS = 1;                     ///< one row of J
  static constexpr int PARTICLES = 1;                ///< touching i
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &SurfaceConstraint::particle, FieldKind::Particle, nullptr, "particle i"),
        field("surface", &SurfaceConstraint::surface, FieldKind::Surface, nullptr,
              "the height field it slides on"));
  }
};

/// Particles the row touches.
inline std::array<int, 1> rowParticles(const SurfaceConstraint& constraint)
{
  return { { constraint.particle } };
}

/// C, J, Jdot v and |Z - z| [m] at positions p [m], velocities v [m/s]. Stateless.
inline void evaluateRows(const SurfaceConstraint& constraint, const EffectContext& context,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  const double* p = positions.data() + 3 * constraint.particle;
  const double* v = velocities.data() + 3 * constraint.particle;
  const SurfaceSample s = evaluateSurface(context.surfaces[constraint.surface], p[0], p[1]);
  out.jacobian[0] = Vec3(s.zx, s.zy, -1.0);
  out.value[0] = s.z - p[2];
  out.jdot_v[0] = s.zxx * v[0] * v[0] + 2.0 * s.zxy * v[0] * v[1] + s.zyy * v[1] * v[1];
  out.violation[0] = std::abs(out.value[0]);
}

/// Geometric stiffness (stability.hpp): |lambda| times the largest row sum of the Hessian of Z at
/// the particle [N/m] (the normal force times the curvature it slides over).
inline void addGeometricStiffness(const SurfaceConstraint& constraint, const EffectContext& context,
                                  const Points& positions, const double* multipliers,
                                  double* stiffness)
{
  const double* p = positions.data() + 3 * constraint.particle;
  const SurfaceSample s = evaluateSurface(context.surfaces[constraint.surface], p[0], p[1]);
  const double rows =
      std::max(std::abs(s.zxx) + std::abs(s.zxy), std::abs(s.zxy) + std::abs(s.zyy));
  stiffness[constraint.particle] += std::abs(multipliers[0]) * rows;
}

/// |dC/dt| [m/s].
inline void violationRates(const SurfaceConstraint& constraint, const EffectContext& context,
                           const Points& positions, const Points& velocities, double* rates)
{
  const Vec3 p = positions.col(constraint.particle);
  const SurfaceSample s = evaluateSurface(context.surfaces[constraint.surface], p.x(), p.y());
  rates[0] = std::abs(Vec3(s.zx, s.zy, -1.0).dot(velocities.col(constraint.particle)));
}

/// Puts the particle on the surface at its (x, y) and its velocity in the tangent plane
/// (vz = Z_x vx + Z_y vy): how scene files place particles they constrain to a surface.
inline void fillFromStart(SurfaceConstraint& constraint, const std::vector<Surface>& surfaces,
                          Points& positions, Points& velocities)
{
  auto p = positions.col(constraint.particle);
  auto v = velocities.col(constraint.particle);
  const SurfaceSample s = evaluateSurface(surfaces[constraint.surface], p.x(), p.y());
  p.z() = s.z;
  v.z() = s.zx * v.x() + s.zy * v.y();
}

/// @throws InvalidInput naming the bad field
inline void validate(const SurfaceConstraint& constraint, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(constraint, num_particles, num_surfaces, prefix, allow_unset);
}

}  // namespace constrained_particles
