// Scene files: every built-in scenario is a file that builds the same scene; every file in
// config/scenes loads, runs and evaluates exactly the effects it lists; bad files are refused
// naming file, line, key and reason.
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

using namespace constrained_particles;

namespace
{
const std::string DIRECTORY = SCENES_DIR;

// The message of the InvalidInput the call throws ("" if none).
template <typename Fn>
std::string refusal(Fn fn)
{
  try
  {
    fn();
  }
  catch (const InvalidInput& e)
  {
    return e.what();
  }
  return "";
}

void expectRefused(const std::string& yaml, const std::vector<std::string>& mentions)
{
  const std::string message = refusal([&] { buildScene(parseScene(yaml, "test.yaml")); });
  ASSERT_FALSE(message.empty()) << "accepted:\n" << yaml;
  for (const std::string& mention : mentions)
    EXPECT_NE(message.find(mention), std::string::npos)
        << "'" << mention << "' not in: " << message;
}

std::vector<int> kindsListed(const Scene& scene, bool forces)
{
  std::vector<int> listed(forces ? NUM_FORCE_KINDS : NUM_CONSTRAINT_KINDS, 0);
  if (forces)
    for (const Force& f : scene.forces)
      listed[f.index()] = 1;
  else
  {
    for (const Constraint& c : scene.constraints)
      listed[c.index()] = 1;
    // a rope's self-collision calls for link pair rows, made as its links come near
    if (!scene.self_collisions.empty())
      listed[constraintKindIndex<LinkPairContact>()] = 1;
  }
  return listed;
}

}  // namespace

// The seed derivation's three systems are the shipped files bead, chain and surface_chain.
TEST(SceneFiles, SeedScenesAreTheSeedProblems)
{
  const BuiltScene bead = buildScene(loadSceneFile(DIRECTORY + "/bead.yaml"));
  ASSERT_EQ(bead.scene.masses.size(), 1u);
  // on the bowl z = (x^2 + y^2) / 2 at (0.5, 0), moving along +y at 0.8 m/s in its tangent plane
  EXPECT_LE((Vec3(bead.initial_state.positions.col(0)) - Vec3(0.5, 0.0, 0.125)).norm(), 1e-15);
  EXPECT_LE((Vec3(bead.initial_state.velocities.col(0)) - Vec3(0.0, 0.8, 0.0)).norm(), 1e-15);
  ASSERT_EQ(bead.scene.constraints.size(), 1u);
  EXPECT_TRUE(std::holds_alternative<SurfaceConstraint>(bead.scene.constraints[0]));

  const BuiltScene chain = buildScene(loadSceneFile(DIRECTORY + "/chain.yaml"));
  ASSERT_EQ(chain.scene.masses.size(), 5u);
  for (int i = 0; i < 5; ++i)
    EXPECT_EQ(Vec3(chain.initial_state.positions.col(i)), Vec3(0.5 * i, 0.0, 0.0));
  EXPECT_TRUE(chain.initial_state.velocities.isZero(0.0));
  ASSERT_EQ(chain.scene.constraints.size(), 5u);  // 4 links, then the pin at the origin
  EXPECT_EQ(std::get<LinkConstraint>(chain.scene.constraints[3]).length, 0.5);
  EXPECT_EQ(std::get<PinConstraint>(chain.scene.constraints[4]).anchor, Vec3::Zero());

  const BuiltScene hanging = buildScene(loadSceneFile(DIRECTORY + "/surface_chain.yaml"));
  ASSERT_EQ(hanging.scene.masses.size(), 5u);
  ASSERT_EQ(hanging.scene.constraints.size(), 5u);  // the surface row first, then 4 links
  EXPECT_TRUE(std::holds_alternative<SurfaceConstraint>(hanging.scene.constraints[0]));
  const Vec3 down(std::sin(M_PI / 6), 0.0, -std::cos(M_PI / 6));
  for (int i = 0; i < 5; ++i)
  {
    EXPECT_LE(
        (Vec3(hanging.initial_state.positions.col(i)) - (Vec3(0.5, 0.0, 0.125) + 0.5 * i * down))
            .norm(),
        1e-15);
    EXPECT_LE((Vec3(hanging.initial_state.velocities.col(i)) - Vec3(0.0, 0.8, 0.0)).norm(), 1e-15);
  }

  // the seed's masses (1 kg), gravity (0, 0, -9.81) m/s^2 alone, the bowl with unit curvatures
  // and links of 0.5 m, in all three
  for (const BuiltScene* seed : { &bead, &chain, &hanging })
  {
    for (double mass : seed->scene.masses)
      EXPECT_EQ(mass, 1.0);
    ASSERT_EQ(seed->scene.forces.size(), 1u);
    ASSERT_TRUE(std::holds_alternative<GravityForce>(seed->scene.forces[0]));
    EXPECT_EQ(std::get<GravityForce>(seed->scene.forces[0]).acceleration, Vec3(0.0, 0.0, -9.81));
    int links = 0;
    for (const Constraint& constraint : seed->scene.constraints)
      if (const auto* link = std::get_if<LinkConstraint>(&constraint))
      {
        EXPECT_EQ(link->length, 0.5);
        EXPECT_EQ(link->second, link->first + 1);
        ++links;
      }
    EXPECT_EQ(links, seed == &bead ? 0 : 4);
  }
  for (const BuiltScene* on_bowl : { &bead, &hanging })
  {
    ASSERT_EQ(on_bowl->scene.surfaces.size(), 1u);
    EXPECT_EQ(on_bowl->scene.surfaces[0].type, SurfaceType::Bowl);
    EXPECT_EQ(on_bowl->scene.surfaces[0].coefficients[0], 1.0);
    EXPECT_EQ(on_bowl->scene.surfaces[0].coefficients[1], 1.0);
    EXPECT_EQ(std::get<SurfaceConstraint>(on_bowl->scene.constraints[0]).particle, 0);
  }
  EXPECT_TRUE(chain.scene.surfaces.empty());
  EXPECT_EQ(std::get<PinConstraint>(chain.scene.constraints[4]).particle, 0);
}

TEST(SceneFiles, EveryFileRunsAndEvaluatesOnlyWhatItLists)
{
  const std::vector<std::string> names = listScenes(DIRECTORY);
  EXPECT_GE(names.size(), 7u);
  for (const char* required :
       { "bead", "chain", "surface_chain", "pinned_pendulum", "chain_pinned_both_ends",
         "two_chains_on_surface", "bead_with_drag" })
    EXPECT_NE(std::find(names.begin(), names.end(), required), names.end()) << required;
  for (const std::string& name : names)
  {
    const SceneDescription description = loadSceneFile(resolveScene(name, DIRECTORY));
    EXPECT_EQ(description.name, name);
    const BuiltScene scenario = buildScene(description);
    Simulator simulator(scenario.scene, scenario.initial_state,
                        description.solver.applyTo(StepSettings{}),
                        description.solver.solve_method);
    simulator.step(500);
    const Diagnostics d = simulator.diagnostics();
    EXPECT_TRUE(d.finite()) << name;
    EXPECT_LT(d.max_position_error, 1e-8) << name;
    // a kind is evaluated if and only if the scene lists it
    const EffectCounters& c = simulator.effectCounters();
    const std::vector<int> forces = kindsListed(scenario.scene, true);
    for (int k = 0; k < NUM_FORCE_KINDS; ++k)
      EXPECT_EQ(c.forces[k] > 0, forces[k] == 1)
          << name << ": force " << KindNames<Force>::value[k];
    const std::vector<int> constraints = kindsListed(scenario.scene, false);
    for (int k = 0; k < NUM_CONSTRAINT_KINDS; ++k)
      EXPECT_EQ(c.constraints[k] > 0, constraints[k] == 1)
          << name << ": constraint " << KindNames<Constraint>::value[k];
  }
}

TEST(SceneFiles, SolveFollowsStructure)
{
  auto method = [](const std::string& name)
  {
    const BuiltScene s = buildScene(loadSceneFile(DIRECTORY + "/" + name + ".yaml"));
    return Model::compile(s.scene).solveMethod();
  };
  EXPECT_EQ(method("bead"), SolveMethod::Single);
  EXPECT_EQ(method("bead_with_drag"), SolveMethod::Single);
  EXPECT_EQ(method("chain"), SolveMethod::Tridiagonal);
  EXPECT_EQ(method("two_chains_on_surface"), SolveMethod::Tridiagonal);
  EXPECT_EQ(method("mobile"), SolveMethod::Tree);
  EXPECT_EQ(method("bead_on_wire"), SolveMethod::Tree);  // two rows inside the bead's block
  EXPECT_EQ(method("sled_on_ramp"), SolveMethod::Tree);
  EXPECT_EQ(method("shaken_chain"), SolveMethod::Tridiagonal);  // the driven top is eliminated
  EXPECT_EQ(method("zigzag_chain"), SolveMethod::Sparse);       // links and angles close cycles
}

// Every force and constraint kind of the registries is shown in some shipped scene.
TEST(SceneFiles, EveryKindIsInAShippedScene)
{
  std::vector<int> forces(NUM_FORCE_KINDS, 0), constraints(NUM_CONSTRAINT_KINDS, 0);
  for (const std::string& name : listScenes(DIRECTORY))
  {
    const BuiltScene s = buildScene(loadSceneFile(resolveScene(name, DIRECTORY)));
    const std::vector<int> f = kindsListed(s.scene, true), c = kindsListed(s.scene, false);
    for (int k = 0; k < NUM_FORCE_KINDS; ++k)
      forces[k] += f[k];
    for (int k = 0; k < NUM_CONSTRAINT_KINDS; ++k)
      constraints[k] += c[k];
  }
  for (int k = 0; k < NUM_FORCE_KINDS; ++k)
    EXPECT_GT(forces[k], 0) << "force " << KindNames<Force>::value[k];
  for (int k = 0; k < NUM_CONSTRAINT_KINDS; ++k)
    EXPECT_GT(constraints[k], 0) << "constraint " << KindNames<Constraint>::value[k];
}

TEST(SceneFiles, ChangesApplyToTheScene)
{
  SceneDescription d = loadSceneFile(DIRECTORY + "/surface_chain.yaml");
  ChainChange chain;
  chain.num_particles = 9;
  chain.link_length = 0.2;
  setChains(d, chain);
  setFirstSurface(d, makeSurface(SurfaceType::Plane, { 0.1, 0.0, -1.0 }));
  setGravityAndDamping(d, Vec3(0, 0, -1.62), 0.3);
  const BuiltScene s = buildScene(d);
  EXPECT_EQ(s.scene.masses.size(), 9u);
  EXPECT_NEAR(s.initial_state.positions(2, 0), 0.1 * 0.5 - 1.0, 1e-15);
  EXPECT_EQ(sceneGravity(d), Vec3(0, 0, -1.62));
  EXPECT_EQ(sceneDamping(d), 0.3);
  // the bead has no chain; the chain has no surface
  SceneDescription bead = loadSceneFile(DIRECTORY + "/bead.yaml");
  EXPECT_NE(refusal([&] { setChains(bead, chain); }).find("has no chain"), std::string::npos);
  SceneDescription pinned = loadSceneFile(DIRECTORY + "/chain.yaml");
  EXPECT_NE(refusal([&] { setFirstSurface(pinned, Surface{}); }).find("has no surface"),
            std::string::npos);
  // a scene naming chain particles by index keeps its chain counts
  SceneDescription mobile = loadSceneFile(DIRECTORY + "/mobile.yaml");
  EXPECT_NE(refusal([&] { setChains(mobile, chain); }).find("names chain particles"),
            std::string::npos);
  ChainChange same_count = chain;
  same_count.num_particles = 3;
  EXPECT_NO_THROW(setChains(mobile, same_count));
  // drag is kept when gravity goes
  SceneDescription drag = loadSceneFile(DIRECTORY + "/bead_with_drag.yaml");
  setGravityAndDamping(drag, Vec3::Zero(), 0.0);
  ASSERT_EQ(drag.forces.size(), 1u);
  EXPECT_TRUE(std::holds_alternative<QuadraticDragForce>(drag.forces[0]));
}

TEST(SceneFiles, NamesAndPathsResolve)
{
  EXPECT_EQ(resolveScene("bead", DIRECTORY), DIRECTORY + "/bead.yaml");
  EXPECT_EQ(resolveScene(DIRECTORY + "/mobile.yaml", DIRECTORY), DIRECTORY + "/mobile.yaml");
  const std::string unknown = refusal([&] { resolveScene("pendulum", DIRECTORY); });
  EXPECT_NE(unknown.find("scenario = 'pendulum' is unknown"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("bead_with_drag"), std::string::npos) << unknown;
  EXPECT_NE(refusal([&] { resolveScene("/no/such/file.yaml", DIRECTORY); }).find("no such"),
            std::string::npos);
  EXPECT_FALSE(refusal([&] { resolveScene("", DIRECTORY); }).empty());
  EXPECT_FALSE(refusal([&] { resolveScene(std::string(10000, 'x'), DIRECTORY); }).empty());
}

TEST(SceneFiles, BadFilesAreRefusedNamingFileKeyAndReason)
{
  const std::string bead =
      "surfaces:\n  ground: {type: bowl}\n"
      "particles:\n  - {mass: 1.0}\n"
      "constraints:\n  - {type: surface, particle: 0, surface: ground}\n";
  EXPECT_NO_THROW(buildScene(parseScene(bead, "test.yaml")));
  // unknown keys, with the valid ones
  expectRefused(bead + "gravity: 9.81\n", { "test.yaml:7: gravity", "not a key of a scene" });
  expectRefused("particles:\n  - {mass: 1.0, colour: red}\n",
                { "test.yaml:2: particles[0].colour", "valid keys: mass, position, velocity" });
  expectRefused("chains:\n  - {particles: 3, lenght: 0.5}\n",
                { "chains[0].lenght", "link_length" });
  expectRefused(
      "particles: [{mass: 1}, {mass: 1}]\n"
      "constraints:\n  - {type: link, first: 0, second: 1, lenght: 2}\n",
      { "test.yaml:3: constraints[0].lenght", "a link record", "length" });
  // a record without its type: the valid types
  expectRefused("particles: [{mass: 1}, {mass: 1}]\nconstraints:\n  - {first: 0, second: 1}\n",
                { "constraints[0].type", "is missing; valid: surface, link, pin, angle" });
  // a surface named twice
  expectRefused("surfaces:\n  ground: {type: bowl}\n  ground: {type: plane}\n",
                { "surfaces.ground", "appears twice" });
  // a key given twice (yaml-cpp would keep one silently)
  expectRefused("particles:\n  - {mass: 1.0, mass: 2.0}\n",
                { "test.yaml:2: particles[0].mass", "appears twice" });
  // invalid values: the key, the value and the range
  expectRefused("particles:\n  - {mass: -1.0}\n",
                { "particles[0].mass", "= -1", "[1e-09, 1e+06]" });
  expectRefused("particles:\n  - {mass: .nan}\n", { "particles[0].mass", "nan" });
  expectRefused("particles:\n  - {position: [1, 2]}\n", { "particles[0].position", "3 numbers" });
  expectRefused("particles:\n  - {mass: heavy}\n", { "particles[0].mass", "must be a number" });
  expectRefused("chains:\n  - {particles: 0}\n", { "chains[0].particles", "= 0, must be in [1, " });
  expectRefused("chains:\n  - {particles: 3, link_length: -0.5}\n",
                { "chains[0].link_length", "= -0.5, must be in [1e-06, " });
  expectRefused("chains:\n  - {particles: 3, direction: [0, 0, 0]}\n",
                { "chains[0].direction", "non-zero" });
  expectRefused(
      "particles: [{mass: 1}, {mass: 1}]\n"
      "constraints:\n  - {type: link, first: 0, second: 1, length: -2}\n",
      { "constraints[0]", "length", "[1e-06, 1000]" });
  expectRefused(
      "particles: [{mass: 1}, {mass: 1}]\n"
      "constraints:\n  - {type: link, first: 0, second: 5}\n",
      { "constraints[0]", "second", "= 5", "[0, 1]" });
  expectRefused(
      "particles: [{mass: 1}, {mass: 1}]\n"
      "constraints:\n  - {type: link, first: 1, second: 1}\n",
      { "constraints[0]", "second", "must differ from first" });
  expectRefused(
      "particles: [{mass: 1}]\nforces:\n  - {type: gravity, acceleration: [0, 0, .inf]}\n",
      { "forces[0]", "acceleration.z", "inf" });
  expectRefused("particles: [{mass: 1}]\nforces:\n  - {type: quadratic_drag, coefficient: -1}\n",
                { "forces[0]", "coefficient", "[0, 1e+06]" });
  // unknown kinds and names
  expectRefused("particles: [{mass: 1}]\nforces:\n  - {type: magnetism}\n",
                { "forces[0].type", "'magnetism' is unknown", "gravity", "spring" });
  expectRefused(
      "particles: [{mass: 1}]\nconstraints:\n  - {type: surface, particle: 0, surface: "
      "floor}\n",
      { "constraints[0].surface", "must name a surface", "defines none" });
  expectRefused("surfaces:\n  ground: {type: cone}\nparticles: [{mass: 1}]\n",
                { "surfaces.ground.type", "'cone' is not a surface type" });
  expectRefused(
      "surfaces:\n  ground: {type: expression, expression: \"sin(x\"}\n"
      "particles: [{mass: 1}]\n",
      { "surfaces.ground.expression", "position" });
  expectRefused("solver: {integrator: leapfrog}\nparticles: [{mass: 1}]\n",
                { "solver.integrator", "'leapfrog' is unknown", "rk4" });
  expectRefused("solver: {dt: 0}\nparticles: [{mass: 1}]\n", { "solver.dt", "[1e-06, 1]" });
  expectRefused("solver: {solve_method: magic}\nparticles: [{mass: 1}]\n",
                { "solver.solve_method", "tree" });
  // structure
  expectRefused("name: empty\n", { "particles", "at least 1 particle" });
  expectRefused("particles: {mass: 1}\n", { "particles", "must be a list" });
  expectRefused("particles: [{mass: 1}]\nforces: {type: gravity}\n", { "forces", "list" });
  expectRefused("[1, 2, 3]\n", { "test.yaml", "must hold a map" });
  expectRefused("particles: [{mass: 1}\n", { "test.yaml:", "not valid YAML" });
  expectRefused(
      "particles: [{mass: 1}, {mass: 1}]\n"
      "constraints:\n  - {type: pin, particle: 0, particles: [1]}\n",
      { "constraints[0].particles", "exclusive" });
  EXPECT_NE(refusal([] { loadSceneFile("/no/such/scene.yaml"); }).find("cannot be read"),
            std::string::npos);
}

TEST(SceneFiles, ParticleListsExpandAndPinsDefaultToTheirStart)
{
  const SceneDescription d = parseScene(
      "surfaces: {flat: {type: plane, coefficients: [0, 0, -1]}}\n"
      "particles:\n"
      "  - {position: [0, 0, 5]}\n  - {position: [1, 0, 5]}\n"
      "  - {position: [2, 0, 5], velocity: [1, 0, 3]}\n"
      "constraints:\n"
      "  - {type: surface, surface: flat, particles: [1, 2]}\n"
      "  - {type: pin, particle: 0}\n",
      "test.yaml");
  const BuiltScene s = buildScene(d);
  ASSERT_EQ(s.scene.constraints.size(), 3u);
  EXPECT_EQ(std::get<SurfaceConstraint>(s.scene.constraints[0]).particle, 1);
  EXPECT_EQ(std::get<SurfaceConstraint>(s.scene.constraints[1]).particle, 2);
  // placed on the plane z = -1, velocity tangent
  EXPECT_EQ(s.initial_state.positions(2, 2), -1.0);
  EXPECT_EQ(s.initial_state.velocities(2, 2), 0.0);
  EXPECT_EQ(std::get<PinConstraint>(s.scene.constraints[2]).anchor, Vec3(0, 0, 5));
}

// a line or plane given without a point goes through where its particle starts: nothing moves
TEST(SceneFiles, LinesAndPlanesDefaultToTheirParticlesStart)
{
  const BuiltScene s = buildScene(
      parseScene("particles: [{position: [0.3, -0.2, 1.0]}, {position: [2, 1, 0.5]}]\n"
                 "constraints: [{type: point_on_line, particle: 0, direction: [1, 1, 0]},\n"
                 "              {type: point_on_plane, particle: 1, normal: [0, 0, 1]}]\n",
                 "test.yaml"));
  EXPECT_EQ(std::get<PointOnLineConstraint>(s.scene.constraints.at(0)).point, Vec3(0.3, -0.2, 1.0));
  EXPECT_EQ(std::get<PointOnPlaneConstraint>(s.scene.constraints.at(1)).point, Vec3(2, 1, 0.5));
  Simulator simulator(s.scene, s.initial_state, StepSettings{});
  EXPECT_EQ(Vec3(simulator.state().positions.col(0)), Vec3(0.3, -0.2, 1.0));
  EXPECT_EQ(Vec3(simulator.state().positions.col(1)), Vec3(2, 1, 0.5));
}

// a driven anchor without a centre starts where its particle is written, whatever its phase
TEST(SceneFiles, DrivenAnchorsStartWhereTheirParticleIs)
{
  const BuiltScene s = buildScene(parseScene(
      "particles: [{position: [1, 2, 3]}]\n"
      "constraints: [{type: moving_anchor, particle: 0, amplitude: [0.1, 0, -0.2], frequency: 2,"
      " phase: 1.2}]\n",
      "test.yaml"));
  const auto& driven = std::get<MovingAnchorConstraint>(s.scene.constraints.at(0));
  EXPECT_LE((driven.anchor - (Vec3(1, 2, 3) - std::sin(1.2) * Vec3(0.1, 0, -0.2))).norm(), 1e-15);
  Simulator simulator(s.scene, s.initial_state, StepSettings{});
  EXPECT_LE((Vec3(simulator.state().positions.col(0)) - Vec3(1, 2, 3)).norm(), 1e-15);
}

TEST(SceneFiles, DocumentedExampleLoadsAndRuns)
{
  std::ifstream readme(SCENES_DOC_PATH);
  ASSERT_TRUE(readme.good());
  std::stringstream text;
  text << readme.rdbuf();
  const std::string all = text.str();
  const std::size_t section = all.find("### The format");
  ASSERT_NE(section, std::string::npos);
  const std::size_t start = all.find("```yaml\n", section);
  ASSERT_NE(start, std::string::npos);
  const std::size_t end = all.find("```", start + 8);
  const SceneDescription d = parseScene(all.substr(start + 8, end - start - 8), "docs/scenes.md");
  EXPECT_EQ(d.name, "hanging_bridge");
  EXPECT_EQ(d.surfaces.size(), 2u);
  EXPECT_EQ(d.numParticles(), 6);
  const BuiltScene s = buildScene(d);
  Simulator simulator(s.scene, s.initial_state, d.solver.applyTo(StepSettings{}),
                      d.solver.solve_method);
  simulator.step(300);
  EXPECT_TRUE(simulator.diagnostics().finite());
  EXPECT_LT(simulator.diagnostics().max_position_error, 1e-8);
  const EffectCounters& c = simulator.effectCounters();
  EXPECT_GT(c.forceCount<SpringForce>(), 0u);
  EXPECT_GT(c.forceCount<QuadraticDragForce>(), 0u);
  EXPECT_EQ(c.forceCount<LinearDampingForce>(), 0u);
}

// Every shipped scene's region of interest (the surface mesh's extent) and its sphere (what the
// camera frames) hold its particles over its first 6 s, as long as scripts/screenshot.sh runs a
// scene before its picture: the view shows the whole scene while it runs.
TEST(SceneFiles, EveryShippedSceneStaysInItsRegion)
{
  for (const std::string& name : listScenes(DIRECTORY))
  {
    SCOPED_TRACE(name);
    const SceneDescription d = loadSceneFile(resolveScene(name, DIRECTORY));
    const BuiltScene s = buildScene(d);
    const RegionSpec region = sceneRegion(d, s.initial_state);
    Simulator simulator(s.scene, s.initial_state, d.solver.applyTo(StepSettings{}),
                        d.solver.solve_method);
    const int steps = static_cast<int>(std::lround(6.0 / simulator.stepSettings().dt));
    for (int k = 0; k < steps; k += 20)
    {
      simulator.step(20);
      const Points& p = simulator.state().positions;
      for (int i = 0; i < p.cols(); ++i)
      {
        const std::string where =
            "particle " + std::to_string(i) + " at t = " + formatValue(simulator.state().time);
        ASSERT_LE((Vec3(p.col(i)) - region.center()).norm(), region.radius()) << where;
        for (int axis = 0; axis < 3; ++axis)
        {
          ASSERT_GE(p(axis, i), region.low[axis]) << where << " axis " << axis;
          ASSERT_LE(p(axis, i), region.high[axis]) << where << " axis " << axis;
        }
      }
    }
  }
}

TEST(SceneFiles, RegionsAreReadJoinedWithTheParticlesAndChecked)
{
  const std::string scene = "particles: [{mass: 1, position: [0.5, 0, 0]}]\n";
  const SceneDescription d =
      parseScene(scene + "region: {low: [-1, -2, -3], high: [1, 2, 0.1]}\n", "test.yaml");
  ASSERT_TRUE(d.region);
  const RegionSpec r = sceneRegion(d, buildScene(d).initial_state);
  EXPECT_EQ(r.low, Vec3(-1, -2, -3));
  // the particle at z = 0 keeps REGION_MARGIN above it
  EXPECT_EQ(r.high, Vec3(1, 2, REGION_MARGIN));
  EXPECT_NEAR(r.radius(), 0.5 * Vec3(2, 4, 3 + REGION_MARGIN).norm(), 1e-12);
  // without one: the particles' box with the margin, and each chain's reach about its start
  const SceneDescription chain =
      parseScene("chains: [{particles: 3, link_length: 0.5, start: [1, 0, 0], pin_first: true}]\n",
                 "test.yaml");
  const RegionSpec c = sceneRegion(chain, buildScene(chain).initial_state);
  EXPECT_EQ(c.low, Vec3(-0.25, -1.25, -1.25));
  EXPECT_EQ(c.high, Vec3(2.25, 1.25, 1.25));
  // the camera's radius: the far corner of the particles' box (2.25, 0.25, 0.25) from the
  // centre (1, 0, 0), beyond the reach sphere's 1.25 about (1, 0, 0)
  EXPECT_NEAR(c.radius(), Vec3(1.25, 0.25, 0.25).norm(), 1e-12);
  // a surface's mesh over the region's x-y is inside it: the bowl z = (x^2 + y^2) / 2 at the
  // corners (+-1, +-2) is 2.5 m high
  const SceneDescription bowl =
      parseScene("surfaces: {ground: {type: bowl, coefficients: [1, 1]}}\n" + scene +
                     "region: {low: [-1, -2, -3], high: [1, 2, 0.1]}\n",
                 "test.yaml");
  EXPECT_DOUBLE_EQ(sceneRegion(bowl, buildScene(bowl).initial_state).high.z(), 2.5);
  // a longer chain than the file drew its region for: the region follows the chain
  SceneDescription surface_chain = loadSceneFile(DIRECTORY + "/surface_chain.yaml");
  ASSERT_TRUE(surface_chain.region);
  ChainChange longer;
  longer.num_particles = 40;
  longer.link_length = 0.5;
  setChains(surface_chain, longer);
  EXPECT_FALSE(surface_chain.region);
  const BuiltScene built = buildScene(surface_chain);
  const RegionSpec follows = sceneRegion(surface_chain, built.initial_state);
  EXPECT_LE(follows.low.z(), built.initial_state.positions(2, 0) - 19.5);
  expectRefused(scene + "region: {low: [0, 0, 1], high: [1, 1, 0]}\n",
                { "test.yaml:2", "region.high.z", "must be >= low.z" });
  expectRefused(scene + "region: {low: [0, 0, .nan], high: [1, 1, 1]}\n",
                { "region.low.z", "must be in" });
  expectRefused(scene + "region: {low: [0, 0, 0], top: [1, 1, 1]}\n", { "region", "top" });
}
