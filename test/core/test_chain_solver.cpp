// The O(n) tridiagonal solve against a dense solve on random chains; its residual on a long
// straight chain; structure detection; singular systems detected and kept finite.
#include "constrained_particles/core/simulator.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

using namespace constrained_particles;
using constrained_particles::testing::computeAccelerations;
using constrained_particles::testing::Random;

namespace
{
struct Evaluation
{
  Points accelerations;
  Eigen::VectorXd multipliers;
  SolveReport report;
};

Evaluation evaluate(const Scene& scene, SolveMethod method, const Points& p, const Points& v)
{
  const Model model = Model::compile(scene, method);
  EXPECT_EQ(model.solveMethod(), method);
  Data data(model);
  Evaluation e;
  e.report = computeAccelerations(model, data, p, v, e.accelerations);
  e.multipliers = data.multipliers;
  return e;
}

// A chain with random masses, link vectors of random length (off the manifold) and random
// velocities, under gravity, damping and an external force.
Scene randomChain(int n, bool pin_first, Random& random, Points& p, Points& v)
{
  Scene scene;
  p.resize(3, n);
  v.resize(3, n);
  p.col(0) = random.vector(1.0);
  for (int i = 0; i < n; ++i)
  {
    scene.masses.push_back(random.uniform(0.1, 10.0));
    if (i > 0)
      p.col(i) = p.col(i - 1) + random.uniform(0.4, 0.6) * random.unitVector();
    v.col(i) = random.vector(1.0);
  }
  for (int i = 0; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, 0.5 });
  if (pin_first)
  {
    scene.constraints.push_back(PinConstraint{ 0, Vec3(p.col(0)) });
    v.col(0).setZero();
  }
  scene.forces = { GravityForce{}, LinearDampingForce{ 0.3 },
                   ExternalForce{ n - 1, Vec3(1.0, -2.0, 0.5) } };
  return scene;
}

}  // namespace

TEST(ChainSolver, TridiagonalMatchesDenseOnRandomChains)
{
  Random random(21);
  for (int n : { 2, 3, 10, 100, 1000 })
    for (bool pin_first : { false, true })
    {
      Points p, v;
      const Scene scene = randomChain(n, pin_first, random, p, v);
      const Evaluation fast = evaluate(scene, SolveMethod::Tridiagonal, p, v);
      const Evaluation dense = evaluate(scene, SolveMethod::Dense, p, v);
      const Evaluation sparse = evaluate(scene, SolveMethod::Sparse, p, v);
      EXPECT_FALSE(fast.report.singular);
      const double scale = dense.multipliers.norm();
      EXPECT_LE((fast.multipliers - dense.multipliers).norm(), 1e-9 * scale) << n;
      EXPECT_LE((sparse.multipliers - dense.multipliers).norm(), 1e-9 * scale) << n;
      EXPECT_LE((fast.accelerations - dense.accelerations).norm(),
                1e-9 * dense.accelerations.norm())
          << n;
    }
}

TEST(ChainSolver, SurfaceChainIsTridiagonalAndMatchesDense)
{
  SceneDescription description =
      constrained_particles::testing::shippedDescription("surface_chain");
  setChains(description, constrained_particles::testing::chainOf(50));
  setFirstSurface(description, makeSurface("waves", { 0.3, 2.0, 1.0 }));
  const BuiltScene scenario = buildScene(description);
  EXPECT_EQ(Model::compile(scenario.scene).solveMethod(), SolveMethod::Tridiagonal);
  Random random(22);
  Points p = scenario.initial_state.positions, v = scenario.initial_state.velocities;
  for (int i = 0; i < p.cols(); ++i)
    v.col(i) += random.vector(0.5);
  const Evaluation fast = evaluate(scenario.scene, SolveMethod::Tridiagonal, p, v);
  const Evaluation dense = evaluate(scenario.scene, SolveMethod::Dense, p, v);
  EXPECT_LE((fast.multipliers - dense.multipliers).norm(), 1e-9 * dense.multipliers.norm());
}

TEST(ChainSolver, StructureDetection)
{
  // one row (the bead) is solved in closed form; chains are tridiagonal
  for (const std::string& name : constrained_particles::testing::seedSceneNames())
  {
    const BuiltScene scenario = constrained_particles::testing::shippedScene(name);
    EXPECT_EQ(Model::compile(scenario.scene).solveMethod(),
              name == "bead" ? SolveMethod::Single : SolveMethod::Tridiagonal)
        << name;
  }
  // a closed ring couples the first and last rows: not tridiagonal
  Scene ring;
  ring.masses.assign(6, 1.0);
  for (int i = 0; i < 6; ++i)
    ring.constraints.push_back(LinkConstraint{ i, (i + 1) % 6, 1.0 });
  EXPECT_EQ(Model::compile(ring).solveMethod(), SolveMethod::Sparse);
  EXPECT_THROW(Model::compile(ring, SolveMethod::Tridiagonal), InvalidInput);
  // no constraints: nothing to solve
  Scene free_particles;
  free_particles.masses = { 1.0, 2.0 };
  EXPECT_EQ(Model::compile(free_particles).solveMethod(), SolveMethod::None);
}

// Straight chain, cos(theta) = -1 everywhere: J W J^T = (l^2/m) tridiag(-1, 2, -1), condition
// number ~ n^2. Pulled at both ends by T at rest, every link carries tension T: lambda = -T / l.
TEST(ChainSolver, StraightChainOf10000HasSmallResidual)
{
  const int n = 10000;
  const double l = 0.01, tension = 10.0;
  Scene scene;
  scene.masses.assign(n, 0.1);
  for (int i = 0; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, l });
  scene.forces = { ExternalForce{ 0, Vec3(-tension, 0, 0) },
                   ExternalForce{ n - 1, Vec3(tension, 0, 0) } };
  Points p(3, n), v = Points::Zero(3, n);
  for (int i = 0; i < n; ++i)
    p.col(i) = Vec3(i * l, 0, 0);
  const Model model = Model::compile(scene);
  ASSERT_EQ(model.solveMethod(), SolveMethod::Tridiagonal);
  Data data(model);
  Points a(3, n);
  const SolveReport report = computeAccelerations(model, data, p, v, a);
  EXPECT_FALSE(report.singular);
  const Eigen::VectorXd lambda = data.multipliers;

  // residual of (J W J^T) lambda = b, b = -J W f
  Eigen::VectorXd product, b;
  // J evaluated anew at these positions: the fused stages store only each link's first block
  RowData rows;
  rows.resize(model);
  evaluateRowRecords(model, 0.0, p, v, rows, nullptr);
  multiplyJWJt(model, rows, lambda, product);
  multiplyJacobianInverseMass(model, rows, data.applied_forces, b);
  b = -b;
  const double residual = (product - b).norm() / (b.norm() + product.norm());
  EXPECT_LE(residual, 1e-13);
  // forward error can grow with the condition number (~4e7)
  EXPECT_LE((lambda.array() + tension / l).abs().maxCoeff(), 1e-6 * tension / l);
  EXPECT_LE(a.norm(), 1e-6);
}

// Taut between two pins, a straight chain has one redundant constraint: J W J^T is singular.
TEST(ChainSolver, RedundantConstraintsAreReportedSingularAndStayFinite)
{
  const int n = 8;
  Scene scene = constrained_particles::testing::pinnedChain(std::vector<double>(n, 1.0), 1.0);
  scene.constraints.push_back(PinConstraint{ n - 1, Vec3(n - 1.0, 0, 0) });
  Points p(3, n), v = Points::Zero(3, n);
  for (int i = 0; i < n; ++i)
    p.col(i) = Vec3(i, 0, 0);
  for (SolveMethod method : { SolveMethod::Tridiagonal, SolveMethod::Sparse, SolveMethod::Dense })
  {
    const Evaluation e = evaluate(scene, method, p, v);
    EXPECT_TRUE(e.report.singular) << solveMethodName(method);
    EXPECT_GT(e.report.regularization, 0.0);
    EXPECT_LT(e.report.min_pivot_ratio, SINGULAR_PIVOT_RATIO);
    EXPECT_TRUE(e.accelerations.allFinite());
    EXPECT_TRUE(e.multipliers.allFinite());
  }
}

// A link between two pinned particles is a zero row: singular, finite, no motion.
TEST(ChainSolver, RowBetweenPinnedParticlesStaysFinite)
{
  Scene scene;
  scene.masses = { 1.0, 1.0 };
  scene.constraints = { LinkConstraint{ 0, 1, 1.0 }, PinConstraint{ 0, Vec3(0, 0, 0) },
                        PinConstraint{ 1, Vec3(1, 0, 0) } };
  scene.forces = { GravityForce{} };
  Points p(3, 2), v = Points::Zero(3, 2);
  p << 0, 1, 0, 0, 0, 0;
  const Evaluation e = evaluate(scene, SolveMethod::Tridiagonal, p, v);
  EXPECT_TRUE(e.report.singular);
  EXPECT_TRUE(e.accelerations.isZero(0.0));
  EXPECT_TRUE(e.multipliers.allFinite());
}
