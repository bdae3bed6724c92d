#include "constrained_particles/core/constraints.hpp"

#include <cmath>

namespace constrained_particles
{
void evaluateRow(const SurfaceConstraint& constraint, const Surface& surface,
                 const Points& positions, const Points& velocities, ConstraintRow& row)
{
  const int i = constraint.particle;
  const double* p = positions.data() + 3 * i;
  const double* v = velocities.data() + 3 * i;
  const SurfaceSample s = evaluateSurface(surface, p[0], p[1]);
  row.particle = { { i, -1 } };
  row.gradient = Vec3(s.zx, s.zy, -1.0);
  row.value = s.z - p[2];
  row.jdot_v = s.zxx * v[0] * v[0] + 2.0 * s.zxy * v[0] * v[1] + s.zyy * v[1] * v[1];
  row.metric_error = std::abs(row.value);
}

void evaluateRow(const LinkConstraint& constraint, const Points& positions,
                 const Points& velocities, ConstraintRow& row)
{
  const int i = constraint.first, j = constraint.second;
  const double* pi = positions.data() + 3 * i;
  const double* pj = positions.data() + 3 * j;
  const double* vi = velocities.data() + 3 * i;
  const double* vj = velocities.data() + 3 * j;
  const double dx = pi[0] - pj[0], dy = pi[1] - pj[1], dz = pi[2] - pj[2];
  const double ux = vi[0] - vj[0], uy = vi[1] - vj[1], uz = vi[2] - vj[2];
  const double squared = dx * dx + dy * dy + dz * dz;
  const double distance = std::sqrt(squared);
  row.particle = { { i, j } };
  row.gradient = Vec3(dx, dy, dz);
  row.value = 0.5 * (squared - constraint.length * constraint.length);
  row.jdot_v = ux * ux + uy * uy + uz * uz;
  row.metric_error = std::abs(distance - constraint.length);
}

double metricRate(const SurfaceConstraint& constraint, const ConstraintRow& row,
                  const Points& velocities)
{
  return std::abs(row.gradient.dot(velocities.col(constraint.particle)));
}

double metricRate(const LinkConstraint& constraint, const ConstraintRow& row,
                  const Points& velocities)
{
  const Vec3 relative = velocities.col(constraint.first) - velocities.col(constraint.second);
  const double distance = row.gradient.norm();
  // coincident particles have no defined direction: report the relative speed instead
  return distance > 0.0 ? std::abs(row.gradient.dot(relative)) / distance : relative.norm();
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
