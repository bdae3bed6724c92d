// A scene evaluates only the effects it lists (per-effect counters), and its solve is chosen by
// its constraint structure: closed form for one row, O(n) for chains and trees, sparse otherwise.
#include "constrained_particles/core/simulator.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

#include <chrono>

using namespace constrained_particles;
using constrained_particles::testing::beadScene;
using constrained_particles::testing::computeAccelerations;
using constrained_particles::testing::pinnedChain;
using constrained_particles::testing::Random;

namespace
{
StepSettings rk4Projection()
{
  StepSettings settings;
  settings.dt = 1e-3;
  settings.integrator = "rk4";
  settings.stabilization = Stabilization::Projection;
  return settings;
}

// A random tree: particle k > 0 hangs by a link from a random earlier particle; some particles
// also slide on a plane; optionally particle 0 is pinned.
Scene randomTree(int n, bool pin_root, Random& random, Points& p, Points& v)
{
  Scene scene;
  scene.surfaces = { makeSurface(SurfaceType::Plane, { 0.1, -0.2, -5.0 }) };
  p.resize(3, n);
  v.resize(3, n);
  p.col(0) = random.vector(1.0);
  v.col(0) = random.vector(1.0);
  scene.masses.push_back(random.uniform(0.1, 10.0));
  for (int k = 1; k < n; ++k)
  {
    const int parent = static_cast<int>(random.uniform(0.0, k - 1e-9));
    p.col(k) = p.col(parent) + random.uniform(0.4, 0.6) * random.unitVector();
    v.col(k) = random.vector(1.0);
    scene.masses.push_back(random.uniform(0.1, 10.0));
    scene.constraints.push_back(LinkConstraint{ parent, k, 0.5 });
  }
  // a leaf-only surface row keeps the graph a forest (one more row per chosen particle)
  for (int k = 1; k < n; k += 7)
    scene.constraints.push_back(SurfaceConstraint{ k, 0 });
  if (pin_root)
  {
    scene.constraints.push_back(PinConstraint{ 0, Vec3(p.col(0)) });
    v.col(0).setZero();
  }
  scene.forces = { GravityForce{}, LinearDampingForce{ 0.2 } };
  return scene;
}

struct Solved
{
  Eigen::VectorXd multipliers;
  SolveReport report;
  bool tree_rows = false;  // the tree solve eliminated rows (Model::solvesTreeByRows())
};

Solved solve(const Scene& scene, SolveMethod method, const Points& p, const Points& v,
             StagePaths paths = StagePaths::Specialized)
{
  const Model model = Model::compile(scene, method, paths);
  Data data(model);
  Points a(3, p.cols());
  Solved s;
  s.report = computeAccelerations(model, data, p, v, a);
  s.multipliers = data.multipliers;
  s.tree_rows = model.solvesTreeByRows();
  return s;
}

}  // namespace

TEST(EffectCounters, ASceneEvaluatesOnlyTheEffectsItLists)
{
  for (const std::string& name : constrained_particles::testing::seedSceneNames())
  {
    SceneDescription description = constrained_particles::testing::shippedDescription(name);
    setGravityAndDamping(description, sceneGravity(description), 0.1);
    const BuiltScene scenario = buildScene(description);
    Simulator simulator(scenario.scene, scenario.initial_state, rk4Projection());
    simulator.step(10);
    const EffectCounters& c = simulator.effectCounters();
    // listed: evaluated every step; not listed: never
    EXPECT_GT(c.forceCount<GravityForce>(), 0u) << name;
    EXPECT_GT(c.forceCount<LinearDampingForce>(), 0u) << name;
    EXPECT_EQ(c.forceCount<QuadraticDragForce>(), 0u) << name;
    EXPECT_EQ(c.forceCount<SpringForce>(), 0u) << name;
    EXPECT_EQ(c.forceCount<ExternalForce>(), 0u) << name;
    const bool has_surface = name != "chain";
    const bool has_links = name != "bead";
    EXPECT_EQ(c.constraintCount<SurfaceConstraint>() > 0, has_surface) << name;
    EXPECT_EQ(c.constraintCount<LinkConstraint>() > 0, has_links) << name;
    EXPECT_EQ(c.constraintCount<PinConstraint>() > 0, name == "chain") << name;
    // the lone bead never assembles or factorises a matrix
    if (name == "bead")
    {
      for (SolveMethod method :
           { SolveMethod::Tridiagonal, SolveMethod::Sparse, SolveMethod::Dense, SolveMethod::Tree })
        EXPECT_EQ(c.factorizationCount(method), 0u) << solveMethodName(method);
      EXPECT_GT(c.factorizationCount(SolveMethod::Single), 0u);
    }
  }
}

TEST(EffectCounters, DragSceneEvaluatesDragAndNoConstraints)
{
  Scene scene;
  scene.masses = { 0.5 };
  scene.forces = { GravityForce{}, QuadraticDragForce{ 0.01 } };
  State state;
  state.positions = Points::Zero(3, 1);
  state.velocities = Points::Constant(3, 1, 2.0);
  Simulator simulator(scene, state, rk4Projection());
  simulator.step(5);
  const EffectCounters& c = simulator.effectCounters();
  EXPECT_EQ(c.forceCount<QuadraticDragForce>(), 5u * 4u);  // RK4: four evaluations per step
  EXPECT_EQ(c.forceCount<GravityForce>(), 5u * 4u);
  for (int k = 0; k < NUM_CONSTRAINT_KINDS; ++k)
    EXPECT_EQ(c.constraints[k], 0u);
  for (int k = 0; k < NUM_SOLVE_METHODS; ++k)
    EXPECT_EQ(c.factorizations[k], 0u);
}

TEST(EffectCounters, BeadCostDoesNotGrowWithChainParameters)
{
  // chain parameters cannot reach a scene without chains (the node's ~set_chain is refused)...
  ChainChange huge;
  huge.num_particles = 100000;
  huge.link_length = 3.0;
  SceneDescription bead_file = constrained_particles::testing::shippedDescription("bead");
  EXPECT_THROW(setChains(bead_file, huge), InvalidInput);
  // ...and the bead costs one surface row per evaluation: 100 steps of RK4 + projection
  const BuiltScene bead = constrained_particles::testing::shippedScene("bead");
  ASSERT_EQ(bead.scene.masses.size(), 1u);
  Simulator simulator(bead.scene, bead.initial_state, rk4Projection());
  simulator.step(100);
  const EffectCounters& counters = simulator.effectCounters();
  EXPECT_LT(counters.constraintCount<SurfaceConstraint>(), 100u * 20u);
  for (SolveMethod matrix :
       { SolveMethod::Tridiagonal, SolveMethod::Tree, SolveMethod::Sparse, SolveMethod::Dense })
    EXPECT_EQ(counters.factorizationCount(matrix), 0u);  // a closed form, no matrix
}

TEST(SolveSelection, ChosenByConstraintStructure)
{
  Random random(31);
  Points p, v;
  EXPECT_EQ(Model::compile(beadScene(Surface{})).solveMethod(), SolveMethod::Single);
  EXPECT_EQ(Model::compile(pinnedChain({ 1.0, 1.0, 1.0 }, 0.5)).solveMethod(),
            SolveMethod::Tridiagonal);
  EXPECT_EQ(Model::compile(randomTree(40, true, random, p, v)).solveMethod(), SolveMethod::Tree);
  // two chains hanging from one particle: a star, not tridiagonal
  Scene star;
  star.masses.assign(7, 1.0);
  for (int k = 1; k < 7; ++k)
    star.constraints.push_back(LinkConstraint{ 0, k, 1.0 });
  EXPECT_EQ(Model::compile(star).solveMethod(), SolveMethod::Tree);
  // the one choice names the elimination the structure took: a hub under 6 links keeps the
  // block elimination, one under 3 eliminates its rows; on the generic stages, blocks
  EXPECT_EQ(solveAlgorithmName(Model::compile(star)), "tree (by particles)");
  Scene forked;
  forked.masses.assign(4, 1.0);
  for (int k = 1; k < 4; ++k)
    forked.constraints.push_back(LinkConstraint{ 0, k, 1.0 });
  const Model forked_model = Model::compile(forked);
  ASSERT_EQ(forked_model.solveMethod(), SolveMethod::Tree);
  EXPECT_EQ(solveAlgorithmName(forked_model), "tree (by rows)");
  EXPECT_EQ(solveAlgorithmName(Model::compile(forked, SolveMethod::Automatic, StagePaths::Generic)),
            "tree (by particles)");
  EXPECT_EQ(solveAlgorithmName(Model::compile(pinnedChain({ 1.0, 1.0, 1.0 }, 0.5))), "tridiagonal");
  // a ring closes a cycle: sparse; asking for the tree solve is refused
  Scene ring;
  ring.masses.assign(5, 1.0);
  for (int i = 0; i < 5; ++i)
    ring.constraints.push_back(LinkConstraint{ i, (i + 1) % 5, 1.0 });
  EXPECT_EQ(Model::compile(ring).solveMethod(), SolveMethod::Sparse);
  EXPECT_THROW(Model::compile(ring, SolveMethod::Tree), InvalidInput);
  EXPECT_THROW(Model::compile(star, SolveMethod::Single), InvalidInput);
  // a cycle through a pinned particle is no cycle: the pin is eliminated
  Scene pinned_ring = ring;
  pinned_ring.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
  EXPECT_TRUE(isForest(Model::compile(pinned_ring, SolveMethod::Dense)));
  EXPECT_FALSE(isForest(Model::compile(ring, SolveMethod::Dense)));
}

TEST(SolveSelection, SingleAndTreeMatchDenseSolves)
{
  Random random(32);
  int row_eliminations = 0;
  for (int trial = 0; trial < 30; ++trial)
  {
    Points p, v;
    const int n = 2 + trial * 3;
    const Scene tree = randomTree(n, trial % 2 == 0, random, p, v);
    const Solved dense = solve(tree, SolveMethod::Dense, p, v);
    // the particle elimination (generic paths) and, where it fits, the row elimination
    for (const StagePaths paths : { StagePaths::Generic, StagePaths::Specialized })
    {
      const Solved fast = solve(tree, SolveMethod::Tree, p, v, paths);
      EXPECT_EQ(fast.report.method, SolveMethod::Tree);
      EXPECT_FALSE(fast.report.singular);
      EXPECT_LE((fast.multipliers - dense.multipliers).norm(), 1e-9 * dense.multipliers.norm())
          << "n = " << n << (fast.tree_rows ? ", rows eliminated" : ", particles eliminated");
      row_eliminations += fast.tree_rows ? 1 : 0;
    }
  }
  EXPECT_GE(row_eliminations, 3);  // the smaller trees: random parents make hubs in the larger
  // one row: closed form
  Points p(3, 1), v(3, 1);
  p.col(0) = Vec3(0.3, -0.2, 0.1);
  v.col(0) = Vec3(0.5, 0.7, 0.0);
  const Scene bead = beadScene(makeSurface(SurfaceType::Waves, { 0.3, 2.0, 1.0 }));
  const Solved single = solve(bead, SolveMethod::Single, p, v);
  const Solved dense = solve(bead, SolveMethod::Dense, p, v);
  EXPECT_NEAR(single.multipliers[0], dense.multipliers[0], 1e-12 * std::abs(dense.multipliers[0]));
}

TEST(SolveSelection, TreeSolveHandlesLargeStarsAndStaysFiniteWhenSingular)
{
  // a star of k links on one particle: J W J^T is dense (k^2 entries), the tree solve is O(k)
  auto star = [](int k, Points& p, Points& v)
  {
    Scene scene;
    scene.masses.assign(k + 1, 1.0);
    p.setZero(3, k + 1);
    v.setZero(3, k + 1);
    for (int j = 1; j <= k; ++j)
    {
      const double angle = 2.0 * M_PI * j / k;
      p.col(j) = Vec3(std::cos(angle), std::sin(angle), 0.0);
      v.col(j) = Vec3(0.0, 0.0, 0.1 * j);
      scene.constraints.push_back(LinkConstraint{ 0, j, 1.0 });
    }
    scene.forces = { GravityForce{} };
    return scene;
  };
  Points p, v;
  const Scene small = star(10, p, v);
  const Solved tree = solve(small, SolveMethod::Tree, p, v);
  const Solved dense = solve(small, SolveMethod::Dense, p, v);
  EXPECT_FALSE(tree.tree_rows);  // ten rows on the hub: its rows' block would be dense
  EXPECT_LE((tree.multipliers - dense.multipliers).norm(), 1e-10 * dense.multipliers.norm());
  // 20,000 links on one particle: J W J^T would have 4e8 entries; the tree solve needs none
  const Scene large = star(20000, p, v);
  const Model model = Model::compile(large);
  EXPECT_EQ(model.solveMethod(), SolveMethod::Tree);
  Data data(model);
  Points a(3, p.cols());
  computeAccelerations(model, data, p, v, a);
  EXPECT_TRUE(data.multipliers.allFinite());
  EXPECT_EQ(data.counters.factorizationCount(SolveMethod::Tree), 1u);
  // a link between two pinned particles touches no free particle: singular, regularised, finite
  Scene stuck;
  stuck.masses = { 1.0, 1.0, 1.0 };
  stuck.constraints = { LinkConstraint{ 0, 1, 1.0 }, LinkConstraint{ 1, 2, 1.0 },
                        PinConstraint{ 0, Vec3::Zero() }, PinConstraint{ 1, Vec3(1, 0, 0) } };
  Points ps(3, 3), vs = Points::Zero(3, 3);
  ps << 0, 1, 2, 0, 0, 0, 0, 0, 0;
  for (const StagePaths paths : { StagePaths::Generic, StagePaths::Specialized })
  {
    const Solved regularised = solve(stuck, SolveMethod::Tree, ps, vs, paths);
    EXPECT_EQ(regularised.tree_rows, paths == StagePaths::Specialized);
    EXPECT_TRUE(regularised.report.singular);
    EXPECT_TRUE(regularised.multipliers.allFinite());
  }
}

// The row elimination (Model::solvesTreeByRows()) is taken where every free particle has at most
// four rows and every row at most two free particles, on the specialised paths only; it solves what
// the particle elimination solves, singular systems (regularised alike) included.
TEST(SolveSelection, TheTreeEliminatesRowsWhereParticlesHaveFewRows)
{
  // particle k hangs from (k - 1) / 2: three rows on every inner particle, the root pinned
  auto binaryTree = [](int n, Points& p, Points& v)
  {
    Scene scene;
    scene.masses.assign(n, 0.1);
    p.setZero(3, n);
    v.setZero(3, n);
    for (int k = 1; k < n; ++k)
    {
      const int parent = (k - 1) / 2;
      const double angle = 2.0 * M_PI * k / n;
      p.col(k) = p.col(parent) + 0.1 * Vec3(std::cos(angle), std::sin(angle), -1.0).normalized();
      v.col(k) = Vec3(0.1 * std::sin(3.0 * k), 0.2, -0.1 * std::cos(k));
      scene.constraints.push_back(LinkConstraint{ parent, k, 0.1 });
    }
    scene.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
    scene.forces = { GravityForce{} };
    return scene;
  };
  Points p, v;
  Scene tree = binaryTree(63, p, v);
  EXPECT_TRUE(Model::compile(tree).solvesTreeByRows());
  EXPECT_FALSE(
      Model::compile(tree, SolveMethod::Automatic, StagePaths::Generic).solvesTreeByRows());
  EXPECT_FALSE(Model::compile(tree, SolveMethod::Sparse).solvesTreeByRows());
  const Solved rows = solve(tree, SolveMethod::Tree, p, v);
  const Solved particles = solve(tree, SolveMethod::Tree, p, v, StagePaths::Generic);
  ASSERT_TRUE(rows.tree_rows);
  ASSERT_FALSE(particles.tree_rows);
  EXPECT_LE((rows.multipliers - particles.multipliers).norm(),
            1e-12 * particles.multipliers.norm());
  EXPECT_EQ(rows.report.singular, false);
  EXPECT_GT(rows.report.min_pivot_ratio, 0.0);
  EXPECT_LT(rows.report.min_pivot_ratio, 1.0);
  // a plane under particles 1 and 2 makes four rows on each: rows still
  tree.surfaces = { makeSurface(SurfaceType::Plane, { 0.0, 0.0, 0.0 }) };
  tree.constraints.push_back(SurfaceConstraint{ 1, 0 });
  tree.constraints.push_back(SurfaceConstraint{ 2, 0 });
  EXPECT_TRUE(Model::compile(tree).solvesTreeByRows());
  // a fifth row on particle 1: its particles' elimination again
  tree.constraints.push_back(PointOnPlaneConstraint{ 1, Vec3(p.col(1)), Vec3(1.0, 0.0, 0.0) });
  EXPECT_FALSE(Model::compile(tree).solvesTreeByRows());
  // singular: particle 2's link to the pinned root along a line with a second pinned particle
  Scene taut;
  taut.masses = { 1.0, 1.0, 1.0, 1.0 };
  taut.constraints = { LinkConstraint{ 0, 1, 1.0 }, LinkConstraint{ 1, 2, 1.0 },
                       LinkConstraint{ 1, 3, 1.0 }, PinConstraint{ 0, Vec3::Zero() },
                       PinConstraint{ 2, Vec3(2.0, 0.0, 0.0) } };
  Points pt(3, 4), vt = Points::Zero(3, 4);
  pt << 0, 1, 2, 1, 0, 0, 0, 0, 0, 0, 0, -1;
  vt(2, 3) = 0.5;
  const Solved singular_rows = solve(taut, SolveMethod::Tree, pt, vt);
  const Solved singular_particles = solve(taut, SolveMethod::Tree, pt, vt, StagePaths::Generic);
  const Solved singular_dense = solve(taut, SolveMethod::Dense, pt, vt);
  ASSERT_TRUE(singular_rows.tree_rows);
  EXPECT_TRUE(singular_rows.report.singular);
  EXPECT_TRUE(singular_particles.report.singular);
  EXPECT_TRUE(singular_dense.report.singular);
  EXPECT_TRUE(singular_rows.multipliers.allFinite());
  // the two tree solves regularise alike (delta from the largest w_i |J_ri|^2)
  EXPECT_EQ(singular_rows.report.regularization, singular_particles.report.regularization);
  EXPECT_LE((singular_rows.multipliers - singular_particles.multipliers).norm(),
            1e-9 * singular_particles.multipliers.norm());
}

// step(count) reports the worst and the totals over all its steps, not only the last: the same
// as merging count single steps.
TEST(StepStatistics, BatchIsTheMergeOfItsSteps)
{
  const BuiltScene chain = constrained_particles::testing::shippedScene(
      "chain", constrained_particles::testing::chainOf(12, 0.1, 0.1));
  for (const char* integrator : { "rk4", "velocity_verlet", "dopri5" })
  {
    StepSettings settings;
    settings.integrator = integrator;
    settings.dt = 2e-3;
    Simulator batch(chain.scene, chain.initial_state, settings);
    Simulator single(chain.scene, chain.initial_state, settings);
    const StepStatistics merged = batch.step(40);
    StepStatistics sum;
    double worst_pivot = 1.0;
    int worst_iterations = 0;
    bool all_converged = true;
    for (int k = 0; k < 40; ++k)
    {
      const StepStatistics one = single.step();
      sum.steps += one.steps;
      sum.solve.factorizations += one.solve.factorizations;
      sum.solve.singular_count += one.solve.singular_count;
      sum.projection.projections += one.projection.projections;
      sum.projection.iterations += one.projection.iterations;
      sum.internal_steps += one.internal_steps;
      sum.rejected_internal_steps += one.rejected_internal_steps;
      for (int f = 0; f < NUM_FORCE_KINDS; ++f)
        sum.effects.forces[f] += one.effects.forces[f];
      for (int c = 0; c < NUM_CONSTRAINT_KINDS; ++c)
        sum.effects.constraints[c] += one.effects.constraints[c];
      worst_pivot = std::min(worst_pivot, one.solve.min_pivot_ratio);
      worst_iterations = std::max(worst_iterations, one.projection.max_iterations);
      all_converged = all_converged && one.projection.converged;
    }
    EXPECT_EQ(batch.state().positions, single.state().positions) << integrator;
    EXPECT_EQ(merged.steps, 40) << integrator;
    EXPECT_EQ(merged.solve.factorizations, sum.solve.factorizations) << integrator;
    EXPECT_GT(merged.solve.factorizations, 40) << integrator;
    EXPECT_EQ(merged.solve.singular_count, sum.solve.singular_count) << integrator;
    EXPECT_EQ(merged.solve.min_pivot_ratio, worst_pivot) << integrator;
    EXPECT_LT(merged.solve.min_pivot_ratio, 1.0) << integrator;
    EXPECT_EQ(merged.projection.projections, sum.projection.projections) << integrator;
    EXPECT_EQ(merged.projection.iterations, sum.projection.iterations) << integrator;
    EXPECT_EQ(merged.projection.max_iterations, worst_iterations) << integrator;
    EXPECT_EQ(merged.projection.converged, all_converged) << integrator;
    EXPECT_EQ(merged.internal_steps, sum.internal_steps) << integrator;
    EXPECT_EQ(merged.rejected_internal_steps, sum.rejected_internal_steps) << integrator;
    EXPECT_EQ(merged.effects.forces, sum.effects.forces) << integrator;
    EXPECT_EQ(merged.effects.constraints, sum.effects.constraints) << integrator;
  }
}

// A particle whose own rows (a wire, a plane) all but lock it along the link to its parent: the
// tree elimination cannot subtract that mobility without losing its digits, so it hands the solve
// to the sparse LDL^T (reported as a fallback). Random forests with such rows on any particle,
// and a wire perpendicular to its link, match the dense solve, and so does their motion.
TEST(SolveSelection, TreeMatchesDenseWhenParticlesCarryTheirOwnRows)
{
  Random random(33);
  int fallbacks = 0, row_eliminations = 0;
  for (int trial = 0; trial < 40; ++trial)
  {
    Points p, v;
    Scene scene = randomTree(2 + trial % 12, trial % 3 == 0, random, p, v);
    // wires and planes on random particles, some across the link to their parent
    for (int k = 1; k < static_cast<int>(scene.masses.size()); k += 1 + trial % 3)
    {
      const auto& link = std::get<LinkConstraint>(scene.constraints[k - 1]);
      const Vec3 along = p.col(link.second) - p.col(link.first);
      const Vec3 across = along.cross(random.unitVector());
      if (trial % 2 == 0)
        scene.constraints.push_back(PointOnLineConstraint{ k, Vec3(p.col(k)), across });
      else
        scene.constraints.push_back(PointOnPlaneConstraint{ k, Vec3(p.col(k)), along });
    }
    if (!isForest(Model::compile(scene, SolveMethod::Dense)))
      continue;
    const Solved dense = solve(scene, SolveMethod::Dense, p, v);
    // the particle elimination (generic paths) and, where it fits, the row elimination, which
    // has no such breakdown: a particle's own rows are rows like the others
    for (const StagePaths paths : { StagePaths::Generic, StagePaths::Specialized })
    {
      const Solved tree = solve(scene, SolveMethod::Tree, p, v, paths);
      fallbacks += tree.report.fallback ? 1 : 0;
      row_eliminations += tree.tree_rows ? 1 : 0;
      EXPECT_FALSE(tree.tree_rows && tree.report.fallback) << trial;
      EXPECT_EQ(tree.report.singular, dense.report.singular) << trial;
      if (!dense.report.singular)
      {
        EXPECT_LE((tree.multipliers - dense.multipliers).norm(),
                  1e-8 * (1.0 + dense.multipliers.norm()))
            << "trial " << trial << (tree.tree_rows ? ", rows eliminated" : "");
      }
    }
  }
  EXPECT_GT(fallbacks, 0);  // the cases that need it occur
  EXPECT_GT(row_eliminations, 10);

  // a free particle linked to one on a wire: tree (automatic) and dense move alike for 3 s
  Scene wire;
  wire.masses = { 0.4, 0.9 };
  wire.forces = { GravityForce{} };
  wire.constraints = { PointOnLineConstraint{ 1, Vec3(0.9, 0.2, 1.1), Vec3(1.0, 0.3, 0.2) },
                       LinkConstraint{ 0, 1, 0.55 } };
  State start;
  start.positions.resize(3, 2);
  start.positions << 0.6, 0.9, -0.1, 0.2, 1.45, 1.1;
  start.velocities = Points::Zero(3, 2);
  start.velocities(2, 1) = 0.3;
  StepSettings settings;
  settings.stabilization = Stabilization::None;
  Simulator automatic(wire, start, settings);
  Simulator dense(wire, start, settings, SolveMethod::Dense);
  EXPECT_EQ(automatic.model().solveMethod(), SolveMethod::Tree);
  automatic.step(3000);
  dense.step(3000);
  EXPECT_TRUE(isFinite(automatic.state()));
  EXPECT_LE((automatic.state().positions - dense.state().positions).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LE(automatic.diagnostics().max_position_error, 1e-6);
}
