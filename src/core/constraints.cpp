#include "constrained_particles/core/constraints.hpp"

#include <cmath>

namespace constrained_particles
{
ConstraintRow evaluateRow(const SurfaceConstraint& constraint, const Surface& surface,
                          const Points& positions, const Points& velocities)
{
  const int i = constraint.particle;
  const Vec3 p = positions.col(i);
  const Vec3 v = velocities.col(i);
  const SurfaceSample s = evaluateSurface(surface, p.x(), p.y());
  ConstraintRow row;
  row.particle = { { i, -1 } };
  row.gradient[0] = Vec3(s.zx, s.zy, -1.0);
  row.gradient[1].setZero();
  row.value = s.z - p.z();
  row.jdot_v = s.zxx * v.x() * v.x() + 2.0 * s.zxy * v.x() * v.y() + s.zyy * v.y() * v.y();
  row.metric_error = std::abs(row.value);
  row.metric_rate = std::abs(row.gradient[0].dot(v));
  return row;
}

ConstraintRow evaluateRow(const LinkConstraint& constraint, const Points& positions,
                          const Points& velocities)
{
  const int i = constraint.first, j = constraint.second;
  const Vec3 d = positions.col(i) - positions.col(j);
  const Vec3 dv = velocities.col(i) - velocities.col(j);
  const double distance = d.norm();
  ConstraintRow row;
  row.particle = { { i, j } };
  row.gradient[0] = d;
  row.gradient[1] = -d;
  row.value = 0.5 * (d.squaredNorm() - constraint.length * constraint.length);
  row.jdot_v = dv.squaredNorm();
  row.metric_error = std::abs(distance - constraint.length);
  // coincident particles have no defined direction: report the relative speed instead
  row.metric_rate = distance > 0.0 ? std::abs(d.dot(dv)) / distance : dv.norm();
  return row;
}

double constraintValue(const SurfaceConstraint& constraint, const Surface& surface,
                       const Points& positions)
{
  const Vec3 p = positions.col(constraint.particle);
  return evaluateSurface(surface, p.x(), p.y()).z - p.z();
}

double constraintValue(const LinkConstraint& constraint, const Points& positions)
{
  const Vec3 d = positions.col(constraint.first) - positions.col(constraint.second);
  return 0.5 * (d.squaredNorm() - constraint.length * constraint.length);
}

}  // namespace constrained_particles
