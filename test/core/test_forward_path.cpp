// The stage path (forward_path.hpp) is chosen once, with its reason, and is the one every stage
// takes: a chain of links and a tree of links take their fused sweeps, anything else the generic
// stages with a reason naming what rules the sweeps out; Baumgarte's bias and an integrator that
// holds the constraints keep a fused model on the generic stages. The fused buffers show which
// path a step really ran.
#include "stages.hpp"
#include "test_helpers.hpp"

#include "constrained_particles/core/forward_path.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <string>

using namespace constrained_particles;

namespace
{
bool contains(const std::string& text, const std::string& part)
{
  return text.find(part) != std::string::npos;
}

StepSettings withStabilization(Stabilization stabilization)
{
  StepSettings settings;
  settings.integrator = "rk4";
  settings.stabilization = stabilization;
  return settings;
}

// Whether a step wrote the fused chain's own Jacobian (only the fused chain stages write it).
bool fusedChainStagesRan(const Scene& scene, Stabilization stabilization)
{
  Simulator simulator(
      scene, constrained_particles::testing::horizontalStart(static_cast<int>(scene.masses.size())),
      withStabilization(stabilization));
  simulator.step(1);
  for (const Vec3& block : simulator.data().fused.chain_jacobian)
    if (block != Vec3::Zero())
      return true;
  return false;
}
}  // namespace

TEST(ForwardPath, AChainOfTenTakesTheFusedChainSweepsAndSaysWhy)
{
  const Scene scene =
      constrained_particles::testing::pinnedChain(std::vector<double>(10, 0.1), 0.1);
  const Model model = Model::compile(scene);
  EXPECT_EQ(model.path().path, ForwardPath::FusedChain);
  EXPECT_TRUE(contains(model.path().reason, "9 rows")) << model.path().reason;
  EXPECT_TRUE(contains(model.path().reason, "tridiagonal")) << model.path().reason;
  const PathChoice projected = choosePath(model, withStabilization(Stabilization::Projection));
  EXPECT_EQ(projected.path, ForwardPath::FusedChain);
  EXPECT_EQ(std::string(forwardPathName(projected.path)), "fused_chain");
  // the stages follow the plan: the sweeps write their own Jacobian
  EXPECT_TRUE(fusedChainStagesRan(scene, Stabilization::Projection));
  EXPECT_TRUE(fusedChainStagesRan(scene, Stabilization::None));
}

TEST(ForwardPath, BaumgartesBiasKeepsAChainOnTheGenericStages)
{
  const Scene scene =
      constrained_particles::testing::pinnedChain(std::vector<double>(10, 0.1), 0.1);
  const Model model = Model::compile(scene);
  const PathChoice choice = choosePath(model, withStabilization(Stabilization::Baumgarte));
  EXPECT_EQ(choice.path, ForwardPath::Generic);
  EXPECT_EQ(forwardPath(model, withStabilization(Stabilization::Baumgarte)), ForwardPath::Generic);
  EXPECT_TRUE(contains(choice.reason, "baumgarte")) << choice.reason;
  EXPECT_TRUE(contains(choice.reason, "fused_chain")) << choice.reason;
  EXPECT_FALSE(fusedChainStagesRan(scene, Stabilization::Baumgarte));
  // the simulator reports the path of its own settings, and a settings change moves it
  Simulator simulator(scene, constrained_particles::testing::horizontalStart(10),
                      withStabilization(Stabilization::Baumgarte));
  EXPECT_EQ(simulator.forwardPath().path, ForwardPath::Generic);
  simulator.setStepSettings(withStabilization(Stabilization::Projection));
  EXPECT_EQ(simulator.forwardPath().path, ForwardPath::FusedChain);
}

TEST(ForwardPath, ATreeOfLinksTakesTheFusedTreeSweeps)
{
  // a star: particle 0 pinned, three links from particle 1
  Scene scene;
  scene.masses = { 0.1, 0.1, 0.1, 0.1, 0.1 };
  scene.forces = { GravityForce{} };
  scene.constraints = { PinConstraint{ 0, Vec3::Zero() }, LinkConstraint{ 0, 1, 0.1 },
                        LinkConstraint{ 1, 2, 0.1 }, LinkConstraint{ 1, 3, 0.1 },
                        LinkConstraint{ 1, 4, 0.1 } };
  const Model model = Model::compile(scene);
  EXPECT_EQ(model.path().path, ForwardPath::FusedTree) << model.path().reason;
  EXPECT_TRUE(contains(model.path().reason, "tree")) << model.path().reason;
  // the tree sweeps ran: they keep each link's d by place
  State start;
  start.positions.setZero(3, 5);
  start.velocities.setZero(3, 5);
  start.positions.col(1) = Vec3(0.1, 0.0, 0.0);
  start.positions.col(2) = Vec3(0.2, 0.0, 0.0);
  start.positions.col(3) = Vec3(0.1, 0.1, 0.0);
  start.positions.col(4) = Vec3(0.1, -0.1, 0.0);
  Simulator simulator(scene, start, withStabilization(Stabilization::Projection));
  simulator.step(1);
  EXPECT_FALSE(simulator.data().fused.tree_jacobian.isZero());
}

TEST(ForwardPath, OtherStructuresTakeTheGenericStagesWithTheirReason)
{
  // no rows at all
  Scene free_particle;
  free_particle.masses = { 1.0 };
  free_particle.forces = { GravityForce{} };
  const PathChoice none = Model::compile(free_particle).path();
  EXPECT_EQ(none.path, ForwardPath::Generic);
  EXPECT_TRUE(contains(none.reason, "no constraint rows")) << none.reason;
  // a chain with a row of another kind: the sweeps know links and surface rows only
  Scene planar = constrained_particles::testing::pinnedChain(std::vector<double>(4, 0.1), 0.1);
  PointOnPlaneConstraint plane;
  plane.particle = 3;
  plane.point = Vec3::Zero();
  planar.constraints.push_back(plane);
  const PathChoice other = Model::compile(planar).path();
  EXPECT_EQ(other.path, ForwardPath::Generic);
  EXPECT_FALSE(other.reason.empty());
  EXPECT_FALSE(contains(other.reason, "no constraint rows")) << other.reason;
  // asked for
  const Scene chain = constrained_particles::testing::pinnedChain(std::vector<double>(4, 0.1), 0.1);
  const PathChoice asked =
      Model::compile(chain, SolveMethod::Automatic, StagePaths::Generic).path();
  EXPECT_EQ(asked.path, ForwardPath::Generic);
  EXPECT_TRUE(contains(asked.reason, "StagePaths::Generic")) << asked.reason;
  // a chain solved densely
  const PathChoice dense = Model::compile(chain, SolveMethod::Dense).path();
  EXPECT_EQ(dense.path, ForwardPath::Generic);
  EXPECT_TRUE(contains(dense.reason, "dense")) << dense.reason;
}

// The path reported is the one the stages run, for every shipped scene: each fused path writes a
// Jacobian layout of its own, which no other path touches.
TEST(ForwardPath, EveryShippedSceneRunsThePathItReports)
{
  int fused = 0, contact_trees = 0;
  for (const std::string& name : listScenes(SCENES_DIR))
  {
    const BuiltScene built =
        buildScene(loadSceneFile(std::string(SCENES_DIR) + "/" + name + ".yaml"));
    Simulator simulator(built.scene, built.initial_state, StepSettings{});
    const PathChoice choice = simulator.forwardPath();
    EXPECT_FALSE(choice.reason.empty()) << name;
    simulator.step(1);
    const FusedWorkspace& buffers = simulator.data().fused;
    bool chain_ran = false;
    for (const Vec3& block : buffers.chain_jacobian)
      chain_ran |= block != Vec3::Zero();
    const bool tree_ran = buffers.tree_jacobian.size() > 0 && !buffers.tree_jacobian.isZero();
    EXPECT_EQ(chain_ran, choice.path == ForwardPath::FusedChain) << name << ": " << choice.reason;
    // a contact tree's sweeps keep d and the contacts' normals by place too
    EXPECT_EQ(tree_ran,
              choice.path == ForwardPath::FusedTree || choice.path == ForwardPath::FusedContactTree)
        << name << ": " << choice.reason;
    contact_trees += choice.path == ForwardPath::FusedContactTree;
    fused += choice.path != ForwardPath::Generic;
    // an integrator that holds the constraints steps on the generic rows, and says so
    StepSettings verlet;
    verlet.integrator = "velocity_verlet";
    simulator.setStepSettings(verlet);
    EXPECT_EQ(simulator.forwardPath().path, ForwardPath::Generic) << name;
  }
  EXPECT_GE(fused, 3);  // chain, surface_chain, two_chains_on_surface at least
  // dome, friction_ramp, rope_on_table, surface_chain_contact at least
  EXPECT_GE(contact_trees, 4);
}

// One rule for "the state changed" (FactorizationCache): the projection's factorisation is kept
// for the next step, and any write of the state between steps retires it.
TEST(ForwardPath, AWriteOfTheStateRetiresTheKeptFactorisation)
{
  const Scene scene = constrained_particles::testing::pinnedChain(std::vector<double>(6, 0.1), 0.1);
  Simulator simulator(scene, constrained_particles::testing::horizontalStart(6),
                      withStabilization(Stabilization::Projection));
  simulator.step(3);
  const auto kept = [&]
  { return simulator.data().fused.factorization.state_version == simulator.data().stateVersion(); };
  EXPECT_TRUE(kept());
  simulator.restoreState(simulator.state());
  EXPECT_FALSE(kept());
  simulator.step(1);
  EXPECT_TRUE(kept());
  simulator.reset();
  EXPECT_FALSE(kept());
  simulator.step(1);
  EXPECT_TRUE(kept());
  simulator.setStepSettings(withStabilization(Stabilization::Projection));
  EXPECT_FALSE(kept());
}
