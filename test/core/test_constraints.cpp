// The surface and link constraints' J and Jdot v against central finite differences on random
// states, and the pin's elimination (test_registry.cpp runs the same checks over every kind).
#include "constrained_particles/core/constraints.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

using namespace constrained_particles;
using constrained_particles::testing::computeAccelerations;
using constrained_particles::testing::evaluateRecord;
using constrained_particles::testing::FD_STEP;
using constrained_particles::testing::Random;
using constrained_particles::testing::RecordRows;

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
    return row_at(p).jv(0, velocities);
  };
  return (jv(FD_STEP) - jv(-FD_STEP)) / (2 * FD_STEP);
}

template <typename Kind>
void expectRowMatches(const RecordRows<Kind>& row, const Points& numerical_jacobian,
                      double tolerance)
{
  const Points analytic = row.jacobianRow(0, static_cast<int>(numerical_jacobian.cols()));
  EXPECT_LE((analytic - numerical_jacobian).cwiseAbs().maxCoeff(), tolerance)
      << "analytic\n"
      << analytic << "\nnumerical\n"
      << numerical_jacobian;
}

// C of a record at positions p alone (velocities zero)
template <typename Kind>
double constraintValue(const Kind& constraint, const std::vector<Surface>& surfaces,
                       const Points& positions)
{
  const Points zero = Points::Zero(3, positions.cols());
  return evaluateRecord(constraint, surfaces, positions, zero).value[0];
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
    const std::vector<Surface> surface{ makeSurface(type, coefficients) };
    for (int trial = 0; trial < 50; ++trial)
    {
      Points p(3, 2), v(3, 2);
      for (int i = 0; i < 2; ++i)
      {
        p.col(i) = random.vector(1.5);
        v.col(i) = random.vector(2.0);
      }
      const SurfaceConstraint constraint{ 1, 0 };
      const auto row = evaluateRecord(constraint, surface, p, v);
      EXPECT_DOUBLE_EQ(row.value[0], constraintValue(constraint, surface, p));
      expectRowMatches(row,
                       numericalJacobian(p, [&](const Points& q)
                                         { return constraintValue(constraint, surface, q); }),
                       1e-7);
      const double numerical = numericalJdotV(
          p, v, [&](const Points& q) { return evaluateRecord(constraint, surface, q, v); });
      EXPECT_NEAR(row.jdot_v[0], numerical, 1e-6 * (1.0 + std::abs(numerical))) << type;
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
    const std::vector<Surface> none;
    const auto row = evaluateRecord(constraint, none, p, v);
    EXPECT_DOUBLE_EQ(row.value[0], constraintValue(constraint, none, p));
    expectRowMatches(
        row,
        numericalJacobian(p, [&](const Points& q) { return constraintValue(constraint, none, q); }),
        1e-7);
    const double numerical = numericalJdotV(
        p, v, [&](const Points& q) { return evaluateRecord(constraint, none, q, v); });
    EXPECT_NEAR(row.jdot_v[0], numerical, 1e-6 * (1.0 + std::abs(numerical)));
    // metric errors are in metres and metres per second
    const Vec3 d = p.col(2) - p.col(0);
    EXPECT_NEAR(row.violation[0], std::abs(d.norm() - constraint.length), 1e-14);
    const double rate =
        (Vec3(p.col(2) + FD_STEP * v.col(2)) - Vec3(p.col(0) + FD_STEP * v.col(0))).norm();
    const double rate_back =
        (Vec3(p.col(2) - FD_STEP * v.col(2)) - Vec3(p.col(0) - FD_STEP * v.col(0))).norm();
    EXPECT_NEAR(row.metric_rate[0], std::abs(rate - rate_back) / (2 * FD_STEP), 1e-6);
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
  Data data(model);
  for (int trial = 0; trial < 20; ++trial)
  {
    Points p(3, 3), v(3, 3), a(3, 3);
    p.col(0) = Vec3(0.1, 0.2, 0.3);
    p.col(1) = p.col(0) + random.unitVector();
    p.col(2) = p.col(1) + random.unitVector();
    v.setZero();
    v.col(1) = random.vector(1.0);
    v.col(2) = random.vector(1.0);
    computeAccelerations(model, data, p, v, a);
    EXPECT_TRUE(a.col(0).isZero(0.0));
    const Vec3 applied = data.applied_forces.col(0);
    EXPECT_LE((data.constraint_forces.col(0) + applied).norm(), 1e-12 * (1 + applied.norm()));
    // the reaction is the last three multipliers
    const Vec3 link_force = p.col(0) - p.col(1);
    const Vec3 reaction = data.multipliers.tail<3>();
    EXPECT_LE((reaction + applied + link_force * data.multipliers[0]).norm(), 1e-10);
  }
}
