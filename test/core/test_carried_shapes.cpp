/// @file test_carried_shapes.cpp
/// @brief Obstacles carried by a holder (Shape::frame / topic, their paths in Data::carriers):
/// the contact row's dC/dt and Cddot - J a against finite differences along a moving, turning
/// shape; a plane rising at constant speed and at constant acceleration carries a particle with
/// the normal force m (g + a) exactly and the energy ledger balanced by the work it books; a
/// sphere sweeping into a particle at rest sends it off at (1 + e) times its speed.
#include "test_helpers.hpp"

#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/robot_shapes.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include "stages.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>

using namespace constrained_particles;
using constrained_particles::testing::G;

namespace
{
Shape carried(ShapeType type, const std::string& frame)
{
  Shape shape;
  shape.name = "carried";
  shape.type = type;
  shape.frame = frame;
  shape.radius = 0.3;
  shape.length = 0.8;
  shape.size = Vec3(0.4, 0.6, 0.8);
  return shape;
}

// A track through path(t) (origin) and turn(t) sampled every `period` from `from` to `to` [s],
// resting at path(from - period) before: from `from` on, its intervals are the spline's through
// these samples (exact for paths of degree 2 and less after the first interval)
AnchorTrack trackOf(const std::function<Vec3(double)>& path,
                    const std::function<Eigen::Quaterniond(double)>& turn, double from, double to,
                    double period)
{
  AnchorTrack track;
  const double start = from - period;
  track.restart(path(start), turn(start));
  for (double t = from; t <= to + 1e-12; t += period)
  {
    AnchorSample sample;
    sample.time = t;
    sample.position = path(t);
    sample.orientation = turn(t);
    EXPECT_EQ(track.append(sample, start), AnchorTrack::Append::Taken) << t;
  }
  return track;
}

Eigen::Quaterniond still(double)
{
  return Eigen::Quaterniond::Identity();
}

StepSettings settingsOf(double dt, const std::string& integrator = "rk4")
{
  StepSettings settings;
  settings.dt = dt;
  settings.integrator = integrator;
  return settings;
}
// A rope of n 0.1 kg particles on 0.1 m links laid along +x on the plane surface z = 0, a
// surface_contact each, and `extra` records, under gravity, rk4 at dt 1 ms
Simulator ropeOnPlane(int n, const std::vector<Constraint>& extra)
{
  Scene scene;
  scene.masses.assign(n, 0.1);
  scene.surfaces = { makeSurface(SurfaceType::Plane, { 0.0, 0.0, 0.0 }, "surface") };
  scene.forces = { GravityForce{} };
  for (int i = 0; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, 0.1 });
  for (int i = 0; i < n; ++i)
    scene.constraints.push_back(SurfaceContact{ i, 0 });
  scene.constraints.insert(scene.constraints.end(), extra.begin(), extra.end());
  State start;
  start.positions.setZero(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
    start.positions(0, i) = 0.1 * i;
  return Simulator(scene, start, settingsOf(1e-3));
}

// How far ropeOnPlane's rope is off what holds it [m]: the deepest a particle went into `ball`,
// the worst link's error (0.1 m links) and the deepest into the plane z = 0
std::array<double, 3> ropeErrors(const Points& p, const Shape& ball)
{
  double inside = 0.0, link = 0.0, below = 0.0;
  for (int i = 0; i < p.cols(); ++i)
  {
    inside = std::max(inside, -evaluateShape(ball, p.col(i)).distance);
    below = std::max(below, -p(2, i));
    if (i + 1 < p.cols())
      link = std::max(link, std::abs((p.col(i + 1) - p.col(i)).norm() - 0.1));
  }
  return { { inside, link, below } };
}

// A sphere named "ball" of `radius` [m] at the origin
Shape ballOf(double radius)
{
  Shape ball;
  ball.name = "ball";
  ball.type = ShapeType::Sphere;
  ball.radius = radius;
  return ball;
}

// A shape_contact with `ball` for each of n particles, the ball moved to `centre` first
std::vector<Constraint> contactsAround(Shape& ball, int n, const Vec3& centre)
{
  ball.position = centre;
  std::vector<Constraint> contacts;
  for (int i = 0; i < n; ++i)
    contacts.push_back(ShapeContact{ i, ball, 0.0 });
  return contacts;
}
}  // namespace

// A box and a capsule moving along a curved path and turning at a constant rate: along a
// particle's path p(t) = p0 + v t + a t^2 / 2, the row's C(t) has the rate J v + dC/dt and the
// second derivative J a + curvature_term that central differences in time give (the moving and
// turning terms derived in shape_contact.hpp).
TEST(CarriedShapes, RowRatesMatchFiniteDifferencesAlongAMovingTurningShape)
{
  const auto path = [](double t)
  { return Vec3(0.3 * t + 0.2 * t * t, -0.1 * t, 0.5 - 0.4 * t * t); };
  const Vec3 axis = Vec3(0.3, -0.5, 0.8).normalized();
  const auto turn = [axis](double t)
  { return Eigen::Quaterniond(Eigen::AngleAxisd(0.2 + 1.3 * t, axis)); };
  std::vector<AnchorTrack> carriers{ trackOf(path, turn, 0.0, 2.0, 0.25) };
  for (const ShapeType type : { ShapeType::Box, ShapeType::Capsule, ShapeType::Sphere })
  {
    Shape shape = carried(type, "hand");
    shape.position = Vec3(0.1, 0.05, -0.2);  // off the frame's origin: its turn moves it
    shape.rotation = rotationFromRpy(Vec3(0.3, 0.1, -0.4));
    ShapeContact contact{ 0, shape, 0.05 };
    contact.carrier = 0;
    const Vec3 p0(0.9, 0.4, 0.1), v(0.7, -0.3, 0.2), a(0.5, 0.1, -0.8);
    const double t0 = 0.6;  // inside an interval: the track is smooth there
    auto at = [&](double s)
    {
      Points p(3, 1), pv(3, 1);
      p.col(0) = p0 + v * s + 0.5 * a * s * s;
      pv.col(0) = v + a * s;
      return contactFrame(contact, EffectContext{ {}, t0 + s, nullptr, &carriers }, p, pv);
    };
    const ContactFrame f = at(0.0);
    ASSERT_GT(f.surface_velocity.norm(), 0.1) << shapeTypeName(type);
    const double h = 1e-4;
    const double rate = (at(h).gap - at(-h).gap) / (2 * h);
    const double second = (at(h).gap - 2 * f.gap + at(-h).gap) / (h * h);
    EXPECT_NEAR(f.normal.dot(v) + f.timeRate(), rate, 1e-7) << shapeTypeName(type);
    EXPECT_NEAR(f.normal.dot(a) + f.curvature_term, second, 2e-5) << shapeTypeName(type);
  }
}

// The angular velocity a track turns at between two samples is the slerp's: the orientation's
// derivative, dR/dt = [omega]x R.
TEST(CarriedShapes, TrackAngularVelocityIsTheSlerpsRate)
{
  const Vec3 axis = Vec3(1.0, 2.0, -0.5).normalized();
  const auto turn = [axis](double t)
  { return Eigen::Quaterniond(Eigen::AngleAxisd(2.0 * t, axis)); };
  const AnchorTrack track = trackOf([](double) { return Vec3::Zero(); }, turn, 0.0, 1.0, 0.1);
  const double t = 0.43, h = 1e-6;
  const Eigen::Matrix3d derivative =
      (track.orientation(t + h).toRotationMatrix() - track.orientation(t - h).toRotationMatrix()) /
      (2 * h);
  const Vec3 omega = track.angularVelocity(t);
  Eigen::Matrix3d cross;
  cross << 0, -omega.z(), omega.y(), omega.z(), 0, -omega.x(), -omega.y(), omega.x(), 0;
  EXPECT_LT((derivative - cross * track.orientation(t).toRotationMatrix()).norm(), 1e-7);
  EXPECT_NEAR(omega.norm(), 2.0, 1e-9);  // samples 0.2 rad apart: the slerp's constant rate
  EXPECT_EQ(track.angularVelocity(5.0), Vec3::Zero());  // past the newest sample: still
}

// A floor on a frame rising at constant speed u, then with constant acceleration a: the particle
// resting on it rises with it (on it within the projection tolerance, its speed the floor's), the
// normal force is m (g + a) exactly, and the ledger books the floor's work (residual ~ 0).
TEST(CarriedShapes, RisingFloorCarriesAParticleWithTheNormalForceOfItsAcceleration)
{
  struct Case
  {
    double speed, acceleration;
  };
  for (const Case c : { Case{ 0.4, 0.0 }, Case{ 0.0, 2.5 }, Case{ 0.3, -1.5 } })
  {
    const auto path = [c](double t)
    { return Vec3(0.0, 0.0, c.speed * t + 0.5 * c.acceleration * t * t); };
    Scene scene;
    scene.masses = { 2.0 };
    scene.forces = { GravityForce{} };
    scene.constraints = { ShapeContact{ 0, carried(ShapeType::Plane, "lift") } };
    State start = constrained_particles::testing::stateOf(Points::Zero(3, 1), Points::Zero(3, 1));
    start.velocities(2, 0) = c.speed;  // moving with the floor
    Simulator sim(scene, start, settingsOf(1e-3));
    sim.carriers()[0] = trackOf(path, still, 0.0, 2.0, 0.1);
    // the ledger opened with the floor at rest (no track yet): its first step books half a
    // step's power short, the test's rewrite of the path at `now`, which appends never make
    ASSERT_EQ(sim.step().failed_check, StepCheck::None);
    const double first = sim.data().ledger.residual();
    for (int k = 1; k < 1000; ++k)
      ASSERT_EQ(sim.step().failed_check, StepCheck::None) << k;
    const double t = sim.state().time;
    const Vec3 floor = path(t);
    EXPECT_NEAR(sim.state().positions(2, 0), floor.z(), 1e-9) << c.speed << " " << c.acceleration;
    EXPECT_NEAR(sim.state().velocities(2, 0), c.speed + c.acceleration * t, 1e-9);
    ASSERT_EQ(sim.data().contacts.size(), 1u);
    EXPECT_NE(sim.data().contacts[0].mode, ContactMode::Separated);
    EXPECT_NEAR(sim.data().contacts[0].normal_force, 2.0 * (G + c.acceleration), 1e-9);
    const EnergyLedger& ledger = sim.data().ledger;
    EXPECT_GT(std::abs(ledger.work_in), 1.0);  // the floor's work is booked
    EXPECT_LT(std::abs(ledger.residual() - first), 1e-6 * std::abs(ledger.work_in))
        << "work in " << ledger.work_in;
  }
}

// A sphere carried at speed u into a particle at rest, head on (no gravity): Newton's impact law
// against a moving obstacle sends the particle off at (1 + e) u, and it never enters the sphere.
TEST(CarriedShapes, SweptSphereSendsAParticleOffAtOnePlusETimesItsSpeed)
{
  const double u = 2.0, radius = 0.3;
  for (const double e : { 0.0, 0.5, 1.0 })
    for (const double dt : { 1e-3, 1e-2 })
    {
      const auto path = [u](double t) { return Vec3(-1.0 + u * t, 0.0, 0.0); };
      Shape ball = carried(ShapeType::Sphere, "bat");
      ball.radius = radius;
      Scene scene;
      scene.masses = { 0.5 };
      scene.constraints = { ShapeContact{ 0, ball, 0.0, 0.0, e } };
      const State start =
          constrained_particles::testing::stateOf(Points::Zero(3, 1), Points::Zero(3, 1));
      Simulator sim(scene, start, settingsOf(dt));
      sim.carriers()[0] = trackOf(path, still, 0.0, 3.0, 0.05);
      double deepest = 0.0;
      while (sim.state().time < 1.0 - 1e-9)
      {
        ASSERT_EQ(sim.step().failed_check, StepCheck::None) << sim.state().time;
        const Vec3 centre = path(sim.state().time);
        deepest = std::max(deepest, radius - (Vec3(sim.state().positions.col(0)) - centre).norm());
      }
      // met at 0.35 s; by 1 s the particle is ahead of the ball, or (e = 0) on it, pushed
      const double expected = (1.0 + e) * u;
      EXPECT_NEAR(sim.state().velocities(0, 0), expected, 1e-6 * expected) << e << " " << dt;
      EXPECT_NEAR(sim.state().velocities.col(0).tail(2).norm(), 0.0, 1e-9);
      EXPECT_LT(deepest, 1e-8) << e << " " << dt;
    }
}

// A floor with friction mu accelerating sideways at a: under mu g the particle on it sticks and
// goes with it (friction m a, no drift against the floor); over mu g it slides, accelerated by
// friction alone at mu g (Coulomb, the slip relative to the floor).
TEST(CarriedShapes, AcceleratingFloorCarriesAParticleByFrictionUpToMuG)
{
  const double mu = 0.5, mass = 2.0;
  for (const double a : { 2.0, 7.0 })
  {
    const auto path = [a](double t) { return Vec3(0.5 * a * t * t, 0.0, 0.0); };
    Scene scene;
    scene.masses = { mass };
    scene.forces = { GravityForce{} };
    scene.constraints = { ShapeContact{ 0, carried(ShapeType::Plane, "cart"), 0.0, mu } };
    const State start =
        constrained_particles::testing::stateOf(Points::Zero(3, 1), Points::Zero(3, 1));
    Simulator sim(scene, start, settingsOf(1e-3));
    sim.carriers()[0] = trackOf(path, still, 0.0, 2.0, 0.1);
    for (int k = 0; k < 1000; ++k)
      ASSERT_EQ(sim.step().failed_check, StepCheck::None) << a << " " << k;
    const double t = sim.state().time;
    const bool sticks = a < mu * G;
    const double expected = sticks ? a : mu * G;  // the particle's acceleration
    EXPECT_NEAR(sim.state().velocities(0, 0), expected * t, 1e-9) << a;
    EXPECT_NEAR(sim.state().positions(0, 0), 0.5 * expected * t * t, 1e-9) << a;
    EXPECT_NEAR(sim.state().positions(2, 0), 0.0, 1e-12) << a;
    EXPECT_EQ(sim.data().contacts[0].mode, sticks ? ContactMode::Sticking : ContactMode::Sliding);
    EXPECT_NEAR(sim.data().contacts[0].friction_force.x(), mass * expected, 1e-9) << a;
    EXPECT_EQ(sim.data().control.unconverged_friction, 0);
  }
}

namespace
{
std::string testRobot()
{
  std::ifstream file(TEST_ROBOT_URDF);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

// The InvalidInput a scene's parse throws (its field and reason, joined), or "" if none
std::string refusal(const std::string& yaml, const std::string& urdf)
{
  try
  {
    parseScene(yaml + "particles: [{mass: 1.0, position: [0.0, 0.0, 5.0]}]\n", "robot.yaml",
               SceneInputs{ urdf });
  }
  catch (const InvalidInput& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

// robot_links: each collision element of a named link is a shape on the link's tf frame, posed
// at its <origin> there, of its type and size; several are named <link>_<k>.
TEST(RobotLinks, CollisionElementsBecomeShapesOnTheLinksFrames)
{
  const std::vector<Shape> shapes =
      robotLinkShapes(testRobot(), { "forearm", "gripper", "base_link" }, "robot_links");
  ASSERT_EQ(shapes.size(), 4u);
  const Shape& forearm = shapes[0];
  EXPECT_EQ(forearm.name, "forearm");
  EXPECT_EQ(forearm.frame, "forearm");
  EXPECT_EQ(forearm.type, ShapeType::Box);
  EXPECT_EQ(forearm.size, Vec3(0.6, 0.3, 0.1));
  EXPECT_EQ(forearm.position, Vec3(0.1, 0.0, -0.05));
  EXPECT_LT((forearm.rotation - rotationFromRpy(Vec3(0.0, 0.0, 0.2))).norm(), 1e-12);
  EXPECT_EQ(shapes[1].name, "gripper_0");
  EXPECT_EQ(shapes[1].type, ShapeType::Sphere);
  EXPECT_EQ(shapes[1].radius, 0.02);
  EXPECT_EQ(shapes[1].position, Vec3(0.0, 0.05, 0.0));
  EXPECT_EQ(shapes[2].name, "gripper_1");
  EXPECT_EQ(shapes[2].type, ShapeType::Cylinder);
  EXPECT_EQ(shapes[2].length, 0.04);
  EXPECT_LT((shapes[2].rotation.col(2) - Vec3(0.0, -1.0, 0.0)).norm(), 1e-12);  // rolled 90 deg
  EXPECT_EQ(shapes[3].name, "base_link");
  EXPECT_EQ(shapes[3].type, ShapeType::Cylinder);
}

// Refusals name robot_links and say why: no description, a link not in it, a mesh file not
// found, twice.
TEST(RobotLinks, RefusalsNameTheFieldAndWhy)
{
  const std::string urdf = testRobot();
  auto expectRefused =
      [&](const std::string& links, const std::string& description, const std::string& words)
  {
    const std::string what = refusal("robot_links: " + links + "\n", description);
    EXPECT_NE(what.find("robot_links"), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << what;
  };
  expectRefused("[forearm]", "", "robot_description");
  expectRefused("[elbow]", urdf, "'elbow' is not a link of robot 'test_arm'");
  expectRefused("[camera]", urdf, "package://test_arm/camera.stl");  // its mesh file, unfound
  expectRefused("[forearm, forearm]", urdf, "named twice");
  expectRefused("[forearm]", "<robot", "not a URDF");
  EXPECT_EQ(refusal("robot_links: [forearm]\n", urdf), "");
  // a shape of the same name under shapes
  const std::string what =
      refusal("shapes: {forearm: {type: sphere}}\nrobot_links: [forearm]\n", urdf);
  EXPECT_NE(what.find("a name under shapes already"), std::string::npos) << what;
}

// A rope dropped 5 mm onto the test robot's forearm (its frame 0.5 m up and turned 0.6 rad,
// as tf would have it; the rope along the box's long side, 0.8 rad) comes to rest on its top: never
// inside it, its particles at the top plus their radius, the box carrying its whole weight.
TEST(RobotLinks, RopeComesToRestOnARobotLink)
{
  const std::string yaml = R"(
robot_links: [forearm]
chains:
  - {particles: 5, link_length: 0.08, particle_mass: 0.05,
     start: [-0.0289395, -0.0583128, 0.515], direction: [0.696707, 0.717356, 0.0],
     obstacles: [forearm], radius: 0.01, restitution: 0.0}
forces:
  - {type: gravity, acceleration: [0.0, 0.0, -9.81]}
)";
  const BuiltScene built = buildScene(parseScene(yaml, "rope.yaml", SceneInputs{ testRobot() }));
  Simulator sim(built.scene, built.initial_state, settingsOf(1e-3));
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.6, Vec3::UnitZ()));
  const Vec3 link(0.0, 0.0, 0.5);
  sim.carriers()[0].restart(link, turn);
  // the box's top in the world: the link's z plus the collision's -0.05 plus half its 0.1
  const double top = 0.5 - 0.05 + 0.05;
  Shape box = sim.model().carriers()[0];
  ShapePose pose;
  pose.origin = link + turn * box.position;
  pose.rotation = turn.toRotationMatrix() * box.rotation;
  double deepest = 0.0;
  for (int k = 0; k < 1500; ++k)
  {
    ASSERT_EQ(sim.step().failed_check, StepCheck::None) << k;
    for (int i = 0; i < sim.model().numParticles(); ++i)
      deepest =
          std::max(deepest, 0.01 - evaluateShape(box, pose, sim.state().positions.col(i)).distance);
  }
  EXPECT_LT(deepest, 1e-9);
  double weight = 0.0, normal = 0.0;
  for (int i = 0; i < sim.model().numParticles(); ++i)
  {
    EXPECT_NEAR(sim.state().positions(2, i), top + 0.01, 1e-9) << i;
    EXPECT_LT(sim.state().velocities.col(i).norm(), 1e-9) << i;
    weight += 0.05 * 9.81;
    normal += sim.data().contacts[i].normal_force;
  }
  EXPECT_NEAR(normal, weight, 1e-9 * weight);
}

// setSurfaces: a rope resting on a plane surface, the plane raised 1 cm under it: every
// particle lifted onto it (the report says 0.01 m), the time going on, at rest on the new plane;
// a count of surfaces other than the scene's is refused with nothing changed.
TEST(SetSurfaces, GroundRaisedUnderARestingRopeLiftsItOntoIt)
{
  const int n = 6;
  Simulator sim = ropeOnPlane(n, {});
  sim.step(200);
  EXPECT_THROW(sim.setSurfaces({}), InvalidInput);
  EXPECT_EQ(sim.model().scene().surfaces[0].coefficients[2], 0.0);  // nothing changed
  const ProjectionReport report =
      sim.setSurfaces({ makeSurface(SurfaceType::Plane, { 0.0, 0.0, 0.01 }, "surface") });
  EXPECT_NEAR(report.max_displacement, 0.01, 1e-12);
  EXPECT_NEAR(sim.state().time, 0.2, 1e-12);
  for (int i = 0; i < n; ++i)
    EXPECT_NEAR(sim.state().positions(2, i), 0.01, 1e-12) << i;
  sim.step(300);
  for (int i = 0; i < n; ++i)
  {
    EXPECT_NEAR(sim.state().positions(2, i), 0.01, 1e-9) << i;
    EXPECT_LT(sim.state().velocities.col(i).norm(), 1e-9) << i;
  }
}

// setObstacles (~set_obstacle, issue 48 item 5): a rope resting on a plane surface, a sphere
// raised under its middle (two particles 9.3 mm inside it): every particle moved out of it and
// its links kept, the report's displacement the largest move, the time going on and the rope
// staying out over 0.5 s; a record of another kind, and a sphere added centred on the rope's line
// (its normals along the rope, the link across it: no way out along them, and no way there to
// move it along), refused with nothing changed (bitwise); the sphere removed, the rope falls back
// onto the plane.
TEST(SetObstacles, SphereMovedOntoARestingRopePushesItOutAndRemovedLetsItFall)
{
  const int n = 6;
  Shape ball = ballOf(0.08);
  ball.position = Vec3(0.25, 0.0, -5.0);  // far under the plane: never touched
  std::vector<Constraint> far;
  for (int i = 0; i < n; ++i)
    far.push_back(ShapeContact{ i, ball, 0.0 });
  Simulator sim = ropeOnPlane(n, far);
  sim.step(200);
  const State before = sim.state();
  const std::size_t records = sim.model().scene().constraints.size();
  // another kind: refused, nothing changed
  EXPECT_THROW(sim.setObstacles({ LinkConstraint{ 0, 1, 0.1 } }), InvalidInput);
  EXPECT_EQ(sim.model().scene().constraints.size(), records);
  EXPECT_EQ(sim.state().positions, before.positions);
  EXPECT_EQ(sim.state().velocities, before.velocities);
  auto around = [&ball, n](const Vec3& centre) { return contactsAround(ball, n, centre); };
  // another sphere added centred on the rope's line: particles 2 and 3 pushed apart along it,
  // the link between them 0.1 m long where they would need 0.16 m; with no way there to move it
  // along (the ball's is in steps: SphereMovedDeepOverARopeIsMovedThereInSteps): refused,
  // nothing changed
  try
  {
    std::vector<Constraint> added = around(Vec3(0.25, 0.0, -5.0));
    Shape other = ball;
    other.name = "other";
    other.position = Vec3(0.25, 0.0, 0.0);
    for (int i = 0; i < n; ++i)
      added.push_back(ShapeContact{ i, other, 0.0 });
    sim.setObstacles(added);
    ADD_FAILURE() << "a sphere with no way out along its normals accepted";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_NE(std::string(e.what()).find("too deep for the projection"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(sim.model().scene().constraints.size(), records);
  EXPECT_EQ(sim.state().positions, before.positions);
  EXPECT_EQ(sim.state().velocities, before.velocities);
  EXPECT_EQ(std::get<ShapeContact>(sim.model().scene().constraints.back()).shape.position.z(),
            -5.0);
  // raised under the rope's middle: particles 2 and 3 lie 7.07 cm from its centre, 9.3 mm in
  const ProjectionReport report = sim.setObstacles(around(Vec3(0.25, 0.0, -0.05)));
  EXPECT_EQ(sim.model().scene().constraints.size(), records);
  EXPECT_NEAR(sim.state().time, before.time, 1e-15);
  const double moved = (sim.state().positions - before.positions).colwise().norm().maxCoeff();
  EXPECT_GT(moved, 0.005);
  EXPECT_NEAR(report.max_displacement, moved, 1e-15);
  auto worst = [&sim, &ball] { return ropeErrors(sim.state().positions, ball); };
  for (const double error : worst())
    EXPECT_LT(error, 1e-9);
  for (int k = 0; k < 500; ++k)
  {
    ASSERT_EQ(sim.step().failed_check, StepCheck::None) << k;
    for (const double error : worst())
      ASSERT_LT(error, 1e-9) << k;
  }
  EXPECT_GT(sim.state().positions.row(2).maxCoeff(), 0.005);  // over the ball
  // removed: the rope falls back onto the plane
  const ProjectionReport removed = sim.setObstacles({});
  EXPECT_EQ(removed.max_displacement, 0.0);
  EXPECT_EQ(sim.model().scene().constraints.size(), records - n);
  sim.step(1500);
  EXPECT_LT(sim.state().positions.row(2).maxCoeff(), 1e-6);
  EXPECT_GT(sim.state().positions.row(2).minCoeff(), -1e-9);
}

// setObstacles with a sphere moved from far under a rope resting on a plane to centred on the
// rope's line and grown (at once, no way out along its normals: SphereMovedOntoARestingRope...):
// moved there in steps, it lifts the rope over itself as a sphere rising slowly would: every
// particle out of it and off the plane's inside, the links kept (1e-9 m), the time unchanged,
// the report's displacement the largest move, and the rope staying out over 0.5 s. Pressed down
// to the same place from far above instead, squeezing the rope into the plane, it is refused even
// in steps, nothing changed (bitwise).
TEST(SetObstacles, SphereMovedDeepOverARopeIsMovedThereInSteps)
{
  const int n = 6;
  Shape ball = ballOf(0.05);  // grown to 0.08 on its way
  auto around = [&ball, n](const Vec3& centre) { return contactsAround(ball, n, centre); };
  Simulator sim = ropeOnPlane(n, around(Vec3(0.25, 0.0, -5.0)));
  sim.step(200);
  const State before = sim.state();
  // from far above, pressed down onto the rope's line: in steps it squeezes the rope into the
  // plane, which it could leave only by stretching: refused, nothing changed
  EXPECT_EQ(sim.setObstacles(around(Vec3(0.25, 0.0, 5.0))).max_displacement, 0.0);
  ball.radius = 0.08;
  try
  {
    sim.setObstacles(around(Vec3(0.25, 0.0, 0.0)));
    ADD_FAILURE() << "a sphere pressing the rope into the plane accepted";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_NE(std::string(e.what()).find("even moved there in steps"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(sim.state().positions, before.positions);
  EXPECT_EQ(sim.state().velocities, before.velocities);
  EXPECT_EQ(std::get<ShapeContact>(sim.model().scene().constraints.back()).shape.radius, 0.05);
  // from far below: lifting the rope over itself
  ball.radius = 0.05;
  EXPECT_EQ(sim.setObstacles(around(Vec3(0.25, 0.0, -5.0))).max_displacement, 0.0);
  ball.radius = 0.08;
  const ProjectionReport report = sim.setObstacles(around(Vec3(0.25, 0.0, 0.0)));
  EXPECT_GT(report.change_steps, 1);
  std::printf("[set obstacles] the ball moved there in %d steps\n", report.change_steps);
  EXPECT_NEAR(sim.state().time, before.time, 1e-15);
  const double moved = (sim.state().positions - before.positions).colwise().norm().maxCoeff();
  EXPECT_NEAR(report.max_displacement, moved, 1e-15);
  EXPECT_GT(moved, 0.05);
  auto worst = [&sim, &ball] { return ropeErrors(sim.state().positions, ball); };
  for (const double error : worst())
    EXPECT_LT(error, 1e-9);
  // over the ball: particles 2 and 3 either side of its top, sqrt(0.08^2 - 0.05^2) = 0.062 m up
  EXPECT_GT(sim.state().positions.row(2).maxCoeff(), 0.06);
  for (int k = 0; k < 500; ++k)
  {
    ASSERT_EQ(sim.step().failed_check, StepCheck::None) << k;
    for (const double error : worst())
      ASSERT_LT(error, 1e-9) << k;
  }
}

// A new scene (a ~reset) with an obstacle of the same name carried: it stays where its holder
// has it (the world outside the scene goes on), at rest until the holder's next pose.
TEST(CarriedShapes, NewSceneKeepsACarriedObstacleWhereItIs)
{
  Scene scene;
  scene.masses = { 1.0 };
  scene.constraints = { ShapeContact{ 0, carried(ShapeType::Sphere, "hand"), 0.0 } };
  const State start =
      constrained_particles::testing::stateOf(Points::Zero(3, 1), Points::Zero(3, 1));
  Simulator sim(scene, start, settingsOf(1e-3));
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.4, Vec3::UnitX()));
  sim.carriers()[0].restart(Vec3(2.0, 0.0, 0.0), turn);
  sim.step(10);
  sim.setScene(scene, start);
  EXPECT_EQ(sim.state().time, 0.0);
  EXPECT_EQ(sim.carriers()[0].motion(0.0).position, Vec3(2.0, 0.0, 0.0));
  EXPECT_TRUE(sim.carriers()[0].orientation(0.0).isApprox(turn, 1e-15));
  // another obstacle's name: it starts at its own pose
  scene.constraints = { ShapeContact{ 0, carried(ShapeType::Sphere, "hand"), 0.0 } };
  std::get<ShapeContact>(scene.constraints[0]).shape.name = "other";
  sim.setScene(scene, start);
  EXPECT_EQ(sim.carriers()[0].motion(0.0).position, Vec3::Zero());
  // the same name on another holder: its track is that holder's, from its own pose too
  scene.constraints = { ShapeContact{ 0, carried(ShapeType::Sphere, "hand"), 0.0 } };
  sim.setScene(scene, start);
  sim.carriers()[0].restart(Vec3(2.0, 0.0, 0.0), turn);
  std::get<ShapeContact>(scene.constraints[0]).shape.frame = "wrist";
  sim.setScene(scene, start);
  EXPECT_EQ(sim.carriers()[0].motion(0.0).position, Vec3::Zero());
}

// setObstacles with carried shapes (~set_obstacle on a frame, issue 48 item 5): a shape on the
// same holder keeps its track (resized where its holder has it, its motion going on); moved to
// another holder, or added, it starts at its pose as written, at rest until that holder's first
// pose; removed, its track goes with it and the other's stays.
TEST(SetObstacles, ACarriedShapeKeepsItsHoldersTrackAndANewOneStartsAsWritten)
{
  const int n = 4;
  Shape hand = carried(ShapeType::Sphere, "gripper");
  hand.name = "hand";
  hand.radius = 0.05;
  hand.position = Vec3(0.0, 0.0, 3.0);  // in its frame: clear of the rope wherever it starts
  auto on = [n](const std::vector<Shape>& shapes)
  {
    std::vector<Constraint> contacts;
    for (const Shape& shape : shapes)
      for (int i = 0; i < n; ++i)
        contacts.push_back(ShapeContact{ i, shape, 0.0 });
    return contacts;
  };
  Simulator sim = ropeOnPlane(n, on({ hand }));
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.3, Vec3::UnitZ()));
  sim.carriers()[0].restart(Vec3(0.15, 0.0, 1.0), turn);  // over the rope, clear of it
  sim.step(20);
  // resized on the same frame: where its holder has it
  Shape bigger = hand;
  bigger.radius = 0.08;
  sim.setObstacles(on({ bigger }));
  ASSERT_EQ(sim.carriers().size(), 1u);
  EXPECT_EQ(sim.carriers()[0].motion(sim.state().time).position, Vec3(0.15, 0.0, 1.0));
  EXPECT_TRUE(sim.carriers()[0].orientation(sim.state().time).isApprox(turn, 1e-15));
  // a second carried shape added: at its pose as written (its frame's origin here), the hand kept
  Shape thumb = carried(ShapeType::Sphere, "thumb_link");
  thumb.name = "thumb";
  thumb.radius = 0.02;
  thumb.position = Vec3(0.0, 0.0, 2.0);
  sim.setObstacles(on({ bigger, thumb }));
  ASSERT_EQ(sim.carriers().size(), 2u);
  EXPECT_EQ(sim.model().carriers()[1].name, "thumb");
  EXPECT_EQ(sim.carriers()[0].motion(sim.state().time).position, Vec3(0.15, 0.0, 1.0));
  EXPECT_EQ(sim.carriers()[1].motion(sim.state().time).position, Vec3::Zero());
  const EffectContext context{ sim.model().scene().surfaces, sim.state().time, nullptr,
                               &sim.carriers() };
  EXPECT_EQ(shapePose(thumb, 1, context).origin, Vec3(0.0, 0.0, 2.0));
  // the hand removed: the thumb's track stays its own
  sim.carriers()[1].restart(Vec3(0.0, 0.5, 0.0));
  sim.setObstacles(on({ thumb }));
  ASSERT_EQ(sim.carriers().size(), 1u);
  EXPECT_EQ(sim.carriers()[0].motion(sim.state().time).position, Vec3(0.0, 0.5, 0.0));
  // the thumb moved to another frame: that holder's track starts anew, at its pose as written
  thumb.frame = "index_link";
  sim.setObstacles(on({ thumb }));
  EXPECT_EQ(sim.carriers()[0].motion(sim.state().time).position, Vec3::Zero());
  // and from a frame to a topic of the same name: another holder too
  sim.carriers()[0].restart(Vec3(0.0, 0.5, 0.0));
  thumb.topic = thumb.frame;
  thumb.frame.clear();
  sim.setObstacles(on({ thumb }));
  EXPECT_EQ(sim.carriers()[0].motion(sim.state().time).position, Vec3::Zero());
  sim.step(10);
  EXPECT_LT(sim.state().positions.row(2).maxCoeff(), 1e-6);  // the rope still on its plane
}
