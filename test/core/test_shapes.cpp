/// @file test_shapes.cpp
/// @brief Obstacle shapes (shapes.hpp) and shape_contact against finite differences and closed
/// forms: each shape's signed distance has the gradient and Hessian its differences give, in
/// every region (face, edge, corner, cap, rim, inside); a bead leaves a sphere obstacle where the
/// energy balance says; a rope over a frictionless cylinder balances equal weights, and over one
/// with friction holds the capstan ratio e^(mu theta) and no more; a ball
/// bounces off a box to e^2 of its height; scene files read shapes and name what is wrong.
#include "capstan_rope.hpp"
#include "test_helpers.hpp"

#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

using namespace constrained_particles;
using constrained_particles::testing::G;
using constrained_particles::testing::shapeOf;

namespace
{
// central differences of the distance (gradient) and of the gradient (Hessian) at p
void expectDerivativesMatchDifferences(const Shape& shape, const Vec3& p, const std::string& where)
{
  const double h = 1e-6;
  const ShapeSample s = evaluateShape(shape, p);
  EXPECT_NEAR(s.normal.norm(), 1.0, 1e-12) << where;
  for (int axis = 0; axis < 3; ++axis)
  {
    const Vec3 e = h * Vec3::Unit(axis);
    const ShapeSample plus = evaluateShape(shape, p + e), minus = evaluateShape(shape, p - e);
    EXPECT_NEAR(s.normal[axis], (plus.distance - minus.distance) / (2 * h), 1e-7)
        << where << " gradient " << axis;
    const Vec3 column = (plus.normal - minus.normal) / (2 * h);
    for (int row = 0; row < 3; ++row)
      EXPECT_NEAR(s.hessian(row, axis), column[row], 2e-5) << where << " hessian " << row << axis;
  }
}

StepSettings settingsOf(double dt)
{
  StepSettings settings;
  settings.dt = dt;
  settings.integrator = "rk4";
  return settings;
}

ShapeContact contactWith(int particle, const Shape& shape, double radius = 0.0,
                         double friction = 0.0, double restitution = 0.0)
{
  return ShapeContact{ particle, shape, radius, friction, restitution };
}
}  // namespace

// Every region of every shape, turned and moved: the gradient and Hessian are the distance's.
TEST(Shapes, DerivativesMatchFiniteDifferencesInEveryRegion)
{
  const Vec3 at(0.3, -0.2, 0.5), rpy(0.3, -0.5, 1.1);
  const Eigen::Matrix3d r = rotationFromRpy(rpy);
  auto world = [&](const Vec3& local) { return Vec3(at + r * local); };
  struct Case
  {
    ShapeType type;
    Vec3 local;
    const char* region;
  };
  const Case cases[] = {
    { ShapeType::Plane, Vec3(0.3, 0.1, 0.2), "plane above" },
    { ShapeType::Plane, Vec3(0.3, 0.1, -0.2), "plane below" },
    { ShapeType::Sphere, Vec3(0.4, 0.2, 0.3), "sphere outside" },
    { ShapeType::Sphere, Vec3(0.1, 0.05, 0.1), "sphere inside" },
    { ShapeType::Box, Vec3(0.1, 0.1, 0.7), "box face" },
    { ShapeType::Box, Vec3(0.35, 0.1, 0.7), "box edge" },
    { ShapeType::Box, Vec3(0.35, 0.5, 0.7), "box corner" },
    { ShapeType::Box, Vec3(0.15, 0.05, 0.1), "box inside" },
    { ShapeType::Capsule, Vec3(0.3, 0.2, 0.1), "capsule side" },
    { ShapeType::Capsule, Vec3(0.2, 0.1, 0.7), "capsule cap" },
    { ShapeType::Capsule, Vec3(0.1, 0.05, 0.2), "capsule inside" },
    { ShapeType::Cylinder, Vec3(0.3, 0.3, 0.1), "cylinder side" },
    { ShapeType::Cylinder, Vec3(0.1, 0.05, 0.7), "cylinder end" },
    { ShapeType::Cylinder, Vec3(0.4, 0.2, 0.6), "cylinder rim" },
    { ShapeType::Cylinder, Vec3(0.25, 0.02, 0.1), "cylinder inside, side nearest" },
    { ShapeType::Cylinder, Vec3(0.02, 0.01, 0.35), "cylinder inside, end nearest" },
  };
  for (const Case& c : cases)
    expectDerivativesMatchDifferences(shapeOf(c.type, at, rpy), world(c.local), c.region);
}

// Distances every reader can check by hand.
TEST(Shapes, DistancesAreTheClosedForms)
{
  const Shape sphere = shapeOf(ShapeType::Sphere, Vec3(1, 2, 3));
  EXPECT_NEAR(evaluateShape(sphere, Vec3(1, 2, 4)).distance, 0.7, 1e-15);
  const Shape box = shapeOf(ShapeType::Box);  // half sides 0.2, 0.3, 0.4
  EXPECT_NEAR(evaluateShape(box, Vec3(0.5, 0.7, 0.8)).distance, std::sqrt(0.09 + 0.16 + 0.16),
              1e-15);
  EXPECT_NEAR(evaluateShape(box, Vec3(0.1, 0.0, 0.0)).distance, -0.1, 1e-15);
  const Shape capsule = shapeOf(ShapeType::Capsule);  // segment z in [-0.4, 0.4], radius 0.3
  EXPECT_NEAR(evaluateShape(capsule, Vec3(0.0, 0.0, 1.0)).distance, 0.3, 1e-15);
  EXPECT_NEAR(evaluateShape(capsule, Vec3(0.5, 0.0, 0.2)).distance, 0.2, 1e-15);
  const Shape cylinder = shapeOf(ShapeType::Cylinder);  // z in [-0.4, 0.4], radius 0.3
  EXPECT_NEAR(evaluateShape(cylinder, Vec3(0.6, 0.0, 0.8)).distance, 0.5, 1e-15);
  // a plane turned by roll pi/2: its normal, the local z, is the world's -y
  const Shape wall = shapeOf(ShapeType::Plane, Vec3::Zero(), Vec3(M_PI / 2, 0, 0));
  EXPECT_NEAR(evaluateShape(wall, Vec3(0.0, -2.0, 5.0)).distance, 2.0, 1e-12);
}

// A bead of radius r released at speed v0 from the top of a sphere obstacle of radius R leaves
// it where gravity's normal part no longer holds it on: its centre at height
// (R + r) (2 + v0^2 / (g (R + r))) / 3 over the sphere's.
TEST(ShapeContact, BeadLeavesASphereWhereTheEnergyBalanceSays)
{
  for (const double bead : { 0.0, 0.1 })
  {
    const double radius = 0.9, v0 = 0.05, reach = radius + bead;
    const Vec3 centre(1.0, 2.0, 0.5);
    Shape sphere = shapeOf(ShapeType::Sphere, centre);
    sphere.radius = radius;
    Scene scene;
    scene.masses = { 1.0 };
    scene.forces = { GravityForce{} };
    scene.constraints = { contactWith(0, sphere, bead) };
    State start;
    start.positions = centre + Vec3(0.0, 0.0, reach);
    start.velocities = Vec3(v0, 0.0, 0.0);
    Simulator sim(scene, start, settingsOf(1e-4));
    double last_force = -1.0, last_z = 0.0, left_at = NAN;
    for (int k = 0; k < 20000 && std::isnan(left_at); ++k)
    {
      ASSERT_EQ(sim.step().failed_check, StepCheck::None) << k;
      const ContactState& contact = sim.data().contacts[0];
      const double z = sim.state().positions(2, 0) - centre.z();
      // the multiplier crosses 0 between two steps: the height there, interpolated
      if (last_force > 0.0 && contact.normal_force <= 0.0)
        left_at = last_z + (z - last_z) * last_force / (last_force - contact.normal_force);
      if (contact.mode == ContactMode::Separated && std::isnan(left_at))
        FAIL() << "switched off at z = " << z << " before its force was seen crossing 0";
      last_force = contact.normal_force;
      last_z = z;
    }
    ASSERT_FALSE(std::isnan(left_at)) << "the bead never left the sphere";
    const double expected = reach * (2.0 + v0 * v0 / (G * reach)) / 3.0;
    EXPECT_NEAR(left_at, expected, 2e-4 * radius) << "bead radius " << bead;
    std::cout << "bead of radius " << bead << " leaves the sphere " << (left_at - expected) / radius
              << " R from the closed form\n";
    // on the sphere until then, exactly: the projection holds it at the tolerance
    const double gap = (sim.state().positions.col(0) - centre).norm() - reach;
    EXPECT_GT(gap, -1e-9);
    // and it flies clear: never inside the sphere again before it falls past its equator
    double lowest_gap = INFINITY;
    while (sim.state().positions(2, 0) > centre.z())
    {
      sim.step();
      lowest_gap = std::min(lowest_gap, (sim.state().positions.col(0) - centre).norm() - reach);
      ASSERT_EQ(sim.data().contacts[0].mode, ContactMode::Separated);
    }
    EXPECT_GT(lowest_gap, -1e-12);
  }
}

// A rope of radius r draped over a frictionless horizontal cylinder, equal weights on its ends:
// it stays where it is, each particle on the cylinder or hanging straight, nothing inside.
TEST(ShapeContact, RopeOverAFrictionlessCylinderBalancesEqualWeights)
{
  const double radius = 0.2, rope = 0.01, reach = radius + rope;
  const int arc = 16, hanging = 5;  // links on the half circle; links down each side
  // the cylinder's axis (its local z) along the world y: roll pi/2
  Shape cylinder = shapeOf(ShapeType::Cylinder, Vec3::Zero(), Vec3(M_PI / 2, 0.0, 0.0));
  cylinder.radius = radius;
  cylinder.length = 1.0;
  const double link = 2.0 * reach * std::sin(M_PI / (2 * arc));
  std::vector<Vec3> points;
  for (int k = hanging; k > 0; --k)
    points.push_back(Vec3(reach, 0.0, -k * link));
  for (int k = 0; k <= arc; ++k)
  {
    const double theta = M_PI * k / arc;
    points.push_back(Vec3(reach * std::cos(theta), 0.0, reach * std::sin(theta)));
  }
  for (int k = 1; k <= hanging; ++k)
    points.push_back(Vec3(-reach, 0.0, -k * link));
  const int n = static_cast<int>(points.size());
  Scene scene;
  scene.masses.assign(n, 0.01);
  scene.masses.front() = scene.masses.back() = 1.0;  // the weights
  scene.forces = { GravityForce{} };
  State start;
  start.positions.resize(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
  {
    start.positions.col(i) = points[i];
    scene.constraints.push_back(contactWith(i, cylinder, rope));
  }
  for (int i = 0; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, link });
  Simulator sim(scene, start, settingsOf(1e-3));
  for (int k = 0; k < 1000; ++k)
    ASSERT_EQ(sim.step().failed_check, StepCheck::None) << k;
  double moved = 0.0, deepest = 0.0;
  for (int i = 0; i < n; ++i)
  {
    moved = std::max(moved, (sim.state().positions.col(i) - points[i]).norm());
    deepest =
        std::max(deepest, -(evaluateShape(cylinder, sim.state().positions.col(i)).distance - rope));
  }
  EXPECT_LT(moved, 1e-9) << "after 1 s";
  EXPECT_LE(deepest, sim.stepSettings().projection_tolerance);
  // the arc carries the weights: every particle on it touches
  for (int k = 0; k <= arc; ++k)
    EXPECT_NE(sim.data().contacts[hanging + k].mode, ContactMode::Separated) << k;
  // and a heavier weight on one side pulls the rope its way
  scene.masses.back() = 1.5;
  Simulator uneven(scene, start, settingsOf(1e-3));
  uneven.step(100);
  EXPECT_LT(uneven.state().positions(2, n - 1), points.back().z() - 1e-3);
  EXPECT_GT(uneven.state().positions(2, 0), points.front().z() + 1e-3);
}

// The capstan equation: a rope over a fixed cylinder with friction mu, pulled down at both ends
// (no gravity, light particles), holds while the tension ratio is under e^(mu theta) and slips
// above it. On the particles' arc each contact turns the rope by delta (the end ones by delta /
// 2) and holds at most (1 + mu tan(delta / 2)) / (1 - mu tan(delta / 2)); their product is
// e^(mu pi) to 6e-4 here (capstan_rope.hpp). At 0.999 of it the rope's end stays within 1e-9 m
// (the friction iteration crept 8.7 mm before its Anderson mixing), at 1.001 it slips.
TEST(ShapeContact, RopeOverACylinderHoldsTheCapstanRatio)
{
  const double mu = 0.3;
  EXPECT_NEAR(capstanRope(mu, 1.0).ratio / std::exp(mu * M_PI), 1.0, 1e-3);
  // how far the heavier end moves in 0.5 s at `load` times the ratio [m]
  auto slipAt = [mu](double load)
  {
    const CapstanRope rope = capstanRope(mu, load);
    Simulator sim(rope.scene, rope.start, settingsOf(1e-3));
    EXPECT_EQ(sim.step(500).failed_check, StepCheck::None) << load;
    return (sim.state().positions.col(0) - rope.start.positions.col(0)).norm();
  };
  EXPECT_LT(slipAt(1.0 - 1e-3), 1e-9) << "after 0.5 s";
  EXPECT_GT(slipAt(1.0 + 1e-3), 1e-3) << "after 0.5 s";
}

// A ball dropped on a box (turned about z, so its top stays level) bounces to e^2 of its height,
// and comes to rest on it.
TEST(ShapeContact, BallBouncesOffABoxToRestitutionSquaredHeight)
{
  const double h = 1.0, e = 0.5, ball = 0.05;
  Shape box = shapeOf(ShapeType::Box, Vec3(0.0, 0.0, -0.5), Vec3(0.0, 0.0, 0.7));
  box.size = Vec3(2.0, 2.0, 1.0);  // top face at z = 0
  Scene scene;
  scene.masses = { 1.0 };
  scene.forces = { GravityForce{} };
  scene.constraints = { contactWith(0, box, ball, 0.0, e) };
  State start;
  start.positions = Vec3(0.1, 0.2, h + ball);
  start.velocities = Vec3::Zero();
  Simulator sim(scene, start, settingsOf(1e-4));
  bool bounced = false;
  double top = 0.0;
  for (int k = 0; k < 20000; ++k)
  {
    sim.step();
    const double z = sim.state().positions(2, 0) - ball, vz = sim.state().velocities(2, 0);
    bounced = bounced || vz > 0.0;
    if (bounced)
      top = std::max(top, z);
    if (bounced && vz < 0.0)
      break;
  }
  ASSERT_TRUE(bounced);
  EXPECT_NEAR(top, e * e * h, 2e-3 * h);
  sim.step(100000);
  EXPECT_LE(kineticEnergy(sim.model(), sim.state()), 1e-12);
  EXPECT_NE(sim.data().contacts[0].mode, ContactMode::Separated);
  EXPECT_NEAR(sim.state().positions(2, 0), ball, 1e-9);
}

// A ball of radius 1 cm sliding down a box's side face (at rest against it, frictionless) rolls
// over its bottom edge and falls straight on, its energy kept: its contact is let go where its
// force crosses 0 within the step (releaseFraction), not held round the edge's rounding for the
// rest of the step (6 cm off the fall by 0.4 s); a point there was shot through the box.
TEST(ShapeContact, ABallFallsPastABoxEdgeAsIfTheBoxWereNotThere)
{
  for (const std::string integrator :
       { "rk4", "velocity_verlet", "semi_implicit_euler", "midpoint", "dopri5" })
  {
    Shape box = shapeOf(ShapeType::Box);
    box.size = Vec3(0.4, 0.4, 0.4);
    Scene scene;
    scene.masses = { 1.0 };
    scene.forces = { GravityForce{} };
    scene.constraints = { contactWith(0, box, 0.01) };
    State start;
    start.positions = Vec3(0.21, 0.0, 0.1);
    start.velocities = Vec3::Zero();
    StepSettings settings;
    settings.dt = 1e-3;
    settings.integrator = integrator;
    Simulator sim(scene, start, settings);
    // the same fall with no box: the same method's own path, which the ball's must be
    scene.constraints.clear();
    Simulator free(scene, start, settings);
    for (int k = 0; k < 400; ++k)
    {
      ASSERT_EQ(sim.step().failed_check, StepCheck::None) << integrator << " step " << k;
      free.step();
    }
    const Vec3 p = sim.state().positions.col(0), v = sim.state().velocities.col(0);
    const Vec3 p_free = free.state().positions.col(0), v_free = free.state().velocities.col(0);
    std::cout << integrator << ": past the edge, off the fall without the box by "
              << (p - p_free).norm() << " m, " << (v - v_free).norm() << " m/s\n";
    EXPECT_LE((p - p_free).norm(), 1e-9) << integrator;
    EXPECT_LE((v - v_free).norm(), 1e-9) << integrator;
    EXPECT_LT(p.z(), -0.6);  // 0.785 m down from z = 0.1
  }
}

// Scene files: named shapes, a chain's obstacles and radius; what is wrong is named with its line.
TEST(ShapeContact, SceneFilesReadShapesAndNameWhatIsWrong)
{
  const std::string good = R"(
shapes:
  post: {type: cylinder, position: [0, 0, 0], rpy: [1.5707963267948966, 0, 0], radius: 0.1,
         length: 1}
  ground: {type: plane, position: [0, 0, -1]}
chains:
  - {particles: 4, link_length: 0.1, start: [-0.15, 0, 0.2], obstacles: [post, ground],
     radius: 0.01, friction: 0.3}
forces:
  - {type: gravity}
)";
  const BuiltScene built = buildScene(parseScene(good, "good.yaml"));
  int contacts = 0;
  for (const Constraint& c : built.scene.constraints)
    if (const auto* contact = std::get_if<ShapeContact>(&c))
    {
      ++contacts;
      EXPECT_DOUBLE_EQ(contact->radius, 0.01);
      EXPECT_DOUBLE_EQ(contact->friction, 0.3);
    }
  EXPECT_EQ(contacts, 8);  // 4 particles x 2 obstacles
  const Model model = Model::compile(built.scene);
  EXPECT_EQ(model.numParticleContacts(), 8);

  auto refusal = [](const std::string& text)
  {
    try
    {
      buildScene(parseScene(text, "bad.yaml"));
    }
    catch (const InvalidInput& e)
    {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string unknown = refusal(R"(
shapes: {post: {type: sphere, radius: 0.1}}
chains: [{particles: 2, start: [0, 0, 1], obstacles: [pole]}]
)");
  EXPECT_NE(unknown.find("obstacles[0]"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("defined: post"), std::string::npos) << unknown;
  const std::string radius = refusal(R"(
shapes: {post: {type: sphere, radius: -0.1}}
chains: [{particles: 2, start: [0, 0, 1], obstacles: [post]}]
)");
  EXPECT_NE(radius.find("shapes.post.radius"), std::string::npos) << radius;
  EXPECT_NE(radius.find(limits::SHAPE_SIZE.text()), std::string::npos) << radius;
  const std::string key = refusal(R"(
shapes: {post: {type: sphere, radius: 0.1, length: 2}}
chains: [{particles: 2, start: [0, 0, 1], obstacles: [post]}]
)");
  EXPECT_NE(key.find("length"), std::string::npos) << key;
  const std::string type = refusal(R"(
shapes: {post: {type: torus}}
chains: [{particles: 2, start: [0, 0, 1], obstacles: [post]}]
)");
  EXPECT_NE(type.find("capsule"), std::string::npos) << type;
  // a particle starting inside an obstacle: refused, naming it and how deep
  const std::string inside = refusal(R"(
shapes: {ball: {type: sphere, position: [0, 0, 0], radius: 0.5}}
chains: [{particles: 3, link_length: 0.3, start: [0, 0, 0.1], obstacles: [ball]}]
)");
  EXPECT_NE(inside.find("inside obstacle 'ball' (a sphere)"), std::string::npos) << inside;
  EXPECT_NE(inside.find("particle 0 position"), std::string::npos) << inside;
  // a wrong type names its key and line
  const std::string word = refusal(R"(
shapes: {post: {type: sphere, radius: big}}
chains: [{particles: 2, start: [0, 0, 1], obstacles: [post]}]
)");
  EXPECT_NE(word.find("bad.yaml:2: shapes.post.radius"), std::string::npos) << word;
  // a record must name its obstacle; a chain may not list one twice
  const std::string unnamed = refusal(R"(
particles: [{position: [0, 0, 1]}]
constraints: [{type: shape_contact, particle: 0}]
)");
  EXPECT_NE(unnamed.find("constraints[0].shape is missing"), std::string::npos) << unnamed;
  const std::string twice = refusal(R"(
shapes: {post: {type: sphere, radius: 0.1}}
chains: [{particles: 2, start: [0, 0, 1], obstacles: [post, post]}]
)");
  EXPECT_NE(twice.find("obstacles[1]"), std::string::npos) << twice;
  // a point against a box's sharp edges: refused, naming the chain's radius
  const std::string point = refusal(R"(
shapes: {block: {type: box, position: [0, 0, 0], size: [0.4, 0.4, 0.4]}}
chains: [{particles: 2, start: [0, 0, 1], obstacles: [block]}]
)");
  EXPECT_NE(point.find("chains[0].radius = 0 against box 'block', must be > 0"), std::string::npos)
      << point;
  // a record repeating what a chain's obstacles made: the model refuses the second row
  const BuiltScene doubled = buildScene(parseScene(R"(
shapes: {post: {type: sphere, radius: 0.1}}
chains: [{particles: 2, start: [0, 0, 1], obstacles: [post]}]
constraints: [{type: shape_contact, particle: 1, shape: post}]
)",
                                                   "doubled.yaml"));
  try
  {
    Model::compile(doubled.scene);
    ADD_FAILURE() << "two contacts of particle 1 with 'post' accepted";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_NE(std::string(e.what()).find("keeps particle 1 out already"), std::string::npos)
        << e.what();
  }
}

// ~set_obstacle's scene change (changeObstacle): an added shape is kept out by every chain with
// its radius, friction and capsules; a replaced one everywhere it is named (a chain's obstacles
// and a listed record); a removed one nowhere; each refusal names its field and changes nothing.
TEST(ShapeContact, ObstaclesAddedReplacedAndRemovedInASceneDescription)
{
  const SceneDescription scene = parseScene(R"(
name: two_posts
shapes:
  post: {type: sphere, position: [0, 0, 0], radius: 0.1}
  hand: {type: sphere, radius: 0.1, frame: gripper}
chains:
  - {particles: 4, link_length: 0.1, start: [-0.15, 0, 0.5], obstacles: [post], radius: 0.01,
     friction: 0.3, capsules: true}
constraints: [{type: shape_contact, particle: 0, shape: hand}]
particles: [{position: [2, 0, 0.5]}]
)",
                                            "two_posts.yaml");
  auto records = [](const SceneDescription& d, const std::string& name, bool segments)
  {
    int count = 0;
    for (const Constraint& c : buildScene(d, false).scene.constraints)
    {
      if (const auto* contact = std::get_if<ShapeContact>(&c); contact && !segments)
        count += contact->shape.name == name;
      if (const auto* segment = std::get_if<SegmentContact>(&c); segment && segments)
        count += segment->shape.name == name;
    }
    return count;
  };
  // added: 4 particles and 3 links keep out of it, with the chain's radius and friction
  SceneDescription added = scene;
  changeObstacle(added, ObstacleChange::Add, "block",
                 "{type: box, position: [0, 0, 0.5], size: [0.4, 0.4, 0.1]}");
  EXPECT_EQ(added.shapes.size(), 3u);
  EXPECT_EQ(records(added, "block", false), 4);
  EXPECT_EQ(records(added, "block", true), 3);
  for (const Constraint& c : buildScene(added, false).scene.constraints)
    if (const auto* contact = std::get_if<ShapeContact>(&c);
        contact && contact->shape.name == "block")
    {
      EXPECT_DOUBLE_EQ(contact->radius, 0.01);
      EXPECT_DOUBLE_EQ(contact->friction, 0.3);
      EXPECT_DOUBLE_EQ(contact->shape.size.z(), 0.1);
    }
  // the chain starts inside it: a scene file would be refused, ~set_obstacle's build is not
  EXPECT_THROW(buildScene(added), InvalidInput);
  // replaced: moved and grown wherever it is named
  SceneDescription replaced = scene;
  changeObstacle(replaced, ObstacleChange::Replace, "post",
                 "{type: sphere, position: [0, 0, -1], radius: 0.3}");
  for (const Constraint& c : buildScene(replaced, false).scene.constraints)
    if (const auto* contact = std::get_if<ShapeContact>(&c);
        contact && contact->shape.name == "post")
    {
      EXPECT_DOUBLE_EQ(contact->shape.radius, 0.3);
      EXPECT_DOUBLE_EQ(contact->shape.position.z(), -1.0);
    }
  EXPECT_EQ(records(replaced, "post", false), 4);
  // removed: from shapes, the chain's obstacles and its records
  SceneDescription removed = scene;
  changeObstacle(removed, ObstacleChange::Remove, "post", "");
  EXPECT_EQ(removed.shapes.size(), 1u);
  EXPECT_TRUE(removed.chains[0].obstacles.empty());
  EXPECT_EQ(records(removed, "post", false), 0);
  EXPECT_EQ(records(removed, "post", true), 0);
  EXPECT_EQ(records(removed, "hand", false), 1);  // the other shape's record stays

  auto refusal = [&scene](ObstacleChange change, const std::string& name, const std::string& yaml)
  {
    SceneDescription changed = scene;
    try
    {
      changeObstacle(changed, change, name, yaml);
    }
    catch (const InvalidInput& e)
    {
      EXPECT_EQ(changed.shapes.size(), scene.shapes.size());
      EXPECT_EQ(changed.chains[0].obstacles, scene.chains[0].obstacles);
      EXPECT_EQ(changed.constraints.size(), scene.constraints.size());
      return std::string(e.what());
    }
    ADD_FAILURE() << name << ": " << yaml << " accepted";
    return std::string();
  };
  const std::string sphere = "{type: sphere, radius: 0.1}";
  EXPECT_EQ(refusal(ObstacleChange::Add, "", sphere).rfind("name is empty", 0), 0u);
  EXPECT_NE(refusal(ObstacleChange::Add, "post", sphere).find("name = 'post' is a shape"),
            std::string::npos);
  const std::string unknown = refusal(ObstacleChange::Replace, "pole", sphere);
  EXPECT_NE(unknown.find("its shapes: post, hand"), std::string::npos) << unknown;
  const std::string range = refusal(ObstacleChange::Add, "ball", "{type: sphere, radius: -0.1}");
  EXPECT_NE(range.find("shape:1: radius"), std::string::npos) << range;
  EXPECT_NE(range.find(limits::SHAPE_SIZE.text()), std::string::npos) << range;
  const std::string key = refusal(ObstacleChange::Add, "ball", "{type: sphere, size: [1, 1, 1]}");
  EXPECT_NE(key.find("size"), std::string::npos) << key;
  const std::string yaml = refusal(ObstacleChange::Add, "ball", "{type: sphere, radius: [");
  EXPECT_NE(yaml.find("shape"), std::string::npos) << yaml;
  const std::string slash =
      refusal(ObstacleChange::Add, "ball", "{type: sphere, radius: 0.1, frame: /tool0}");
  EXPECT_NE(slash.find("shape:1: frame"), std::string::npos) << slash;
  EXPECT_NE(slash.find("no leading /"), std::string::npos) << slash;
  const std::string both =
      refusal(ObstacleChange::Add, "ball", "{type: sphere, frame: a, topic: b}");
  EXPECT_NE(both.find("not both"), std::string::npos) << both;
  // carried shapes change as fixed ones do: added on a frame, a carried one retyped onto a topic,
  // a carried one removed with its records (the lone particle's contact with the hand)
  SceneDescription carried = scene;
  changeObstacle(carried, ObstacleChange::Add, "thumb",
                 "{type: capsule, frame: tool0, radius: 0.02, length: 0.1}");
  EXPECT_EQ(carried.shapes.back().frame, "tool0");
  EXPECT_EQ(records(carried, "thumb", false), 4);
  EXPECT_EQ(records(carried, "thumb", true), 3);
  changeObstacle(carried, ObstacleChange::Replace, "hand",
                 "{type: sphere, radius: 0.2, topic: /hand_pose}");
  for (const Constraint& c : buildScene(carried, false).scene.constraints)
    if (const auto* contact = std::get_if<ShapeContact>(&c);
        contact && contact->shape.name == "hand")
    {
      EXPECT_EQ(contact->shape.topic, "/hand_pose");
      EXPECT_TRUE(contact->shape.frame.empty());
      EXPECT_DOUBLE_EQ(contact->shape.radius, 0.2);
    }
  changeObstacle(carried, ObstacleChange::Remove, "hand", "");
  EXPECT_EQ(records(carried, "hand", false), 0);
  EXPECT_EQ(carried.shapes.size(), 2u);
  const std::string text = refusal(ObstacleChange::Remove, "post", sphere);
  EXPECT_NE(text.find("shape must be empty"), std::string::npos) << text;
  SceneDescription rounded = scene;  // the chain's radius is 0.01: a box's edges rounded
  EXPECT_NO_THROW(changeObstacle(rounded, ObstacleChange::Add, "block", "{type: box}"));
  SceneDescription point = scene;
  point.chains[0].radius = 0.0;
  EXPECT_THROW(changeObstacle(point, ObstacleChange::Add, "block", "{type: box}"), InvalidInput);
  SceneDescription beads = scene;
  beads.chains.clear();
  try
  {
    changeObstacle(beads, ObstacleChange::Add, "ball", sphere);
    ADD_FAILURE() << "an obstacle added to a scene with no chain";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_EQ(e.field(), "operation");
  }
}
