/// @file test_segment_contact.cpp
/// @brief Links as capsules (segment_contact.hpp): the nearest point of a segment to each shape
/// against a dense search; the row's Cdot and Cddot against central differences along a path
/// (J v and J a + Jdot v, the nearest point moving along the segment); a rope sliding off a box
/// over its edge never has a link through the box (and with particle contacts only, one is), with
/// no energy gained; scene files read `capsules` and name what is wrong.
#include "test_helpers.hpp"

#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

using namespace constrained_particles;
using constrained_particles::testing::G;
using constrained_particles::testing::Random;
using constrained_particles::testing::shapeOf;

namespace
{
// The least distance of segment a-b to the shape, and where, by sampling it densely.
std::pair<double, double> sampledNearest(const Shape& shape, const Vec3& a, const Vec3& b,
                                         double low, double high, int samples = 20000)
{
  double best = INFINITY, at = low;
  for (int k = 0; k <= samples; ++k)
  {
    const double s = low + (high - low) * k / samples;
    const double d = evaluateShape(shape, Vec3(a + s * (b - a))).distance;
    if (d < best)
    {
      best = d;
      at = s;
    }
  }
  return { best, at };
}

// The deepest any link of the state is inside the shape (its capsule of `radius`), sampled: 400
// points along it and 10 in each end's 1e-3 (where the particles' balls hold it).
double deepestLink(const Shape& shape, const Points& p, double radius)
{
  double deepest = -INFINITY;
  for (int i = 0; i + 1 < p.cols(); ++i)
  {
    const Vec3 a = p.col(i), b = p.col(i + 1);
    double least = sampledNearest(shape, a, b, 0.0, 1.0, 400).first;
    least = std::min(least, sampledNearest(shape, a, b, 0.0, 1e-3, 10).first);
    least = std::min(least, sampledNearest(shape, a, b, 1.0 - 1e-3, 1.0, 10).first);
    deepest = std::max(deepest, radius - least);
  }
  return deepest;
}
}  // namespace

// For random segments near each shape, turned and moved: the nearest point's distance is the
// least a dense sampling finds (to its resolution), never more; and where it lies strictly inside
// with the distance curving, `between` says so.
TEST(SegmentContact, NearestPointIsTheLeastDistanceAlongTheSegment)
{
  Random random(7);
  for (const ShapeType type :
       { ShapeType::Sphere, ShapeType::Box, ShapeType::Capsule, ShapeType::Cylinder })
  {
    const Shape shape = shapeOf(type, Vec3(0.1, -0.2, 0.3), Vec3(0.3, -0.5, 0.9));
    int between = 0;
    for (int trial = 0; trial < 300; ++trial)
    {
      const Vec3 a = shape.position + random.vector(0.9), b = a + random.vector(0.4);
      const SegmentSample near = nearestOnSegment(shape, fixedPose(shape), a, b, 1e-3, 1.0 - 1e-3);
      const auto sampled = sampledNearest(shape, a, b, 1e-3, 1.0 - 1e-3);
      const double step = (b - a).norm() / 20000;
      // never above the sampled least; below it by at most what a sample step can miss
      EXPECT_LE(near.sample.distance, sampled.first + 1e-15) << shapeTypeName(type) << trial;
      EXPECT_GE(near.sample.distance, sampled.first - step) << shapeTypeName(type) << trial;
      // an inner nearest point is where the sampling finds the least, not at a bound
      if (near.between)
      {
        EXPECT_FALSE(near.at_bound);
        EXPECT_GT(sampled.second, 1e-3 + 1e-4) << shapeTypeName(type) << trial;
        EXPECT_LT(sampled.second, 1.0 - 1e-3 - 1e-4) << shapeTypeName(type) << trial;
      }
      between += near.between;
    }
    EXPECT_GT(between, 30) << shapeTypeName(type) << ": few segments had an inner nearest point";
  }
  // a segment lying flat on a box's face, or along a capsule's side: flat, not `between`
  const Shape box = shapeOf(ShapeType::Box, Vec3::Zero(), Vec3::Zero());
  EXPECT_FALSE(nearestOnSegment(box, fixedPose(box), Vec3(-0.1, 0.0, 0.41), Vec3(0.1, 0.0, 0.41),
                                1e-3, 1.0 - 1e-3)
                   .between);
  const Shape capsule = shapeOf(ShapeType::Capsule, Vec3::Zero(), Vec3::Zero());
  EXPECT_FALSE(nearestOnSegment(capsule, fixedPose(capsule), Vec3(0.31, 0.0, -0.1),
                                Vec3(0.31, 0.0, 0.1), 1e-3, 1.0 - 1e-3)
                   .between);
  // across a box's edge, it is
  const SegmentSample edge = nearestOnSegment(box, fixedPose(box), Vec3(0.15, 0.0, 0.5),
                                              Vec3(0.3, 0.0, 0.35), 1e-3, 1.0 - 1e-3);
  EXPECT_TRUE(edge.between);
  // the edge (x, z) = (0.2, 0.4) to the line x + z = 0.65, met half way
  EXPECT_NEAR(edge.sample.distance, std::sqrt(2.0) * 0.025, 1e-12);
  EXPECT_NEAR(edge.fraction, 0.5, 1e-12);
}

// A track through path(t) and turn(t), sampled every 0.25 s from 0 to 2 s (test_carried_shapes'
// trackOf): smooth inside each interval.
AnchorTrack movingTrack()
{
  const auto path = [](double t)
  { return Vec3(0.3 * t + 0.2 * t * t, -0.1 * t, 0.5 - 0.4 * t * t); };
  const Vec3 axis = Vec3(0.3, -0.5, 0.8).normalized();
  const auto turn = [axis](double t)
  { return Eigen::Quaterniond(Eigen::AngleAxisd(0.2 + 1.3 * t, axis)); };
  AnchorTrack track;
  track.restart(path(-0.25), turn(-0.25));
  for (int k = 0; k <= 8; ++k)
  {
    AnchorSample sample;
    sample.time = 0.25 * k;
    sample.position = path(sample.time);
    sample.orientation = turn(sample.time);
    EXPECT_EQ(track.append(sample, -0.25), AnchorTrack::Append::Taken) << k;
  }
  return track;
}

// The row along a path p(t) = p0 + v t + a t^2 / 2 of both particles: C's first and second
// differences are J v + dC/dt and J a + Jdot v (the nearest point sliding along the segment, s*
// moving), on a segment across a box's edge, over a sphere, across a capsule and a cylinder's
// rim; each shape fixed, and carried by a track that moves on a curve and turns (the shape off
// its frame's origin).
TEST(SegmentContact, RowRatesMatchDifferencesAlongAPath)
{
  Random random(11);
  struct Case
  {
    ShapeType type;
    Vec3 a, b;  // in the shape's frame
  };
  const std::vector<Case> cases = {
    { ShapeType::Box, Vec3(0.15, 0.05, 0.5), Vec3(0.31, -0.02, 0.35) },
    { ShapeType::Sphere, Vec3(-0.2, 0.1, 0.33), Vec3(0.2, 0.05, 0.35) },
    { ShapeType::Capsule, Vec3(-0.2, 0.34, 0.1), Vec3(0.2, 0.33, -0.05) },
    { ShapeType::Cylinder, Vec3(0.25, 0.0, 0.5), Vec3(0.41, 0.02, 0.32) },
  };
  const std::vector<Surface> surfaces;
  const std::vector<AnchorTrack> carriers{ movingTrack() };
  const double t0 = 0.6;  // inside an interval of the track
  for (const bool moving : { false, true })
    for (const Case& c : cases)
    {
      Shape shape = shapeOf(c.type, Vec3::Zero(), Vec3::Zero());
      SegmentContact contact{ 0, 1, shape, 0.01, 0.0 };
      if (moving)
      {
        shape.frame = "hand";
        shape.position = Vec3(0.1, 0.05, -0.2);
        shape.rotation = rotationFromRpy(Vec3(0.3, 0.1, -0.4));
        contact.shape = shape;
        contact.carrier = 0;
      }
      const ShapePose pose = shapePose(contact.shape, contact.carrier,
                                       EffectContext{ surfaces, t0, nullptr, &carriers });
      ASSERT_EQ(pose.moving, moving);
      for (int trial = 0; trial < 10; ++trial)
      {
        Points p0(3, 2), v(3, 2), a(3, 2);
        p0.col(0) = pose.origin + pose.rotation * c.a;
        p0.col(1) = pose.origin + pose.rotation * c.b;
        v.col(0) = random.vector(1.0);
        v.col(1) = random.vector(1.0);
        a.col(0) = random.vector(1.0);
        a.col(1) = random.vector(1.0);
        auto rowAt = [&](double t)
        {
          const Points p = p0 + v * t + 0.5 * a * t * t;
          const Points vt = v + a * t;
          return segmentFrame(contact, EffectContext{ surfaces, t0 + t, nullptr, &carriers }, p,
                              vt);
        };
        const SegmentFrame at = rowAt(0.0);
        const std::string where = std::string(shapeTypeName(c.type)) +
                                  (moving ? " carried " : " fixed ") + std::to_string(trial);
        ASSERT_TRUE(at.between) << where;
        const double h = 1e-5;
        const double minus = rowAt(-h).frame.gap, plus = rowAt(h).frame.gap;
        const double rate = (1.0 - at.fraction) * at.frame.normal.dot(v.col(0)) +
                            at.fraction * at.frame.normal.dot(v.col(1)) + at.frame.timeRate();
        const double second = (1.0 - at.fraction) * at.frame.normal.dot(a.col(0)) +
                              at.fraction * at.frame.normal.dot(a.col(1)) + at.frame.curvature_term;
        EXPECT_NEAR(rate, (plus - minus) / (2 * h), 1e-8) << where;
        EXPECT_NEAR(second, (plus - 2 * at.frame.gap + minus) / (h * h),
                    2e-3 * (1 + std::abs(second)))
            << where;
      }
    }
}

namespace
{
// A rope of `n` particles (radius r, links l) lying on a box's top with its last links out over
// the edge at x = 0.2, frictionless, under gravity: it slides off over the edge.
BuiltScene ropeOverBoxEdge(bool capsules)
{
  const std::string text = std::string(R"(
name: rope_over_box_edge
shapes:
  block: {type: box, position: [0, 0, -0.2], size: [0.4, 0.4, 0.4]}
chains:
  - {particles: 14, link_length: 0.05, particle_mass: 0.01, start: [-0.19, 0, 0.005],
     obstacles: [block], radius: 0.005, capsules: )") +
                           (capsules ? "true" : "false") + R"(}
forces:
  - {type: gravity}
)";
  return buildScene(parseScene(text, "rope_over_box_edge.yaml"));
}

const Shape& boxOf(const BuiltScene& built)
{
  for (const Constraint& c : built.scene.constraints)
    if (const auto* contact = std::get_if<ShapeContact>(&c))
      return contact->shape;
  throw std::runtime_error("no shape contact");
}
}  // namespace

// The rope slides off the box over its edge: with its links as capsules no link is ever inside
// the box (sampled along each link, every step at dt 1 ms, every 10th at 0.1 ms; each
// integrator), and the energy never rises
// (frictionless: impacts only take it out); with particle contacts only, links cut through the
// edge by more than the rope's radius (so this scene does test the edge).
TEST(SegmentContact, ARopeSlidingOverABoxEdgeNeverHasALinkThroughIt)
{
  const double radius = 0.005;
  for (const std::string integrator : { "rk4", "velocity_verlet", "semi_implicit_euler" })
    for (const double dt : { 1e-3, 1e-4 })
    {
      const BuiltScene built = ropeOverBoxEdge(true);
      const Shape& box = boxOf(built);
      StepSettings settings;
      settings.dt = dt;
      settings.integrator = integrator;
      Simulator sim(built.scene, built.initial_state, settings);
      const double energy =
          kineticEnergy(sim.model(), sim.state()) + potentialEnergy(sim.model(), sim.state());
      double deepest = -INFINITY, rise = -INFINITY;
      const int steps = static_cast<int>(std::lround(0.6 / dt));
      for (int k = 0; k < steps; ++k)
      {
        ASSERT_EQ(sim.step().failed_check, StepCheck::None)
            << integrator << " dt " << dt << " " << k;
        if (dt > 5e-4 || k % 10 == 9)
          deepest = std::max(deepest, deepestLink(box, sim.state().positions, radius));
        rise = std::max(rise, kineticEnergy(sim.model(), sim.state()) +
                                  potentialEnergy(sim.model(), sim.state()) - energy);
      }
      // it went over: the rope's far end is down the side
      EXPECT_LT(sim.state().positions(2, 13), -0.1) << integrator;
      std::cout << integrator << " dt " << dt << ": deepest link " << deepest
                << " m inside, energy rise " << rise << " J\n";
      EXPECT_LE(deepest, 1e-7) << integrator << " dt " << dt;
      EXPECT_LE(rise, 1e-9) << integrator << " dt " << dt;
    }
  // particle contacts only: a link cuts the edge
  const BuiltScene bare = ropeOverBoxEdge(false);
  const Shape& box = boxOf(bare);
  StepSettings settings;
  settings.dt = 1e-3;
  settings.integrator = "rk4";
  Simulator sim(bare.scene, bare.initial_state, settings);
  double deepest = -INFINITY;
  for (int k = 0; k < 600; ++k)
  {
    sim.step();
    deepest = std::max(deepest, deepestLink(box, sim.state().positions, radius));
  }
  std::cout << "particle contacts only: deepest link " << deepest << " m inside\n";
  EXPECT_GT(deepest, radius);
}

// The forces a caller reads between steps (constraintForces, as the node reads them once per batch)
// on the shipped rope_over_edge: complementary (no acting contact pulls) and with no segment row
// acting where its nearest point is at an end, where it and its end particle's contact are nearly
// dependent rows. Before, such a pair carried large, opposite forces: 98 N from the first step and
// up to 2,958 N (rk4), 4,386 N (dopri5) against a rope weighing 1.96 N. Reading the forces does
// not change the motion (the next step's stick test reads the step's own forces).
TEST(SegmentContact, ForcesReadBetweenStepsAreComplementaryAndNeverOfASegmentAtItsEnd)
{
  const BuiltScene built =
      buildScene(loadSceneFile(std::string(SCENES_DIR) + "/rope_over_edge.yaml"));
  double weight = 0.0;
  for (const double m : built.scene.masses)
    weight += m * G;
  for (const std::string integrator : { "rk4", "dopri5", "explicit_euler" })
  {
    StepSettings settings;
    settings.integrator = integrator;
    // the integrator's own motion: the energy budget would hand a run that gains to its fallback
    settings.energy_budget = 0.0;
    Simulator read(built.scene, built.initial_state, settings);
    Simulator unread(built.scene, built.initial_state, settings);
    const Model& model = read.model();
    double most_pulling = 0.0, largest = 0.0;
    int segments_at_ends = 0, segment_steps = 0;
    for (int k = 0; k < 1500; ++k)
    {
      ASSERT_EQ(read.step().failed_check, StepCheck::None) << integrator << " step " << k;
      unread.step();
      Points forces;
      Eigen::VectorXd multipliers;
      read.constraintForces(forces, multipliers);
      const EffectContext context{ model.scene().surfaces, read.state().time };
      bool segment = false;
      for (int c = 0; c < model.numContacts(); ++c)
      {
        const ContactState& contact = read.data().contacts[c];
        if (contact.mode == ContactMode::Separated)
          continue;
        most_pulling = std::min(most_pulling, contact.normal_force);
        largest = std::max(largest, contact.normal_force);
        const UnilateralRecord& row = model.unilateral()[c];
        if (row.kind != UnilateralKind::SegmentContact)
          continue;
        segment = true;
        const SegmentFrame frame =
            segmentFrame(unilateralRecord<SegmentContact>(model, row), context,
                         read.state().positions, read.state().velocities);
        segments_at_ends += frame.between ? 0 : 1;
      }
      segment_steps += segment ? 1 : 0;
    }
    std::cout << integrator << ": " << segment_steps
              << " steps with a segment acting; most pulling " << most_pulling << " N, largest "
              << largest << " N (weight " << weight << " N)\n";
    EXPECT_GT(segment_steps, 100) << integrator;  // the case is met: links ride the edge
    EXPECT_EQ(segments_at_ends, 0) << integrator;
    EXPECT_GE(most_pulling, -1e-9 * weight) << integrator;
    // a link levered over the edge as the rope whips round it: 8.4 weights at most (rk4, 3 s)
    EXPECT_LE(largest, 20.0 * weight) << integrator;
    EXPECT_EQ((read.state().positions - unread.state().positions).cwiseAbs().maxCoeff(), 0.0)
        << integrator;
  }
}

// Scene files: `capsules` makes a segment contact per link and obstacle (none for a plane);
// capsules with no obstacles are refused, naming the field.
TEST(SegmentContact, SceneFilesReadCapsules)
{
  const BuiltScene built = buildScene(parseScene(R"(
name: capsules
shapes:
  post: {type: cylinder, position: [0, 0, 0.1], rpy: [1.5707963267948966, 0, 0], radius: 0.05,
         length: 0.5}
  ground: {type: plane}
chains:
  - {particles: 4, link_length: 0.1, start: [-0.15, 0, 0.2], obstacles: [post, ground],
     radius: 0.01, capsules: true}
)",
                                                 "capsules.yaml"));
  int segments = 0;
  for (const Constraint& c : built.scene.constraints)
    if (const auto* segment = std::get_if<SegmentContact>(&c))
    {
      ++segments;
      EXPECT_EQ(segment->shape.name, "post");
      EXPECT_EQ(segment->second, segment->first + 1);
      EXPECT_DOUBLE_EQ(segment->radius, 0.01);
    }
  EXPECT_EQ(segments, 3);  // 3 links x the post (the plane takes none)
  const Model model = Model::compile(built.scene);
  EXPECT_EQ(model.numContacts(), 8 + 3);
  try
  {
    buildScene(parseScene(R"(
name: bad
chains:
  - {particles: 4, capsules: true}
)",
                          "bad.yaml"));
    FAIL() << "capsules with no obstacles accepted";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_NE(std::string(e.what()).find("chains[0].capsules"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("obstacles"), std::string::npos) << e.what();
  }
  // by hand: against a plane, twice on one link (refused as the model compiles), a link starting
  // through the post
  auto refusal = [](const std::string& records, const std::string& start)
  {
    try
    {
      Model::compile(buildScene(parseScene(R"(
name: bad
shapes:
  post: {type: cylinder, position: [0, 0, 0.1], rpy: [1.5707963267948966, 0, 0], radius: 0.05,
         length: 0.5}
  ground: {type: plane}
particles:
  - {mass: 1, position: [-0.1, 0, )" + start + R"(]}
  - {mass: 1, position: [0.1, 0, )" + start + R"(]}
constraints:
)" + records,
                                           "bad.yaml"))
                         .scene);
    }
    catch (const InvalidInput& e)
    {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string plane =
      refusal("  - {type: segment_contact, first: 0, second: 1, shape: ground}\n", "0.2");
  EXPECT_NE(plane.find("shape"), std::string::npos) << plane;
  EXPECT_NE(plane.find("a plane"), std::string::npos) << plane;
  const std::string twice = refusal(
      "  - {type: segment_contact, first: 0, second: 1, shape: post, radius: 0.01}\n"
      "  - {type: segment_contact, first: 1, second: 0, shape: post, radius: 0.01}\n",
      "0.2");
  EXPECT_NE(twice.find("redundant"), std::string::npos) << twice;
  // both particles clear of the post (0.1 m off its axis), the link through it
  const std::string through = refusal(
      "  - {type: segment_contact, first: 0, second: 1, shape: post, radius: 0.01}\n", "0.1");
  EXPECT_NE(through.find("inside obstacle 'post'"), std::string::npos) << through;
  EXPECT_NE(through.find("link to particle 1"), std::string::npos) << through;
  EXPECT_EQ(refusal("  - {type: segment_contact, first: 0, second: 1, shape: post, radius: 0.01}\n",
                    "0.2"),
            "accepted");
}

// A link (two 0.5 kg particles) lying across the top of a sphere, square to the way it slides,
// its balls clear of the sphere: its middle rides the sphere as a 1 kg bead of the rope's radius
// would, so it leaves where the energy balance says, at height (R + r) (2 + v0^2 / (g (R + r)))
// / 3 over the centre (within 2e-4 R at dt 0.1 ms), and at dt 1 and 10 ms its middle follows the
// bead's own path with the same method within 1e-9 m (let go within the step where its force
// crosses 0, as the bead's contact is) over 3 s, then flies clear.
TEST(SegmentContact, ALinkAcrossASphereLeavesItAsABeadWould)
{
  const double radius = 0.9, rope = 0.01, v0 = 0.05, reach = radius + rope, half = 0.3;
  const Vec3 centre(1.0, 2.0, 0.5);
  Shape sphere = shapeOf(ShapeType::Sphere, centre, Vec3::Zero());
  sphere.radius = radius;
  Scene link;
  link.masses = { 0.5, 0.5 };
  link.forces = { GravityForce{} };
  link.constraints = { LinkConstraint{ 0, 1, 2 * half }, SegmentContact{ 0, 1, sphere, rope, 0.0 },
                       ShapeContact{ 0, sphere, rope }, ShapeContact{ 1, sphere, rope } };
  State start;
  start.positions.resize(3, 2);
  start.positions.col(0) = centre + Vec3(0.0, -half, reach);
  start.positions.col(1) = centre + Vec3(0.0, half, reach);
  start.velocities = Vec3(v0, 0.0, 0.0).replicate(1, 2);
  Scene bead;
  bead.masses = { 1.0 };
  bead.forces = { GravityForce{} };
  bead.constraints = { ShapeContact{ 0, sphere, rope } };
  State bead_start;
  bead_start.positions = centre + Vec3(0.0, 0.0, reach);
  bead_start.velocities = Vec3(v0, 0.0, 0.0);
  auto settingsOf = [](double dt)
  {
    StepSettings settings;
    settings.dt = dt;
    settings.integrator = "rk4";
    return settings;
  };
  const int segment = 2;  // Data::contacts: the particle contacts, then the segment's
  {
    Simulator sim(link, start, settingsOf(1e-4));
    double last_force = -1.0, last_z = 0.0, left_at = NAN;
    for (int k = 0; k < 20000 && std::isnan(left_at); ++k)
    {
      ASSERT_EQ(sim.step().failed_check, StepCheck::None) << k;
      const double force = sim.data().contacts[segment].normal_force;
      const double z =
          0.5 * (sim.state().positions(2, 0) + sim.state().positions(2, 1)) - centre.z();
      if (last_force > 0.0 && force <= 0.0)
        left_at = last_z + (z - last_z) * last_force / (last_force - force);
      last_force = force;
      last_z = z;
      ASSERT_EQ(sim.data().contacts[0].mode, ContactMode::Separated) << "a ball touched";
    }
    ASSERT_FALSE(std::isnan(left_at)) << "the link never left the sphere";
    const double expected = reach * (2.0 + v0 * v0 / (G * reach)) / 3.0;
    std::cout << "the link leaves the sphere " << (left_at - expected) / radius
              << " R from the closed form\n";
    EXPECT_NEAR(left_at, expected, 2e-4 * radius);
  }
  for (const double dt : { 1e-3, 1e-2 })
  {
    Simulator sim(link, start, settingsOf(dt)), alone(bead, bead_start, settingsOf(dt));
    double apart = 0.0, lowest = INFINITY;
    const int steps = static_cast<int>(std::lround(3.0 / dt));
    for (int k = 0; k < steps; ++k)
    {
      ASSERT_EQ(sim.step().failed_check, StepCheck::None) << dt << " " << k;
      alone.step();
      const Vec3 middle = 0.5 * (sim.state().positions.col(0) + sim.state().positions.col(1));
      apart = std::max(apart, (middle - alone.state().positions.col(0)).norm());
      lowest = std::min(lowest, (middle - centre).norm() - reach);
    }
    std::cout << "dt " << dt << ": the link's middle off the bead's path by at most " << apart
              << " m over 3 s\n";
    EXPECT_LE(apart, 1e-9) << "dt " << dt;
    EXPECT_GT(lowest, -1e-9) << "dt " << dt;
    EXPECT_LT(alone.state().positions(2, 0), centre.z()) << "dt " << dt << ": it fell past";
  }
}

// A link falling at 5 m/s, tilted, onto a box's edge: at dt 10 ms it moves 5 cm a step, five
// times the rope's radius, so its centre line would be inside the box at the step's end; the
// impact is met where the capsule touches (impactFraction), never inside by more than 1e-7 m
// (sampled), with no energy gained, at dt 1 and 10 ms.
TEST(SegmentContact, ALinkFallingFastOntoABoxEdgeIsMetThere)
{
  const double radius = 0.01;
  Shape box = shapeOf(ShapeType::Box, Vec3::Zero(), Vec3::Zero());  // top z = 0.4, side x = 0.2
  Scene scene;
  scene.masses = { 0.5, 0.5 };
  scene.forces = { GravityForce{} };
  scene.constraints = { LinkConstraint{ 0, 1, std::hypot(0.2, 0.05) },
                        ShapeContact{ 0, box, radius }, ShapeContact{ 1, box, radius },
                        SegmentContact{ 0, 1, box, radius, 0.0 } };
  State start;
  start.positions.resize(3, 2);
  start.positions.col(0) = Vec3(0.1, 0.0, 0.55);
  start.positions.col(1) = Vec3(0.3, 0.0, 0.5);
  start.velocities = Vec3(0.0, 0.0, -5.0).replicate(1, 2);
  for (const std::string integrator : { "rk4", "semi_implicit_euler" })
    for (const double dt : { 1e-3, 1e-2 })
    {
      StepSettings settings;
      settings.dt = dt;
      settings.integrator = integrator;
      Simulator sim(scene, start, settings);
      const double energy =
          kineticEnergy(sim.model(), sim.state()) + potentialEnergy(sim.model(), sim.state());
      double deepest = -INFINITY, rise = -INFINITY;
      bool touched = false;
      for (int k = 0; k < static_cast<int>(std::lround(0.3 / dt)); ++k)
      {
        ASSERT_EQ(sim.step().failed_check, StepCheck::None) << integrator << " " << dt << " " << k;
        deepest = std::max(deepest, deepestLink(box, sim.state().positions, radius));
        rise = std::max(rise, kineticEnergy(sim.model(), sim.state()) +
                                  potentialEnergy(sim.model(), sim.state()) - energy);
        touched = touched || sim.data().contacts[2].mode != ContactMode::Separated;
      }
      std::cout << integrator << " dt " << dt << ": deepest " << deepest
                << " m inside, energy rise " << rise << " J\n";
      EXPECT_TRUE(touched) << integrator << " " << dt << ": the capsule never met the edge";
      EXPECT_LE(deepest, 1e-7) << integrator << " " << dt;
      EXPECT_LE(rise, 1e-9) << integrator << " " << dt;
    }
}
