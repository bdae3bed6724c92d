// The structure-specialised stages (issue 17) against the generic ones: every shipped scene and
// random chains, stepped both ways for 1,000 steps, follow the same trajectory exactly (trees, in
// row space, to 1e-12: another order of the same sums) and
// move the same effect counters, solve statistics and step checks (but for the factorisations a
// fused step's first stage reuses from its projection, counted apart). A singular chain takes the
// generic regularised solve from the fused path and still agrees.
#include "same_motion.hpp"
#include "stabilization.hpp"
#include "test_helpers.hpp"

#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

using namespace constrained_particles;
using constrained_particles::testing::difference;
using constrained_particles::testing::expectSameMotion;

namespace
{
const std::string DIRECTORY = SCENES_DIR;

// The height fields random chains slide on: one of each family's shapes.
const std::vector<std::pair<std::string, std::vector<double>>> RANDOM_SURFACES = {
  { "bowl", { 1.0, 0.6 } },
  { "saddle", { 0.8, 0.5 } },
  { "waves", { 0.2, 2.0, 1.5 } },
  { "plane", { 0.3, -0.2, 0.1 } },
};

// A random case on surfaces, stepped both ways for 1,000 steps: it must move, and where the
// fused stages apply (not with Baumgarte's bias) the model takes them with `surface_rows` surface
// rows. Returns whether the fused stages ran: a fused model, no Baumgarte bias, and an integrator
// that evaluates stages (velocity Verlet and fast projection hold the constraints themselves).
bool expectSurfaceCaseSame(const Scene& scene, const State& start, const StepSettings& settings,
                           int surface_rows, const std::string& what)
{
  double moved = 0.0;
  const std::string named = what + " (" + settings.integrator + ")";
  const bool took = expectSameMotion(scene, start, settings, SolveMethod::Automatic, named, 1000,
                                     nullptr, &moved);
  EXPECT_GT(moved, 1e-2) << named;
  if (settings.stabilization == Stabilization::Baumgarte)
    return false;
  Simulator probe(scene, start, settings);
  EXPECT_TRUE(probe.model().fusedChain()) << named;
  EXPECT_EQ(probe.model().chainSurfaceRows(), surface_rows) << named;
  return took && !findIntegrator(settings.integrator).holds_constraints;
}

// Case c's integrator and stabilisation: every one in turn, dt = 1 ms.
StepSettings caseSettings(int c)
{
  const std::vector<std::string> integrators = integratorNames();
  StepSettings settings;
  settings.integrator = integrators[c % integrators.size()];
  settings.stabilization = static_cast<Stabilization>((c / 2) % 3);
  settings.dt = 1e-3;
  return settings;
}

}  // namespace

TEST(StagePaths, EveryShippedSceneMovesTheSameBothWays)
{
  int fused = 0;
  for (const std::string& name : listScenes(DIRECTORY))
  {
    const SceneDescription description = loadSceneFile(DIRECTORY + "/" + name + ".yaml");
    const BuiltScene built = buildScene(description);
    const StepSettings settings = description.solver.applyTo(StepSettings{});
    long reused = 0;
    // a rope piling onto itself is chaotic: once its links meet (its first link pairs come at
    // 0.38 s) its impacts on itself grow the paths' rounding differences (1.4e-11 m/s by 0.4 s,
    // over this test's 1e-11 (1 + moved)), so it is compared over its first 0.3 s
    const int steps = name == "rope_pile" ? 300 : 1000;
    const bool took =
        expectSameMotion(built.scene, built.initial_state, settings,
                         description.solver.solve_method, name, steps, nullptr, nullptr, &reused);
    fused += took;
    // a chain under a bead (seed problem 3) takes the fused stages with its surface row, two
    // chains on one saddle with one each
    if (name == "surface_chain" || name == "two_chains_on_surface")
    {
      EXPECT_TRUE(took) << name;
    }
    // a hub with three chains, all links: the fused tree stages, each step's first stage but the
    // very first (no projected step before it) solving with its projection's factorisation
    if (name == "mobile")
    {
      EXPECT_TRUE(Model::compile(built.scene, description.solver.solve_method).fusedTree());
      EXPECT_EQ(reused, 999) << name;
    }
  }
  // the chains among them (chain, its pinned-both-ends and shaken variants, pinned_pendulum,
  // surface_chain, two_chains_on_surface) take the path
  EXPECT_GE(fused, 6);
}

// Random trees with at most three children a particle, some particles on a plane, the root
// pinned or free: the fused tree stages (Model::fusedTree(), trees of links) and the row
// elimination (Model::solvesTreeByRows()) move them as the particle elimination does, to 1e-12 over
// 1,000 steps, with the same counters.
TEST(StagePaths, RandomTreesMoveTheSameBothWays)
{
  std::mt19937 random(20261203);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const std::vector<std::string> integrators = integratorNames();
  // trees of links take the fused tree stages (Model::fusedTree()), trees with surface rows the
  // generic stages with the solve by rows: both are compared with the solve by particles
  int fused = 0, solved_by_rows = 0;
  for (int c = 0; c < 16; ++c)
  {
    const int n = 4 + static_cast<int>(unit(random) * 20);
    Scene scene;
    State start;
    start.positions.setZero(3, n);
    start.velocities.setZero(3, n);
    std::vector<int> children(n, 0);
    for (int k = 0; k < n; ++k)
    {
      // links of 0.2 to 0.5 m, moving at up to 0.25 m/s: a second of motion, not yet of chaos
      // (a different order of the same sums must not grow past 1e-12 m on its own)
      scene.masses.push_back(0.1 + 2.0 * unit(random));
      start.velocities.col(k) =
          0.5 * Vec3(unit(random) - 0.5, unit(random) - 0.5, unit(random) - 0.5);
      if (k == 0)
        continue;
      // particles 2 and 3 hang from 1, which hangs from 0: three rows on 1, not a chain
      int parent = k < 4 ? (k + 1) / 3 : static_cast<int>(unit(random) * k);
      while (children[parent] == 3)
        parent = (parent + 1) % k;
      ++children[parent];
      const Vec3 step(unit(random) - 0.5, unit(random) - 0.5, -unit(random));
      start.positions.col(k) =
          start.positions.col(parent) + (0.2 + 0.3 * unit(random)) * step.normalized();
      const double length = (start.positions.col(k) - start.positions.col(parent)).norm();
      // either way round (by k, leaving the random draws as they were): a particle is the first
      // of some links and the second of others
      scene.constraints.push_back(k % 2 == 0 ? LinkConstraint{ parent, k, length }
                                             : LinkConstraint{ k, parent, length });
    }
    // a tilted plane through some leaves (z = 0.1 x - 0.2 y + c): at most four rows anywhere
    for (int k = 1; k < n; ++k)
      if (children[k] == 0 && unit(random) < 0.3)
      {
        const Vec3 p = start.positions.col(k);
        scene.surfaces.push_back(
            makeSurface(SurfaceType::Plane, { 0.1, -0.2, p.z() - 0.1 * p.x() + 0.2 * p.y() }));
        scene.constraints.push_back(
            SurfaceConstraint{ k, static_cast<int>(scene.surfaces.size()) - 1 });
      }
    if (c % 2 == 0)
      scene.constraints.push_back(PinConstraint{ 0, Vec3(start.positions.col(0)) });
    scene.forces = { GravityForce{} };
    StepSettings settings;
    settings.integrator = integrators[c % integrators.size()];
    settings.dt = 1e-3;
    const std::string what = "random tree " + std::to_string(c) + " (" + settings.integrator + ")";
    const Simulator probe(scene, start, settings);
    EXPECT_TRUE(probe.model().solvesTreeByRows()) << what;
    EXPECT_EQ(probe.model().fusedTree(), scene.surfaces.empty()) << what;
    ++(probe.model().fusedTree() ? fused : solved_by_rows);
    double moved = 0.0;
    expectSameMotion(scene, probe.state(), settings, SolveMethod::Automatic, what, 1000, nullptr,
                     &moved);
    EXPECT_GT(moved, 1e-3) << what;
  }
  EXPECT_GE(fused, 4);
  EXPECT_GE(solved_by_rows, 4);
  // singular: a taut line between two pins through particle 1, particle 3 below it, moving. Both
  // tree solves regularise alike, but J W J^T + delta I (delta 1e-9 of the diagonal) amplifies
  // their different rounding by about 1 / delta, and near the threshold their pivot ratios (of
  // two matrices) call different steps singular: the motion agrees to 1e-8 m, not 1e-12
  Scene taut;
  taut.masses = { 1.0, 1.0, 1.0, 1.0 };
  taut.constraints = { LinkConstraint{ 0, 1, 1.0 }, LinkConstraint{ 1, 2, 1.0 },
                       LinkConstraint{ 1, 3, 1.0 }, PinConstraint{ 0, Vec3::Zero() },
                       PinConstraint{ 2, Vec3(2.0, 0.0, 0.0) } };
  taut.forces = { GravityForce{} };
  State start;
  start.positions.resize(3, 4);
  start.positions << 0, 1, 2, 1, 0, 0, 0, 0, 0, 0, 0, -1;
  start.velocities = Points::Zero(3, 4);
  start.velocities(1, 3) = 0.5;
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator by_rows(taut, start, settings);
  Simulator by_particles(taut, start, settings, SolveMethod::Automatic, StagePaths::Generic);
  ASSERT_TRUE(by_rows.model().fusedTree());  // its singular pivots go to the solve by rows
  ASSERT_FALSE(by_particles.model().solvesTreeByRows());
  long singular_rows = 0, singular_particles = 0;
  for (int done = 0; done < 1000; done += 100)
  {
    const StepStatistics a = by_rows.step(100);
    const StepStatistics b = by_particles.step(100);
    singular_rows += a.solve.singular_count;
    singular_particles += b.solve.singular_count;
    EXPECT_EQ(a.steps, b.steps);
    EXPECT_EQ(a.failed_check, b.failed_check);
    EXPECT_LE(difference(by_rows.state(), by_particles.state()).positions, 1e-8)
        << "after " << done + 100 << " steps";
  }
  EXPECT_GT(singular_rows, 0);
  EXPECT_GT(singular_particles, 0);
  EXPECT_GT((by_rows.state().positions - start.positions).cwiseAbs().maxCoeff(), 1e-3);
}

// One evaluation of a binary tree of links with a pinned root, a particle no link touches and
// damping besides gravity (so J a0 is summed, not taken as 0): the fused tree stages give the
// generic stages' multipliers, constraint forces and accelerations to rounding.
TEST(StagePaths, TheFusedTreeStagesGiveTheGenericForces)
{
  std::mt19937 random(20261204);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = 64;  // particles 0..62 the tree, 63 alone
  Scene scene;
  State start;
  start.positions.setZero(3, n);
  start.velocities.setZero(3, n);
  for (int k = 0; k < n; ++k)
  {
    scene.masses.push_back(0.1 + unit(random));
    start.velocities.col(k) = Vec3(unit(random) - 0.5, unit(random) - 0.5, unit(random) - 0.5);
    if (k == 0 || k == n - 1)
      continue;
    const int parent = (k - 1) / 2;
    const Vec3 step(unit(random) - 0.5, unit(random) - 0.5, -unit(random));
    start.positions.col(k) = start.positions.col(parent) + 0.3 * step.normalized();
    // either way round: a particle is the first of some links and the second of others
    scene.constraints.push_back(k % 3 == 0 ? LinkConstraint{ k, parent, 0.3 }
                                           : LinkConstraint{ parent, k, 0.3 });
  }
  start.positions.col(n - 1) = Vec3(1.0, 1.0, 1.0);
  scene.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
  scene.forces = { GravityForce{}, LinearDampingForce{ 0.3 } };
  StepSettings settings;
  Simulator fused(scene, start, settings);
  Simulator generic(scene, start, settings, SolveMethod::Automatic, StagePaths::Generic);
  ASSERT_TRUE(fused.model().fusedTree());
  Points f_fused, f_generic;
  Eigen::VectorXd lambda_fused, lambda_generic;
  fused.constraintForces(f_fused, lambda_fused);
  generic.constraintForces(f_generic, lambda_generic);
  ASSERT_EQ(lambda_fused.size(), lambda_generic.size());
  const double lambda_scale = lambda_generic.cwiseAbs().maxCoeff();
  EXPECT_GT(lambda_scale, 1.0);
  EXPECT_LE((lambda_fused - lambda_generic).cwiseAbs().maxCoeff(), 1e-12 * lambda_scale);
  EXPECT_LE((f_fused - f_generic).cwiseAbs().maxCoeff(), 1e-12 * f_generic.cwiseAbs().maxCoeff());
  const Points& a = fused.data().accelerations;
  const Points& b = generic.data().accelerations;
  EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-12 * b.cwiseAbs().maxCoeff());
  // the lone particle falls with damping, and the counters are the generic stages'
  EXPECT_EQ(f_fused.col(n - 1), Vec3::Zero());
  EXPECT_EQ(a.col(n - 1), b.col(n - 1));
  EXPECT_EQ(fused.data().counters.constraints, generic.data().counters.constraints);
  EXPECT_EQ(fused.data().counters.factorizations, generic.data().counters.factorizations);
}

TEST(StagePaths, RandomChainsMoveTheSameBothWays)
{
  std::mt19937 random(20261201);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const std::vector<std::string> integrators = integratorNames();
  int fused = 0;
  for (int c = 0; c < 40; ++c)
  {
    // one or two chains in turn, links either way round, random masses, lengths and pins
    const int chains = 1 + c % 2;
    Scene scene;
    scene.name = "random_chain_" + std::to_string(c);
    State start;
    std::vector<Vec3> positions, velocities;
    int links = 0;
    for (int chain = 0; chain < chains; ++chain)
    {
      const int n = 2 + static_cast<int>(unit(random) * 30);
      const int first = static_cast<int>(positions.size());
      Vec3 p(unit(random), unit(random), unit(random));
      for (int i = 0; i < n; ++i)
      {
        scene.masses.push_back(0.05 + 5.0 * unit(random));
        positions.push_back(p);
        velocities.push_back(Vec3(unit(random) - 0.5, unit(random) - 0.5, unit(random) - 0.5));
        if (i + 1 < n)
        {
          const Vec3 step(unit(random) - 0.5, unit(random) - 0.5, unit(random) - 0.5);
          const double length = 0.05 + 0.3 * unit(random);
          const Vec3 next = p + length * step.normalized();
          const int a = first + i, b = first + i + 1;
          const double l = (next - p).norm();
          if (unit(random) < 0.5)
            scene.constraints.push_back(LinkConstraint{ a, b, l });
          else
            scene.constraints.push_back(LinkConstraint{ b, a, l });
          ++links;
          p = next;
        }
      }
      const double pins = unit(random);
      if (pins < 0.6)
        scene.constraints.push_back(PinConstraint{ first, positions[first] });
      if (pins > 0.4)
        scene.constraints.push_back(PinConstraint{ first + n - 1, positions[first + n - 1] });
      // a held particle inside the chain, under two links (its rows' sums take the held path)
      if (c % 5 == 2 && n >= 6)
        scene.constraints.push_back(PinConstraint{ first + n / 2, positions[first + n / 2] });
    }
    // a particle no link touches, free or pinned: its force is only a reaction (chainUnlinked())
    if (c % 4 == 0 || c % 4 == 3)
    {
      const int loose = static_cast<int>(positions.size());
      scene.masses.push_back(0.5);
      positions.push_back(Vec3(unit(random), unit(random), unit(random)));
      velocities.push_back(Vec3(unit(random) - 0.5, unit(random) - 0.5, unit(random) - 0.5));
      if (c % 4 == 3)
        scene.constraints.push_back(PinConstraint{ loose, positions.back() });
    }
    GravityForce gravity;
    scene.forces = { gravity };
    if (c % 3 == 0)
      scene.forces.push_back(LinearDampingForce{ 0.1 });
    start.positions.resize(3, static_cast<int>(positions.size()));
    start.velocities.resize(3, static_cast<int>(positions.size()));
    for (std::size_t i = 0; i < positions.size(); ++i)
    {
      start.positions.col(static_cast<int>(i)) = positions[i];
      start.velocities.col(static_cast<int>(i)) = velocities[i];
    }
    StepSettings settings;
    settings.integrator = integrators[c % integrators.size()];
    settings.stabilization = static_cast<Stabilization>(c % 3);
    settings.dt = 1e-3;
    // both paths run all 1,000 steps whatever a method gains: the paths are compared here
    settings.energy_budget = 0.0;
    double moved = 0.0;
    const std::string what = scene.name + " (" + settings.integrator + ")";
    long reused = 0;
    const bool took_fused = expectSameMotion(scene, start, settings, SolveMethod::Automatic, what,
                                             1000, nullptr, &moved, &reused);
    fused += took_fused;
    // random velocities: the chains move, so agreeing is not two chains at rest
    EXPECT_GT(moved, 1e-2) << what;
    // projected steps whose first stage is at the step's start reuse the projection's solve
    const bool first_stage_at_start =
        settings.integrator == "rk4" || settings.integrator == "midpoint" ||
        settings.integrator == "explicit_euler" || settings.integrator == "semi_implicit_euler";
    if (took_fused && first_stage_at_start && settings.stabilization == Stabilization::Projection)
      EXPECT_GT(reused, 500) << what;
    else
      EXPECT_EQ(reused, 0) << what;
  }
  // most cases are fused chains (under Baumgarte forward() keeps to the generic stages, and
  // those cases check that the switch is right)
  EXPECT_GE(fused, 30);
}

// Chains whose first particle slides on a height field (row 0 a surface row, then the links):
// random surfaces, masses, lengths and directions, links either way round, sometimes the last
// particle pinned, every integrator and stabilisation.
TEST(StagePaths, RandomChainsOnSurfacesMoveTheSameBothWays)
{
  std::mt19937 random(20261202);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto& surfaces = RANDOM_SURFACES;
  int fused = 0;
  for (int c = 0; c < 24; ++c)
  {
    Scene scene;
    scene.name = "random_surface_chain_" + std::to_string(c);
    const auto& [type, coefficients] = surfaces[c % surfaces.size()];
    scene.surfaces = { makeSurface(type, coefficients) };
    const int n = 2 + static_cast<int>(unit(random) * 20);
    State start;
    start.positions.resize(3, n);
    start.velocities.resize(3, n);
    Vec3 p(unit(random) - 0.5, unit(random) - 0.5, 0.0);
    p.z() = evaluateSurface(scene.surfaces[0], p.x(), p.y()).z;
    scene.constraints.push_back(SurfaceConstraint{ 0, 0 });
    for (int i = 0; i < n; ++i)
    {
      scene.masses.push_back(0.05 + 2.0 * unit(random));
      start.positions.col(i) = p;
      start.velocities.col(i) = Vec3(unit(random) - 0.5, unit(random) - 0.5, unit(random) - 0.5);
      if (i + 1 < n)
      {
        // hanging below the bead, each link leaning a random way
        const Vec3 step(unit(random) - 0.5, unit(random) - 0.5, -1.0);
        const double length = 0.05 + 0.2 * unit(random);
        const Vec3 next = p + length * step.normalized();
        const double l = (next - p).norm();
        if (unit(random) < 0.5)
          scene.constraints.push_back(LinkConstraint{ i, i + 1, l });
        else
          scene.constraints.push_back(LinkConstraint{ i + 1, i, l });
        p = next;
      }
    }
    if (c % 4 == 3 && n > 2)
      scene.constraints.push_back(PinConstraint{ n - 1, p });
    scene.forces = { GravityForce{} };
    if (c % 3 == 0)
      scene.forces.push_back(LinearDampingForce{ 0.1 });
    fused += expectSurfaceCaseSame(scene, start, caseSettings(c), n > 1 ? 1 : 0,
                                   scene.name + ", " + type + ", n = " + std::to_string(n));
  }
  EXPECT_GE(fused, 10);
}

// Several chains in one scene, each free (its first particle sometimes pinned), with its first
// particle on a surface, its last (the surface row then below its chain's links, coupled to the
// link above it), both, or a lone bead: surface rows anywhere in the row order, between and next
// to links and held particles. Random surfaces, masses, lengths and directions; the integrators
// that evaluate stages, with projection or none (so that every case runs the fused stages); a
// spring between two chains' ends.
TEST(StagePaths, RandomChainsOnSeveralSurfacesMoveTheSameBothWays)
{
  std::mt19937 random(20261203);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto& surfaces = RANDOM_SURFACES;
  std::vector<std::string> integrators;
  for (const std::string& name : integratorNames())
    if (!findIntegrator(name).holds_constraints)
      integrators.push_back(name);
  int fused = 0, below = 0;
  for (int c = 0; c < 24; ++c)
  {
    Scene scene;
    scene.name = "random_surface_chains_" + std::to_string(c);
    for (int k = 0; k < 2; ++k)
    {
      const auto& [type, coefficients] = surfaces[(c + k) % surfaces.size()];
      scene.surfaces.push_back(makeSurface(type, coefficients));
    }
    const int chains = 2 + c % 3;
    std::vector<Vec3> positions, velocities;
    std::vector<int> ends;
    int surface_rows = 0;
    for (int chain = 0; chain < chains; ++chain)
    {
      // 0: free; 1: first particle on a surface (its row before its links); 2: last particle on
      // one (its row after them); 3: both; 4: a lone bead
      const int on = (c + 2 * chain) % 5;
      const bool first_on = on == 1 || on == 3 || on == 4, last_on = on == 2 || on == 3;
      const int n = on == 4 ? 1 : 2 + static_cast<int>(unit(random) * 8);
      const int first = static_cast<int>(positions.size());
      const int surface = static_cast<int>(unit(random) * 2);
      Vec3 p(unit(random) - 0.5 + 2.0 * chain, unit(random) - 0.5, 0.0);
      if (first_on)
      {
        p.z() = evaluateSurface(scene.surfaces[surface], p.x(), p.y()).z;
        scene.constraints.push_back(SurfaceConstraint{ first, surface });
        ++surface_rows;
      }
      else if (on == 2 && chain % 2 == 1)
        scene.constraints.push_back(PinConstraint{ first, p });  // held next to links only
      for (int i = 0; i < n; ++i)
      {
        scene.masses.push_back(0.05 + 2.0 * unit(random));
        positions.push_back(p);
        velocities.push_back(Vec3(unit(random) - 0.5, unit(random) - 0.5, unit(random) - 0.5));
        if (i + 1 < n)
        {
          // each link leaning a random way: down below a bead, up towards a surface above
          const Vec3 step(unit(random) - 0.5, unit(random) - 0.5, on == 2 ? 1.0 : -1.0);
          const double length = 0.05 + 0.2 * unit(random);
          Vec3 next = p + length * step.normalized();
          if (last_on && i + 2 == n)
            next.z() = evaluateSurface(scene.surfaces[1 - surface], next.x(), next.y()).z;
          const double l = (next - p).norm();
          if (unit(random) < 0.5)
            scene.constraints.push_back(LinkConstraint{ first + i, first + i + 1, l });
          else
            scene.constraints.push_back(LinkConstraint{ first + i + 1, first + i, l });
          p = next;
        }
      }
      if (last_on)
      {
        scene.constraints.push_back(SurfaceConstraint{ first + n - 1, 1 - surface });
        ++surface_rows;
        ++below;
      }
      ends.push_back(first + n - 1);
    }
    const int n = static_cast<int>(positions.size());
    State start;
    start.positions.resize(3, n);
    start.velocities.resize(3, n);
    for (int i = 0; i < n; ++i)
    {
      start.positions.col(i) = positions[i];
      start.velocities.col(i) = velocities[i];
    }
    scene.forces = { GravityForce{} };
    scene.forces.push_back(SpringForce{ ends[0], ends[1], 20.0, 1.0 });
    if (c % 3 == 0)
      scene.forces.push_back(LinearDampingForce{ 0.1 });
    StepSettings settings;
    settings.integrator = integrators[c % integrators.size()];
    settings.stabilization = c % 2 == 0 ? Stabilization::Projection : Stabilization::None;
    settings.dt = 1e-3;
    fused += expectSurfaceCaseSame(scene, start, settings, surface_rows,
                                   scene.name + ", " + std::to_string(chains) + " chains, " +
                                       std::to_string(surface_rows) + " surface rows");
  }
  EXPECT_EQ(fused, 24);
  EXPECT_GE(below, 12);  // surface rows below links, whose correction adds its shares reversed
}

TEST(StagePaths, ASingularChainTakesTheGenericRegularisedSolve)
{
  // a taut straight chain between two pins: J W J^T has rank 1 at the middle particle
  Scene scene;
  scene.masses = { 1.0, 1.0, 1.0 };
  scene.forces = { GravityForce{} };
  scene.constraints = { LinkConstraint{ 0, 1, 0.1 }, LinkConstraint{ 1, 2, 0.1 },
                        PinConstraint{ 0, Vec3(0, 0, 0) }, PinConstraint{ 2, Vec3(0.2, 0, 0) } };
  State start;
  start.positions.setZero(3, 3);
  start.positions.col(1) = Vec3(0.1, 0, 0);
  start.positions.col(2) = Vec3(0.2, 0, 0);
  start.velocities.setZero(3, 3);
  start.velocities.col(1) = Vec3(0, 0, -0.5);  // moves, and stays near the singular line
  StepSettings settings;
  settings.max_substeps = 1;
  bool singular = false;
  EXPECT_TRUE(expectSameMotion(scene, start, settings, SolveMethod::Automatic, "taut chain", 100,
                               &singular));
  EXPECT_TRUE(singular) << "the fallback was never exercised";
}

// A projected step ends with the factorisation at its final positions; the next step's first
// stage solves with it, not after a reset, a new state or new settings, nor in a step retaken
// after a rejection. Damping makes the scene non-conservative, so no evaluation at the state
// (the energy check's) comes between a write and the next step to clear it by the way.
TEST(StagePaths, TheFirstStageReusesTheProjectionsFactorisation)
{
  const int n = 8;
  Scene scene = constrained_particles::testing::pinnedChain(std::vector<double>(n, 0.1), 0.1);
  scene.forces.push_back(LinearDampingForce{ 0.01 });
  const State start = constrained_particles::testing::horizontalStart(n);
  StepSettings settings;
  settings.integrator = "rk4";
  settings.stabilization = Stabilization::Projection;
  settings.max_substeps = 1;
  Simulator fused(scene, start, settings);
  Simulator generic(scene, start, settings, SolveMethod::Automatic, StagePaths::Generic);
  ASSERT_TRUE(fused.model().fusedChain());
  auto both = [&](int steps)
  {
    const StepStatistics a = fused.step(steps);
    const StepStatistics b = generic.step(steps);
    EXPECT_LE(difference(fused.state(), generic.state()).positions, 1e-12);
    EXPECT_EQ(a.solve.factorizations + a.solve.reused_factorizations, b.solve.factorizations);
    return a;
  };
  // the first step after the reset factorises at every stage; each later one reuses one
  StepStatistics s = both(10);
  EXPECT_EQ(s.solve.reused_factorizations, 9);
  // four stages a step, one per Newton correction and one for the velocities
  EXPECT_EQ(s.solve.factorizations,
            10 * 4 - 9 + s.projection.iterations + s.projection.projections);
  EXPECT_EQ(both(5).solve.reused_factorizations, 5);
  // another state at the same time: its positions were not factorised
  State moved = fused.state();
  moved.positions.row(1) += Eigen::RowVectorXd::LinSpaced(n, 0.0, 0.05);
  fused.setState(moved);
  generic.setState(moved);
  EXPECT_EQ(both(3).solve.reused_factorizations, 2);
  for (Simulator* simulator : { &fused, &generic })
    simulator->reset();
  EXPECT_EQ(both(3).solve.reused_factorizations, 2);
  for (Simulator* simulator : { &fused, &generic })
    simulator->setStepSettings(settings);
  EXPECT_EQ(both(3).solve.reused_factorizations, 2);
  for (Simulator* simulator : { &fused, &generic })
    simulator->restoreState(moved);
  EXPECT_EQ(both(3).solve.reused_factorizations, 2);
  // under Baumgarte the stages are generic and nothing is projected
  settings.stabilization = Stabilization::Baumgarte;
  fused.setStepSettings(settings);
  EXPECT_EQ(fused.step(3).solve.reused_factorizations, 0);
}

// A step rejected and retaken in sub-steps starts again from positions the rejected attempt's
// projection did not end at: its first stage factorises anew, and the motion stays the generic
// stages'.
TEST(StagePaths, ARetakenStepDoesNotReuseTheRejectedAttemptsFactorisation)
{
  const int n = 6;
  const Scene scene =
      constrained_particles::testing::pinnedChain(std::vector<double>(n, 0.05), 0.1);
  const State start = constrained_particles::testing::horizontalStart(n);
  StepSettings settings;
  // one Newton iteration cannot take a whole step's drift to 1e-10 m; a half step's it can
  settings.integrator = "rk4";
  settings.stabilization = Stabilization::Projection;
  settings.dt = 0.02;
  settings.projection_max_iterations = 1;
  settings.max_substeps = 8;
  Simulator fused(scene, start, settings);
  Simulator generic(scene, start, settings, SolveMethod::Automatic, StagePaths::Generic);
  ASSERT_TRUE(fused.model().fusedChain());
  long rejected = 0, reused = 0;
  for (int batch = 0; batch < 20; ++batch)
  {
    const StepStatistics a = fused.step(10);
    const StepStatistics b = generic.step(10);
    ASSERT_LE(difference(fused.state(), generic.state()).positions, 1e-12) << "batch " << batch;
    EXPECT_EQ(a.rejected_steps, b.rejected_steps);
    EXPECT_EQ(a.solve.factorizations + a.solve.reused_factorizations, b.solve.factorizations);
    rejected += a.rejected_steps;
    reused += a.solve.reused_factorizations - b.solve.reused_factorizations;  // the fused path's
  }
  EXPECT_GT(rejected, 0) << "no step was retaken: the case is not exercised";
  EXPECT_GT(reused, 0);
}

// Projects `start` once with the fused projection and once with the generic one (positions to
// 1e-10 m, at most 5 iterations) and compares the reports, counters and projected states (the
// largest position error to `error_close` [m], positions and velocities to `state_close`);
// returns the fused report, and in `kept` whether it kept its factorisation for the next stage.
ProjectionReport expectSameProjection(const Scene& scene, const State& start, double error_close,
                                      double state_close, const std::string& what, bool* kept)
{
  const Model fused_model = Model::compile(scene);
  const Model generic_model = Model::compile(scene, SolveMethod::Automatic, StagePaths::Generic);
  EXPECT_TRUE(fused_model.fusedChain() || fused_model.fusedTree()) << what;
  EXPECT_FALSE(generic_model.fusedChain() || generic_model.solvesTreeByRows()) << what;
  Data fused(fused_model), generic(generic_model);
  for (Data* data : { &fused, &generic })
  {
    data->state.positions = start.positions;
    data->state.velocities = start.velocities;
  }
  const ProjectionReport a = projectStep(fused_model, fused, fused_model.path().path, 0.0,
                                         fused.state.positions, fused.state.velocities, 1e-10, 5);
  const ProjectionReport b =
      projectStep(generic_model, generic, generic_model.path().path, 0.0, generic.state.positions,
                  generic.state.velocities, 1e-10, 5);
  EXPECT_EQ(a.singular, b.singular) << what;
  EXPECT_EQ(a.converged, b.converged) << what;
  EXPECT_EQ(a.iterations, b.iterations) << what;
  EXPECT_LE(std::abs(a.max_position_error - b.max_position_error), error_close) << what;
  EXPECT_EQ(fused.counters.constraints, generic.counters.constraints) << what;
  EXPECT_EQ(fused.counters.factorizations, generic.counters.factorizations) << what;
  EXPECT_EQ(fused.statistics.solve.factorizations, generic.statistics.solve.factorizations) << what;
  EXPECT_EQ(fused.statistics.solve.singular_count, generic.statistics.solve.singular_count) << what;
  EXPECT_LE((fused.state.positions - generic.state.positions).cwiseAbs().maxCoeff(), state_close)
      << what;
  EXPECT_LE((fused.state.velocities - generic.state.velocities).cwiseAbs().maxCoeff(), state_close)
      << what;
  *kept = fused.fused.factorization.state_version == fused.stateVersion();
  return a;
}

// The fused projection's own hand-overs: at an exactly collinear taut chain the velocity solve is
// singular (the positions converge at once); stretched and collinear, every position solve is,
// and the projection runs out of iterations. Both ways give the same reports, counters, motion.
TEST(StagePaths, TheFusedProjectionHandsSingularSolvesToTheGenericOne)
{
  for (const double stretch : { 0.0, 2e-4 })
  {
    Scene scene;
    scene.masses = { 1.0, 1.0, 1.0 };
    scene.forces = { GravityForce{} };
    scene.constraints = { LinkConstraint{ 0, 1, 0.1 }, LinkConstraint{ 1, 2, 0.1 },
                          PinConstraint{ 0, Vec3(0, 0, 0) },
                          PinConstraint{ 2, Vec3(0.2 + stretch, 0, 0) } };
    State start;
    start.positions = Points::Zero(3, 3);
    start.velocities = Points::Zero(3, 3);
    start.positions.col(1) = Vec3(0.1 + 0.5 * stretch, 0, 0);
    start.positions.col(2) = Vec3(0.2 + stretch, 0, 0);
    start.velocities.col(1) = Vec3(0.3, 0, -0.5);
    const std::string what = "stretch " + std::to_string(stretch);
    ASSERT_TRUE(Model::compile(scene).fusedChain());
    bool kept = false;
    const ProjectionReport a = expectSameProjection(scene, start, 0.0, 1e-15, what, &kept);
    EXPECT_TRUE(a.singular) << what << ": the hand-over was not exercised";
    EXPECT_EQ(a.converged, stretch == 0.0) << what;
  }
}

// The same for a tree: a taut line between two pins through particle 1, particle 3 hanging from
// it (a fused tree, Model::fusedTree()), against the generic projection (the block elimination:
// the same regularisation, rounding amplified by about 1 / delta, hence 1e-9 m). Exactly taut
// only: pulled 2e-4 m apart, Newton walks the line towards singular, and the two eliminations'
// pivot ratios (of different matrices, their sums in different orders) call different checks
// singular near the threshold (there the fused path's last check factorised unregularised), so
// the two paths may project the velocities differently (as RandomTreesMoveTheSameBothWays' taut
// tree: both call some singular)
TEST(StagePaths, TheFusedTreeProjectionHandsSingularSolvesToTheGenericOne)
{
  Scene scene;
  scene.masses = { 1.0, 1.0, 1.0, 1.0 };
  scene.forces = { GravityForce{} };
  scene.constraints = { LinkConstraint{ 0, 1, 0.1 }, LinkConstraint{ 1, 2, 0.1 },
                        LinkConstraint{ 3, 1, 0.1 }, PinConstraint{ 0, Vec3(0, 0, 0) },
                        PinConstraint{ 2, Vec3(0.2, 0, 0) } };
  State start;
  start.positions = Points::Zero(3, 4);
  start.velocities = Points::Zero(3, 4);
  start.positions.col(1) = Vec3(0.1, 0, 0);
  start.positions.col(2) = Vec3(0.2, 0, 0);
  start.positions.col(3) = Vec3(0.1, 0, -0.1);
  start.velocities.col(1) = Vec3(0.3, 0, -0.5);
  start.velocities.col(3) = Vec3(0.0, 0.2, 0.0);
  ASSERT_TRUE(Model::compile(scene).fusedTree());
  bool kept = true;
  const ProjectionReport a = expectSameProjection(scene, start, 1e-9, 1e-9, "taut tree", &kept);
  EXPECT_TRUE(a.singular) << "the hand-over was not exercised";
  EXPECT_TRUE(a.converged);
  // a singular projection keeps no factorisation for the next stage
  EXPECT_FALSE(kept);
}

// A fused tree's first stage solving with its projection's factorisation solves with what a new
// factorisation at the same positions gives, bit for bit: `mobile` stepped with the reuse moves
// exactly as when constraintForces() between steps (evaluated on copies of the state) defeats it.
TEST(StagePaths, AFusedTreesReusedFactorisationIsAFreshOne)
{
  const SceneDescription description = loadSceneFile(DIRECTORY + "/mobile.yaml");
  const BuiltScene built = buildScene(description);
  const StepSettings settings = description.solver.applyTo(StepSettings{});
  Simulator reusing(built.scene, built.initial_state, settings);
  Simulator fresh(built.scene, built.initial_state, settings);
  ASSERT_TRUE(reusing.model().fusedTree());
  Points forces;
  Eigen::VectorXd multipliers;
  long reused = 0, fresh_reused = 0;
  for (int k = 0; k < 300; ++k)
  {
    reused += reusing.step().solve.reused_factorizations;
    fresh_reused += fresh.step().solve.reused_factorizations;
    fresh.constraintForces(forces, multipliers);
  }
  EXPECT_EQ(reused, 299);
  EXPECT_EQ(fresh_reused, 0);
  EXPECT_EQ(reusing.state().positions, fresh.state().positions);
  EXPECT_EQ(reusing.state().velocities, fresh.state().velocities);
  EXPECT_GT((reusing.state().positions - built.initial_state.positions).cwiseAbs().maxCoeff(),
            1e-2);
}
