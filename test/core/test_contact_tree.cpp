// The fused contact tree (ForwardPath::FusedContactTree, tree_stages.cpp): chains and trees of
// links with surface contacts take the fused tree's sweeps for their forward stage, each contact
// one more row on its particle. Against the generic stages: the same forces and counters at one
// state (with friction to solve for, the stage the sweeps hand over to the generic one), and the
// same motion over 1,000 steps of random trees dropped onto height fields.
#include "contact.hpp"
#include "same_motion.hpp"
#include "stages.hpp"
#include "test_helpers.hpp"

#include "constrained_particles/core/forward_path.hpp"
#include "constrained_particles/core/simulator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

using namespace constrained_particles;
using constrained_particles::testing::expectSameMotion;

namespace
{
// n particles 5 cm apart along x on the plane z = slope (x - 2 y), linked, each with a contact
// (Coulomb mu `friction`) and the first pinned if `pinned`, or held on the plane by a surface row
// instead of its contact if `on_surface` (seed problem 3's chain); gravity and damping (J a0
// summed)
Scene chainOnTiltedPlane(int n, double friction, bool pinned, State& start, double slope = 0.1,
                         bool on_surface = false)
{
  Scene scene;
  scene.surfaces = { makeSurface(SurfaceType::Plane, { slope, -2.0 * slope, 0.0 }) };
  scene.forces = { GravityForce{}, LinearDampingForce{ 0.2 } };
  start.positions.setZero(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
  {
    scene.masses.push_back(0.05 + 0.01 * (i % 3));
    start.positions.col(i) = Vec3(0.05 * i, 0.0, slope * 0.05 * i);  // on the plane
    if (on_surface && i == 0)
      scene.constraints.push_back(SurfaceConstraint{ 0, 0 });
    else
      scene.constraints.push_back(SurfaceContact{ i, 0, friction, 0.0 });
    if (i > 0)
      scene.constraints.push_back(
          LinkConstraint{ i - 1, i, (start.positions.col(i) - start.positions.col(i - 1)).norm() });
  }
  if (pinned)
    scene.constraints.push_back(PinConstraint{ 0, Vec3(start.positions.col(0)) });
  return scene;
}

// One stage at a state with every contact acting, fused and generic: the same multipliers,
// constraint forces, accelerations and counters to rounding.
void expectSameStage(const Scene& scene, const State& start, const std::string& what)
{
  StepSettings settings;
  settings.dt = 1e-3;
  Simulator fused(scene, start, settings);
  Simulator generic(scene, start, settings, SolveMethod::Automatic, StagePaths::Generic);
  ASSERT_TRUE(fused.model().fusedContactTree()) << what << ": " << fused.model().path().reason;
  ASSERT_EQ(generic.forwardPath().path, ForwardPath::Generic) << what;
  fused.step(1);
  generic.step(1);
  Points f_fused, f_generic;
  Eigen::VectorXd lambda_fused, lambda_generic;
  fused.constraintForces(f_fused, lambda_fused);
  generic.constraintForces(f_generic, lambda_generic);
  int acting = 0;
  for (const ContactState& contact : fused.data().contacts)
    acting += contact.mode != ContactMode::Separated;
  EXPECT_GE(acting, static_cast<int>(fused.data().contacts.size()) - 1) << what;
  ASSERT_EQ(lambda_fused.size(), lambda_generic.size()) << what;
  const double lambda_scale = lambda_generic.cwiseAbs().maxCoeff();
  EXPECT_GT(lambda_scale, 0.1) << what;
  EXPECT_LE((lambda_fused - lambda_generic).cwiseAbs().maxCoeff(), 1e-12 * lambda_scale) << what;
  EXPECT_LE((f_fused - f_generic).cwiseAbs().maxCoeff(), 1e-12 * f_generic.cwiseAbs().maxCoeff())
      << what;
  const Points& a = fused.data().accelerations;
  const Points& b = generic.data().accelerations;
  EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + b.cwiseAbs().maxCoeff())) << what;
  for (std::size_t k = 0; k < fused.data().contacts.size(); ++k)
  {
    const ContactState& x = fused.data().contacts[k];
    const ContactState& y = generic.data().contacts[k];
    EXPECT_EQ(x.mode, y.mode) << what << ", contact " << k;
    EXPECT_NEAR(x.normal_force, y.normal_force, 1e-12 * (1.0 + std::abs(y.normal_force)))
        << what << ", contact " << k;
    EXPECT_LE((x.friction_force - y.friction_force).norm(), 1e-12 * (1.0 + y.normal_force))
        << what << ", contact " << k;
  }
  EXPECT_EQ(fused.data().counters.constraints, generic.data().counters.constraints) << what;
  // the sweeps ran: they keep each row's block by place
  EXPECT_FALSE(fused.data().fused.tree_jacobian.isZero()) << what;
}

// One forward stage of `model` at `start` after the step start's active set (chooseContactModes),
// with NaN in the links' rows of data.rows, which only the generic stage writes: returns the
// constraint forces [N] then the accelerations [m/s^2] (3 x 2n), and sets `sweeps_finished` if
// the NaN are still there (the sweeps finished it).
Points stageOf(const Model& model, const State& start, bool& sweeps_finished)
{
  Data data(model);
  data.setState(start);
  StepSettings settings;
  settings.dt = 1e-3;
  chooseContactModes(model, data, settings);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto& links = std::get<std::vector<KindRecord<LinkConstraint>>>(model.kindTables());
  for (const auto& link : links)
    data.rows.jacobian[link.first_block] = data.rows.jacobian[link.first_block + 1] =
        Vec3::Constant(nan);
  Points p = start.positions, v = start.velocities, a(3, model.numParticles());
  forward(model, data, settings, start.time, p, v, a);
  sweeps_finished = true;
  for (const auto& link : links)
    sweeps_finished = sweeps_finished && std::isnan(data.rows.jacobian[link.first_block].x());
  Points out(3, 2 * model.numParticles());
  out << data.constraint_forces, a;
  return out;
}
}  // namespace

TEST(ContactTree, ChainsAndTreesWithSurfaceContactsTakeTheFusedSweeps)
{
  State start;
  const Scene scene = chainOnTiltedPlane(12, 0.3, true, start);
  const Model model = Model::compile(scene);
  EXPECT_EQ(model.path().path, ForwardPath::FusedContactTree) << model.path().reason;
  EXPECT_TRUE(model.solvesTreeByRows());
  StepSettings baumgarte;
  baumgarte.stabilization = Stabilization::Baumgarte;
  EXPECT_EQ(forwardPath(model, baumgarte), ForwardPath::Generic);
  // another unilateral row (a slack link) or a carried shape: the generic stages, and why
  Scene slack = scene;
  slack.masses.push_back(0.05);
  slack.constraints.push_back(SlackLink{ 11, 12, 0.1 });
  const PathChoice generic = Model::compile(slack).path();
  EXPECT_EQ(generic.path, ForwardPath::Generic);
  EXPECT_NE(generic.reason.find("not a contact tree"), std::string::npos) << generic.reason;
  EXPECT_EQ(Model::compile(scene, SolveMethod::Automatic, StagePaths::Generic).path().path,
            ForwardPath::Generic);
  // a surface row beside the contacts: a contact tree; beside none, the fused chain's (seed
  // problem 3)
  State on_surface_start;
  const Scene on_surface = chainOnTiltedPlane(12, 0.3, false, on_surface_start, 0.1, true);
  EXPECT_EQ(Model::compile(on_surface).path().path, ForwardPath::FusedContactTree)
      << Model::compile(on_surface).path().reason;
  Scene surface_only = on_surface;
  surface_only.constraints.erase(
      std::remove_if(surface_only.constraints.begin(), surface_only.constraints.end(),
                     [](const Constraint& c) { return std::holds_alternative<SurfaceContact>(c); }),
      surface_only.constraints.end());
  EXPECT_EQ(Model::compile(surface_only).path().path, ForwardPath::FusedChain);
}

TEST(ContactTree, TheFusedStageGivesTheGenericForces)
{
  for (const bool pinned : { false, true })
  {
    State start;
    // frictionless: the sweeps' own stage; with friction on the tilt the sticking contacts need
    // friction, which the generic stage solves for
    expectSameStage(chainOnTiltedPlane(30, 0.0, pinned, start), start,
                    pinned ? "frictionless, pinned" : "frictionless");
    expectSameStage(chainOnTiltedPlane(30, 0.6, pinned, start), start,
                    pinned ? "friction 0.6, pinned" : "friction 0.6");
  }
  // the first particle on the plane by a surface row: one more row of one block, always acting
  State start;
  expectSameStage(chainOnTiltedPlane(30, 0.0, false, start, 0.1, true), start,
                  "frictionless, a surface row");
  expectSameStage(chainOnTiltedPlane(30, 0.6, false, start, 0.1, true), start,
                  "friction 0.6, a surface row");
}

TEST(ContactTree, RandomTreesDroppedOnHeightFieldsMoveTheSameBothWays)
{
  std::mt19937 random(20261207);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const std::vector<std::pair<SurfaceType, std::vector<double>>> grounds = {
    { SurfaceType::Plane, { 0.1, -0.05, 0.0 } },
    { SurfaceType::Bowl, { 0.5, 0.5 } },
    { SurfaceType::Waves, { 0.05, 3.0, 2.0 } },
  };
  // integrators that evaluate stages. The counts are compared exactly, and rounding can move
  // them where a decision is on a knife's edge: a stuck particle's slide of rounding's size
  // stopped at a step's start or not (which decides whether the first stage reuses the active
  // set's solve), SHAKE's and RATTLE's iterations to their tolerance (velocity Verlet, fast
  // projection), dopri5's error control; other seeds and integrators met such edges (the same
  // motion to 2e-12 m, not the same counts)
  const std::vector<std::string> integrators = { "rk4", "midpoint", "semi_implicit_euler" };
  int contact_trees = 0;
  for (int c = 0; c < 9; ++c)
  {
    const int n = 5 + static_cast<int>(unit(random) * 16);
    Scene scene;
    scene.surfaces = { makeSurface(grounds[c % 3].first, grounds[c % 3].second) };
    const double friction = c % 2 == 0 ? 0.0 : 0.4;
    const double restitution = c % 4 == 1 ? 0.5 : 0.0;
    State start;
    start.positions.setZero(3, n);
    start.velocities.setZero(3, n);
    std::vector<int> children(n, 0);
    for (int k = 0; k < n; ++k)
    {
      scene.masses.push_back(0.05 + 0.2 * unit(random));
      const Vec3 spread(unit(random) - 0.5, unit(random) - 0.5, 0.2 * (unit(random) - 0.5));
      if (k == 0)
        start.positions.col(k) = Vec3(0.0, 0.0, 0.05 + 0.1 * unit(random));
      else
      {
        // a chain mostly, branching now and then: at most three rows of links on a particle
        int parent = unit(random) < 0.8 ? k - 1 : static_cast<int>(unit(random) * k);
        while (children[parent] == 2)
          parent = (parent + 1) % k;
        ++children[parent];
        start.positions.col(k) = start.positions.col(parent) + 0.08 * spread.normalized();
        scene.constraints.push_back(LinkConstraint{
            parent, k, (start.positions.col(k) - start.positions.col(parent)).norm() });
      }
      start.velocities.col(k) = 0.2 * Vec3(unit(random) - 0.5, unit(random) - 0.5, 0.0);
    }
    // lift the whole above the ground, then each particle its contact
    double lift = 0.0;
    for (int k = 0; k < n; ++k)
    {
      const SurfaceSample ground =
          evaluateSurface(scene.surfaces[0], start.positions(0, k), start.positions(1, k));
      lift = std::max(lift, ground.z - start.positions(2, k) + 0.01);
    }
    start.positions.row(2).array() += lift;
    for (int k = 0; k < n; ++k)
      scene.constraints.push_back(SurfaceContact{ k, 0, friction, restitution });
    if (c % 3 == 2)
      scene.constraints.push_back(PinConstraint{ 0, Vec3(start.positions.col(0)) });
    scene.forces = { GravityForce{} };
    StepSettings settings;
    settings.integrator = integrators[c % integrators.size()];
    settings.dt = 1e-3;
    // both paths run all 1,000 steps whatever a method gains: the paths are compared here
    settings.energy_budget = 0.0;
    const std::string what = "random contact tree " + std::to_string(c) + " (" +
                             settings.integrator + ", mu " + std::to_string(friction) + ")";
    const Simulator probe(scene, start, settings);
    EXPECT_TRUE(probe.model().fusedContactTree()) << what << ": " << probe.model().path().reason;
    contact_trees += probe.model().fusedContactTree();
    double moved = 0.0;
    expectSameMotion(scene, start, settings, SolveMethod::Automatic, what, 1000, nullptr, &moved);
    EXPECT_GT(moved, 1e-2) << what;
  }
  EXPECT_EQ(contact_trees, 9);
}

// The sweeps finish a stage themselves where no friction is to be solved for: frictionless (with
// a surface row too), and sticking on a level plane, its friction at rounding's level
// (contactForceStage's first check); holding a chain on a tilt takes friction, and a slide with
// friction too, and the stage is the generic one. Either way the generic stage's forces and
// accelerations.
TEST(ContactTree, TheSweepsFinishTheStageUnlessFrictionIsToBeSolvedFor)
{
  struct Case
  {
    double slope, friction, speed;  // speed: the chain's slide along x at the start [m/s]
    bool on_surface, swept;
    const char* what;
  };
  for (const Case c : { Case{ 0.0, 0.3, 0.0, false, true, "level, mu 0.3" },
                        Case{ 0.1, 0.0, 0.0, false, true, "tilted, frictionless" },
                        Case{ 0.1, 0.0, 0.0, true, true, "tilted, frictionless, a surface row" },
                        Case{ 0.1, 0.6, 0.0, false, false, "tilted, mu 0.6" },
                        Case{ 0.0, 0.3, 0.5, false, false, "level, mu 0.3, sliding" } })
  {
    State start;
    const Scene scene = chainOnTiltedPlane(10, c.friction, false, start, c.slope, c.on_surface);
    start.velocities.row(0).setConstant(c.speed);
    bool swept = false, generic_swept = false;
    const Points a = stageOf(Model::compile(scene), start, swept);
    const Points b = stageOf(Model::compile(scene, SolveMethod::Automatic, StagePaths::Generic),
                             start, generic_swept);
    EXPECT_EQ(swept, c.swept) << c.what;
    EXPECT_FALSE(generic_swept) << c.what;
    EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + b.cwiseAbs().maxCoeff())) << c.what;
    EXPECT_GT(b.cwiseAbs().maxCoeff(), 0.1) << c.what;  // the contacts carry the chain's weight
  }
}
