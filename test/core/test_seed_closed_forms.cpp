// The general solver against the seed derivation's closed forms (corrected per physics.md's
// errata), on random states on the constraint manifold: relative error <= 1e-10.
#include "test_helpers.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>

using namespace constrained_particles;
using constrained_particles::testing::Random;

namespace
{
constexpr double TOLERANCE = 1e-10;

Points solverConstraintForces(const Scene& scene, const Points& p, const Points& v)
{
  const Model model = Model::compile(scene);
  Data data(model);
  Points a(3, p.cols());
  const SolveReport report =
      constrained_particles::testing::computeAccelerations(model, data, p, v, a);
  EXPECT_FALSE(report.singular);
  return data.constraint_forces;
}

double relativeError(const Points& actual, const Points& expected)
{
  return (actual - expected).norm() / expected.norm();
}

}  // namespace

// Problem 1: f_c = -m / (Zx^2 + Zy^2 + 1) (Zxx vx^2 + Zyy vy^2 + 2 Zxy vx vy + Zx gx + Zy gy - gz)
//            (Zx, Zy, -1)
TEST(SeedProblem1, BeadOnSurfaceMatchesClosedForm)
{
  Random random(1);
  const std::vector<Surface> surfaces = { makeSurface("plane", { 0.4, -0.3, 0.2 }),
                                          makeSurface("bowl", { 1.2, 0.7 }),
                                          makeSurface("saddle", { 0.9, 1.4 }),
                                          makeSurface("waves", { 0.3, 2.0, 1.0 }),
                                          makeSurface("gaussian", { 0.6, 0.5, 0.1, 0.2 }) };
  for (const Surface& surface : surfaces)
    for (int trial = 0; trial < 100; ++trial)
    {
      const double m = random.uniform(0.1, 10.0);
      const Vec3 g = Vec3(random.uniform(-2, 2), random.uniform(-2, 2), random.uniform(-12, -5));
      const double x = random.uniform(-1.5, 1.5), y = random.uniform(-1.5, 1.5);
      const SurfaceSample s = evaluateSurface(surface, x, y);
      Points p(3, 1), v(3, 1);
      p.col(0) = Vec3(x, y, s.z);
      v.col(0) = random.vector(2.0);
      Scene scene;
      scene.masses = { m };
      scene.surfaces = { surface };
      scene.forces = { GravityForce{ g } };
      scene.constraints = { SurfaceConstraint{ 0, 0 } };

      const double vx = v(0, 0), vy = v(1, 0);
      const double scale = -m / (s.zx * s.zx + s.zy * s.zy + 1.0) *
                           (s.zxx * vx * vx + s.zyy * vy * vy + 2 * s.zxy * vx * vy + s.zx * g.x() +
                            s.zy * g.y() - g.z());
      Points expected(3, 1);
      expected.col(0) = scale * Vec3(s.zx, s.zy, -1.0);
      EXPECT_LE(relativeError(solverConstraintForces(scene, p, v), expected), TOLERANCE)
          << surfaceTypeName(surface.type);
    }
}

// Problem 2 (free chain, equal masses m, uniform gravity so J W f = 0):
// f_c = -(m / l^2) D^T A^-1 w, D rows (p_k - p_k+1, p_k+1 - p_k), A = tridiag(cos, 2, cos),
// cos of the interior angle at each inner particle, w_k = |v_k - v_k+1|^2.
TEST(SeedProblem2, ChainMatchesClosedForm)
{
  Random random(2);
  for (int n : { 2, 3, 4, 7, 12, 20 })
    for (int trial = 0; trial < 40; ++trial)
    {
      const double m = random.uniform(0.1, 5.0), l = random.uniform(0.2, 2.0);
      Points p(3, n), v(3, n);
      p.col(0) = random.vector(1.0);
      for (int i = 1; i < n; ++i)
        p.col(i) = p.col(i - 1) + l * random.unitVector();
      for (int i = 0; i < n; ++i)
        v.col(i) = random.vector(2.0);
      Scene scene;
      scene.masses.assign(n, m);
      scene.forces = { GravityForce{ Vec3(0.5, -1.0, -9.81) } };
      for (int i = 0; i + 1 < n; ++i)
        scene.constraints.push_back(LinkConstraint{ i, i + 1, l });

      const int links = n - 1;
      Eigen::MatrixXd D = Eigen::MatrixXd::Zero(links, 3 * n);
      Eigen::MatrixXd A = Eigen::MatrixXd::Zero(links, links);
      Eigen::VectorXd w(links);
      for (int k = 0; k < links; ++k)
      {
        const Vec3 d = p.col(k) - p.col(k + 1);
        D.block<1, 3>(k, 3 * k) = d.transpose();
        D.block<1, 3>(k, 3 * (k + 1)) = -d.transpose();
        A(k, k) = 2.0;
        if (k + 1 < links)
        {
          // theta at particle k+1, between P_k and P_k+2
          const double cos_theta =
              Vec3(p.col(k) - p.col(k + 1)).dot(Vec3(p.col(k + 2) - p.col(k + 1))) / (l * l);
          A(k, k + 1) = A(k + 1, k) = cos_theta;
        }
        w[k] = (v.col(k) - v.col(k + 1)).squaredNorm();
      }
      const Eigen::VectorXd f = -(m / (l * l)) * D.transpose() * A.ldlt().solve(w);
      const Points expected = Eigen::Map<const Points>(f.data(), 3, n);
      EXPECT_LE(relativeError(solverConstraintForces(scene, p, v), expected), TOLERANCE) << n;
    }
}

// Problem 3: bead on the surface with two particles hanging, equal masses m:
// f_c = -J^T (J M^-1 J^T)^-1 (Jdot v + J M^-1 f) with the symmetric matrix
// (1/m) [[1 + Zx^2 + Zy^2, s, 0], [s, 2 l^2, l^2 cos], [0, l^2 cos, 2 l^2]],
// s = (x1 - x2) Zx + (y1 - y2) Zy - (z1 - z2), and the surface row's 2 Zxy vx vy.
TEST(SeedProblem3, SurfaceChainMatchesClosedForm)
{
  Random random(3);
  const std::vector<Surface> surfaces = { makeSurface("bowl", { 1.0, 0.6 }),
                                          makeSurface("waves", { 0.25, 1.5, 2.0 }),
                                          makeSurface("saddle", { 0.8, 0.4 }) };
  for (const Surface& surface : surfaces)
    for (int trial = 0; trial < 100; ++trial)
    {
      const double m = random.uniform(0.1, 5.0), l = random.uniform(0.2, 2.0);
      const Vec3 g = Vec3(random.uniform(-1, 1), random.uniform(-1, 1), -9.81);
      const double x = random.uniform(-1, 1), y = random.uniform(-1, 1);
      const SurfaceSample s = evaluateSurface(surface, x, y);
      Points p(3, 3), v(3, 3);
      p.col(0) = Vec3(x, y, s.z);
      p.col(1) = p.col(0) + l * random.unitVector();
      p.col(2) = p.col(1) + l * random.unitVector();
      for (int i = 0; i < 3; ++i)
        v.col(i) = random.vector(2.0);
      Scene scene;
      scene.masses.assign(3, m);
      scene.surfaces = { surface };
      scene.forces = { GravityForce{ g } };
      scene.constraints = { SurfaceConstraint{ 0, 0 }, LinkConstraint{ 0, 1, l },
                            LinkConstraint{ 1, 2, l } };

      const Vec3 p1 = p.col(0), p2 = p.col(1), p3 = p.col(2);
      const double s12 = (p1.x() - p2.x()) * s.zx + (p1.y() - p2.y()) * s.zy - (p1.z() - p2.z());
      const double cos_theta = (p1 - p2).dot(p3 - p2) / (l * l);
      Eigen::Matrix3d matrix;
      matrix << 1 + s.zx * s.zx + s.zy * s.zy, s12, 0, s12, 2 * l * l, l * l * cos_theta, 0,
          l * l * cos_theta, 2 * l * l;
      matrix /= m;
      const double vx = v(0, 0), vy = v(1, 0);
      const Eigen::Vector3d rhs(s.zxx * vx * vx + s.zyy * vy * vy + 2 * s.zxy * vx * vy +
                                    s.zx * g.x() + s.zy * g.y() - g.z(),
                                (v.col(0) - v.col(1)).squaredNorm(),
                                (v.col(1) - v.col(2)).squaredNorm());
      Eigen::Matrix<double, 9, 3> jacobian_transpose = Eigen::Matrix<double, 9, 3>::Zero();
      jacobian_transpose.block<3, 1>(0, 0) = Vec3(s.zx, s.zy, -1.0);
      jacobian_transpose.block<3, 1>(0, 1) = p1 - p2;
      jacobian_transpose.block<3, 1>(3, 1) = p2 - p1;
      jacobian_transpose.block<3, 1>(3, 2) = p2 - p3;
      jacobian_transpose.block<3, 1>(6, 2) = p3 - p2;
      const Eigen::Matrix<double, 9, 1> f = -jacobian_transpose * matrix.lu().solve(rhs);
      const Points expected = Eigen::Map<const Points>(f.data(), 3, 3);
      EXPECT_LE(relativeError(solverConstraintForces(scene, p, v), expected), TOLERANCE)
          << surfaceTypeName(surface.type);
    }
}
