// Every constraint's J and Jdot v against central finite differences on random states.
#include "constrained_particles/core/constraints.hpp"
#include "constrained_particles/core/dynamics.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

using namespace constrained_particles;
using constrained_particles::testing::FD_STEP;
using constrained_particles::testing::Random;

namespace
{
// J by central differences of C, one coordinate at a time
template <typename ValueFn>
Points numericalJacobian(const Points& positions, ValueFn value)
{
  Points jacobian(3, positions.cols());
  for (int i = 0; i < positions.cols(); ++i)
    for (int axis = 0; axis < 3; ++axis)
    {
      Points plus = positions, minus = positions;
      plus(axis, i) += FD_STEP;
      minus(axis, i) -= FD_STEP;
      jacobian(axis, i) = (value(plus) - value(minus)) / (2 * FD_STEP);
    }
  return jacobian;
}

// Jdot v = d/dt [J(p + t v) v] at t = 0, by central differences
template <typename RowFn>
double numericalJdotV(const Points& positions, const Points& velocities, RowFn row_at)
{
  auto jv = [&](double t)
  {
    const Points p = positions + t * velocities;
    const ConstraintRow row = row_at(p);
    double sum = row.gradientOf(0).dot(velocities.col(row.particle[0]));
    if (row.particle[1] >= 0)
      sum += row.gradientOf(1).dot(velocities.col(row.particle[1]));
    return sum;
  };
  return (jv(FD_STEP) - jv(-FD_STEP)) / (2 * FD_STEP);
}

void expectRowMatches(const ConstraintRow& row, const Points& numerical_jacobian, double tolerance)
{
  Points analytic = Points::Zero(3, numerical_jacobian.cols());
  analytic.col(row.particle[0]) += row.gradientOf(0);
  if (row.particle[1] >= 0)
    analytic.col(row.particle[1]) += row.gradientOf(1);
  EXPECT_LE((analytic - numerical_jacobian).cwiseAbs().maxCoeff(), tolerance)
      << "analytic\n"
      << analytic << "\nnumerical\n"
      << numerical_jacobian;
}

}  // namespace

TEST(SurfaceConstraint, JacobianAndJdotVMatchFiniteDifferences)
{
  Random random(7);
  const std::vector<std::pair<std::string, std::vector<double>>> surfaces = {
    { "plane", { 0.7, -0.4, 0.1 } },
    { "bowl", { 1.5, 0.5 } },
    { "saddle", { 1.0, 2.0 } },
    { "waves", { 0.3, 2.0, 1.5 } },
    { "gaussian", { 0.8, 0.6, 0.2, -0.1 } },
  };
  for (const auto& [type, coefficients] : surfaces)
  {
    const Surfaces surface{ makeSurface(type, coefficients) };
    for (int trial = 0; trial < 50; ++trial)
    {
      Points p(3, 2), v(3, 2);
      for (int i = 0; i < 2; ++i)
      {
        p.col(i) = random.vector(1.5);
        v.col(i) = random.vector(2.0);
      }
      const SurfaceConstraint constraint{ 1, 0 };
      const ConstraintRow row = evaluateRow(constraint, surface, p, v);
      EXPECT_DOUBLE_EQ(row.value, constraintValue(constraint, surface, p));
      expectRowMatches(row,
                       numericalJacobian(p, [&](const Points& q)
                                         { return constraintValue(constraint, surface, q); }),
                       1e-7);
      const double numerical = numericalJdotV(
          p, v, [&](const Points& q) { return evaluateRow(constraint, surface, q, v); });
      EXPECT_NEAR(row.jdot_v, numerical, 1e-6 * (1.0 + std::abs(numerical))) << type;
    }
  }
}

TEST(LinkConstraint, JacobianAndJdotVMatchFiniteDifferences)
{
  Random random(8);
  for (int trial = 0; trial < 200; ++trial)
  {
    Points p(3, 3), v(3, 3);
    for (int i = 0; i < 3; ++i)
    {
      p.col(i) = random.vector(2.0);
      v.col(i) = random.vector(3.0);
    }
    const LinkConstraint constraint{ 2, 0, random.uniform(0.1, 2.0) };
    const Surfaces none;
    const ConstraintRow row = evaluateRow(constraint, none, p, v);
    EXPECT_DOUBLE_EQ(row.value, constraintValue(constraint, none, p));
    expectRowMatches(
        row,
        numericalJacobian(p, [&](const Points& q) { return constraintValue(constraint, none, q); }),
        1e-7);
    const double numerical =
        numericalJdotV(p, v, [&](const Points& q) { return evaluateRow(constraint, none, q, v); });
    EXPECT_NEAR(row.jdot_v, numerical, 1e-6 * (1.0 + std::abs(numerical)));
    // metric errors are in metres and metres per second
    const Vec3 d = p.col(2) - p.col(0);
    EXPECT_NEAR(row.metric_error, std::abs(d.norm() - constraint.length), 1e-14);
    const double rate =
        (Vec3(p.col(2) + FD_STEP * v.col(2)) - Vec3(p.col(0) + FD_STEP * v.col(0))).norm();
    const double rate_back =
        (Vec3(p.col(2) - FD_STEP * v.col(2)) - Vec3(p.col(0) - FD_STEP * v.col(0))).norm();
    EXPECT_NEAR(metricRate(constraint, row, v), std::abs(rate - rate_back) / (2 * FD_STEP), 1e-6);
  }
}

// A pin is solved by elimination: C = p - a, J = I, Jdot v = 0 hold if the particle never
// accelerates and its total constraint force cancels everything else acting on it.
TEST(PinConstraint, HoldsParticleWithReactionCancellingAllOtherForces)
{
  Random random(9);
  Scene scene;
  scene.masses = { 2.0, 0.5, 1.5 };
  scene.forces = { GravityForce{ Vec3(0.3, -0.2, -9.81) },
                   ExternalForce{ 0, Vec3(1.0, 2.0, 3.0) } };
  scene.constraints = { LinkConstraint{ 0, 1, 1.0 }, LinkConstraint{ 1, 2, 1.0 },
                        PinConstraint{ 0, Vec3(0.1, 0.2, 0.3) } };
  const Model model = Model::compile(scene);
  EXPECT_EQ(model.inverseMasses()[0], 0.0);
  Dynamics dynamics(model);
  for (int trial = 0; trial < 20; ++trial)
  {
    Points p(3, 3), v(3, 3), a(3, 3);
    p.col(0) = Vec3(0.1, 0.2, 0.3);
    p.col(1) = p.col(0) + random.unitVector();
    p.col(2) = p.col(1) + random.unitVector();
    v.setZero();
    v.col(1) = random.vector(1.0);
    v.col(2) = random.vector(1.0);
    dynamics.computeAccelerations(p, v, 0.0, 0.0, a);
    EXPECT_TRUE(a.col(0).isZero(0.0));
    const Vec3 applied = dynamics.appliedForces().col(0);
    EXPECT_LE((dynamics.constraintForces().col(0) + applied).norm(), 1e-12 * (1 + applied.norm()));
    // the reaction is the last three multipliers
    const Vec3 link_force = p.col(0) - p.col(1);
    const Vec3 reaction = dynamics.multipliers().tail<3>();
    EXPECT_LE((reaction + applied + link_force * dynamics.multipliers()[0]).norm(), 1e-10);
  }
}
