/// @file test_self_collision.cpp
/// @brief Self-collision (issue 48, item 2): the broad phase against every pair, each particle's
/// ball held by one row only, and a rope dropped onto a floor that piles onto itself without any
/// two of its links that share no particle coming closer than twice its radius.
#include "test_helpers.hpp"

#include "constrained_particles/core/self_collision.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <tuple>

using namespace constrained_particles;
using constrained_particles::testing::Random;

namespace
{
// The closest points' distance of links a and b of `rope` (no snapping: the true one) [m]
double linkDistance(const Points& p, const std::vector<int>& rope, int a, int b)
{
  const SegmentPairSample near =
      closestOnSegments(p.col(rope[a]), p.col(rope[a + 1]), p.col(rope[b]), p.col(rope[b + 1]));
  return ((1 - near.s) * p.col(rope[a]) + near.s * p.col(rope[a + 1]) -
          (1 - near.t) * p.col(rope[b]) - near.t * p.col(rope[b + 1]))
      .norm();
}

// The least distance between two links of `rope` that share no particle [m], by every pair
double closestLinks(const Points& p, const std::vector<int>& rope)
{
  double least = INFINITY;
  const int links = static_cast<int>(rope.size()) - 1;
  for (int a = 0; a < links; ++a)
    for (int b = a + 2; b < links; ++b)
      least = std::min(least, linkDistance(p, rope, a, b));
  return least;
}

// A rope of `n` particles, links of length `length`, folded at random into a ball of a few links'
// size (a random walk pulled back towards the origin)
Points foldedRope(Random& random, int n, double length)
{
  Points p(3, n);
  p.col(0).setZero();
  for (int i = 1; i < n; ++i)
  {
    const Vec3 direction = (random.unitVector() - 0.3 * p.col(i - 1) / length).normalized();
    p.col(i) = p.col(i - 1) + length * direction;
  }
  return p;
}

std::vector<int> ropeOf(int n)
{
  std::vector<int> rope(n);
  for (int i = 0; i < n; ++i)
    rope[i] = i;
  return rope;
}

// The two features a pair's row stands for where it acts: a particle's ball (its index) or a
// link's inside (-1 - its first particle), of link a and of link b
std::pair<int, int> featuresOf(const LinkPairContact& c, const LinkPairFrame& f)
{
  return { f.s_at_end ? (f.s == 0 ? c.first_a : c.second_a) : -1 - c.first_a,
           f.t_at_end ? (f.t == 0 ? c.first_b : c.second_b) : -1 - c.first_b };
}

TEST(SelfCollision, TheBroadPhaseFindsEveryPairWithinTheMargin)
{
  Random random(3);
  int found = 0;
  for (int trial = 0; trial < 20; ++trial)
  {
    const int n = 80;
    const Points p = foldedRope(random, n, 0.04);
    const SelfCollision rope{ ropeOf(n), 0.008 };
    const double margin = random.uniform(0.0, 0.03);
    const std::vector<LinkPairContact> pairs = nearLinkPairs({ rope }, p, margin);
    std::set<std::pair<int, int>> got, expected;
    for (const LinkPairContact& c : pairs)
    {
      EXPECT_EQ(c.second_a, c.first_a + 1);
      EXPECT_EQ(c.second_b, c.first_b + 1);
      EXPECT_GE(c.first_b, c.first_a + 2);  // no neighbours, each pair once
      EXPECT_EQ(c.radius, 0.008);
      EXPECT_TRUE(got.emplace(c.first_a, c.first_b).second) << "listed twice";
    }
    for (int a = 0; a + 1 < n; ++a)
      for (int b = a + 2; b + 1 < n; ++b)
        if (linkDistance(p, rope.particles, a, b) <= 2 * rope.radius + margin)
          expected.emplace(a, b);
    EXPECT_EQ(got, expected) << trial;
    found += static_cast<int>(expected.size());
  }
  EXPECT_GT(found, 200);  // the folds bring many pairs near
}

// Every row that may act (between) stands for one pair of features (a particle's ball, or a
// link's inside), and no feature pair is two rows' (their rows would be one row: J W J^T
// singular); nor is a joint's fold two rows' (the ball one link before it against the link after,
// and the ball after against the link before: with the two links' rows, four rows on three
// degrees of freedom). And the closest two links of a folded rope are some acting row's: its gap
// is their distance, to the end snapping's bound.
TEST(SelfCollision, EachBallAndLinkIsHeldByOneRowAndTheClosestByOne)
{
  Random random(5);
  const double length = 0.04, radius = 0.008;
  const double bound = std::pow(LINK_END_FRACTION * length, 2) / (2 * 2 * radius);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial)
  {
    const int n = 12;
    const Points p = foldedRope(random, n, length);
    const SelfCollision rope{ ropeOf(n), radius };
    const std::vector<LinkPairContact> pairs = nearLinkPairs({ rope }, p, 1e3);  // every pair
    // a feature: a particle's ball (its index) or a link's inside (-1 - its first particle)
    std::map<std::pair<int, int>, int> features;
    std::set<int> folded_joints;
    double closest_row = INFINITY;
    for (const LinkPairContact& c : pairs)
    {
      const LinkPairFrame f = linkPairGeometry(c, p);
      if (!f.between)
        continue;
      const auto [a, b] = featuresOf(c, f);
      EXPECT_EQ(++features[std::minmax(a, b)], 1) << "trial " << trial << ": " << a << ", " << b;
      // a ball against the link that starts or ends one link on: that joint's fold
      if (a >= 0 && b < 0 && (b == -1 - (a + 1) || b == -1 - (a - 2)))
        EXPECT_TRUE(folded_joints.insert(b == -1 - (a + 1) ? a + 1 : a - 1).second)
            << "trial " << trial;
      if (b >= 0 && a < 0 && (a == -1 - (b + 1) || a == -1 - (b - 2)))
        EXPECT_TRUE(folded_joints.insert(a == -1 - (b + 1) ? b + 1 : b - 1).second)
            << "trial " << trial;
      closest_row = std::min(closest_row, f.gap + 2 * radius);
    }
    const double closest = closestLinks(p, rope.particles);
    EXPECT_GE(closest_row, closest - 1e-12) << trial;
    EXPECT_LE(closest_row, closest + bound + 1e-12) << trial;
    ++checked;
  }
  EXPECT_EQ(checked, 200);
}

// docs/physics.md, "Self-collision": the bound on how far two links may be inside 2 r: twice the
// projection tolerance (an impact is met 2 tolerances in), and beside a link's end the capsule
// the end's row leaves to the ball's, (LINK_END_FRACTION l)^2 / (2 |w|), |w| = 2 r
double insideBound(const StepSettings& settings, double length, double radius)
{
  return 2 * settings.projection_tolerance +
         std::pow(LINK_END_FRACTION * length, 2) / (2 * 2 * radius);
}

// The shipped rope_pile: a 30-particle rope of radius 8 mm falls onto a floor and piles onto
// itself. At every step no two links that share no particle are closer than 2 r less the bound,
// under each integrator at dt 1 ms and rk4 at 10 ms, with no failed step. Without
// self_collision the same rope passes through itself (its links come within r of each other):
// the check can fail.
TEST(SelfCollision, ARopeDroppedOnItselfNeverBringsTwoLinksCloserThanTwiceItsRadius)
{
  const BuiltScene built = buildScene(loadSceneFile(std::string(SCENES_DIR) + "/rope_pile.yaml"));
  ASSERT_EQ(built.scene.self_collisions.size(), 1u);
  const SelfCollision& rope = built.scene.self_collisions[0];
  const double length = 0.04;
  for (const auto& [integrator, dt, steps] :
       { std::make_tuple("rk4", 1e-3, 2000), std::make_tuple("velocity_verlet", 1e-3, 2000),
         std::make_tuple("semi_implicit_euler", 1e-3, 2000),
         std::make_tuple("midpoint", 1e-3, 2000), std::make_tuple("rk4", 1e-2, 200) })
  {
    StepSettings settings;
    settings.integrator = integrator;
    settings.dt = dt;
    // the integrator's own motion: the energy budget would hand a run that gains to its fallback
    settings.energy_budget = 0.0;
    Simulator simulator(built.scene, built.initial_state, settings);
    double closest = INFINITY;
    int most_pairs = 0;
    for (int k = 0; k < steps; ++k)
    {
      ASSERT_EQ(simulator.step().failed_check, StepCheck::None) << integrator << " step " << k;
      closest = std::min(closest, closestLinks(simulator.state().positions, rope.particles));
      most_pairs =
          std::max(most_pairs, static_cast<int>(std::get<std::vector<KindRecord<LinkPairContact>>>(
                                                    simulator.model().kindTables())
                                                    .size()));
    }
    EXPECT_GE(closest, 2 * rope.radius - insideBound(settings, length, rope.radius))
        << integrator << " dt " << dt;
    EXPECT_GT(most_pairs, 10) << integrator;  // the pile brought many pairs near
    std::cout << std::setprecision(10) << integrator << " dt " << dt << ": closest links "
              << closest << " m (2 r " << 2 * rope.radius << " m), at most " << most_pairs
              << " pairs\n";
  }
  Scene passing = built.scene;
  passing.self_collisions.clear();
  StepSettings settings;
  Simulator simulator(passing, built.initial_state, settings);
  double closest = INFINITY;
  for (int k = 0; k < 2000; ++k)
  {
    simulator.step();
    closest = std::min(closest, closestLinks(simulator.state().positions, rope.particles));
  }
  EXPECT_LT(closest, rope.radius);
  std::cout << "without self_collision: closest links " << closest << " m\n";
}

std::string refusal(const std::function<void()>& f)
{
  try
  {
    f();
  }
  catch (const InvalidInput& e)
  {
    return e.what();
  }
  return "(accepted)";
}

TEST(SelfCollision, BadRopesAreRefusedNamingTheField)
{
  const std::string chain =
      "chains: [{particles: 6, link_length: 0.04, start: [0, 0, 1], "
      "self_collision: true, radius: ";
  EXPECT_NE(refusal([&] { buildScene(parseScene(chain + "0.02}]\n", "t.yaml")); }).find("radius"),
            std::string::npos);
  EXPECT_NE(refusal([&] { buildScene(parseScene(chain + "0}]\n", "t.yaml")); }).find("radius"),
            std::string::npos);
  EXPECT_EQ(refusal([&] { buildScene(parseScene(chain + "0.019}]\n", "t.yaml")); }), "(accepted)");
  // the core's own checks, for scenes built in code
  BuiltScene built = buildScene(parseScene(chain + "0.01}]\n", "t.yaml"));
  Scene bad = built.scene;
  bad.self_collisions[0].particles[3] = 1;
  EXPECT_NE(refusal([&] { Model::compile(bad); }).find("self_collisions[0].particles[3]"),
            std::string::npos);
  bad = built.scene;
  bad.self_collisions[0].radius = 0.03;
  EXPECT_NE(refusal([&] { Model::compile(bad); }).find("self_collisions[0].radius"),
            std::string::npos);
  EXPECT_NE(
      refusal([&] { Model::compile(built.scene, SolveMethod::Tridiagonal); }).find("solve_method"),
      std::string::npos);
  EXPECT_EQ(refusal([&] { Model::compile(built.scene); }), "(accepted)");
  bad = built.scene;
  bad.self_collisions[0].radius = 0.0;
  EXPECT_NE(refusal([&] { Model::compile(bad); }).find("self_collisions[0].radius"),
            std::string::npos);
  bad = built.scene;
  std::get<LinkConstraint>(bad.constraints[2]).length = 0.05;  // the rope's third link
  EXPECT_NE(refusal([&] { Model::compile(bad); }).find("equally long"), std::string::npos);
  // a pair listed on the rope's links would be the simulator's row twice
  bad = built.scene;
  bad.constraints.push_back(LinkPairContact{ 0, 1, 3, 4, 0.01 });
  EXPECT_NE(refusal([&] { Model::compile(bad); })
                .find("constraints[" + std::to_string(bad.constraints.size() - 1) + "]"),
            std::string::npos);
}

// A self-colliding rope's model changes with its pairs (a tree with none, sparse with some):
// changes between steps (forces, holders) compile with the method the scene asked for, not the
// one its current model resolved to, before, while and after its links touch.
TEST(SelfCollision, ForcesChangeBeforeAndAfterTheLinksMeet)
{
  const BuiltScene built = buildScene(loadSceneFile(std::string(SCENES_DIR) + "/rope_pile.yaml"));
  StepSettings settings;
  Simulator simulator(built.scene, built.initial_state, settings);
  EXPECT_EQ(simulator.model().solveMethod(), SolveMethod::Tree);
  const std::uint64_t first = simulator.modelVersion();
  std::vector<Force> forces = built.scene.forces;
  EXPECT_NO_THROW(simulator.setForces(forces));  // a tree now
  simulator.step(600);
  EXPECT_GT(simulator.modelVersion(), first + 1);  // the pairs came
  EXPECT_EQ(simulator.model().solveMethod(), SolveMethod::Sparse);
  EXPECT_NO_THROW(simulator.setForces(forces));
  EXPECT_EQ(simulator.step(100).failed_check, StepCheck::None);
  simulator.reset();  // the rope upright again: its pairs far
  simulator.step(1);
  EXPECT_NO_THROW(simulator.setForces(forces));
}

}  // namespace

// Two ropes (issue 48, item 2): every self-colliding rope's links collide with every other's.
// The broad phase finds each pair of links, a rope's own and two ropes', within r_a + r_b + margin
// (the pair's 2 r the two radii), and each ball or link of one rope against a ball or link of the
// other is one acting row's, the closest two links' among them.
TEST(SelfCollision, TwoRopesPairsAreFoundAndEachFeatureHeldByOneRow)
{
  Random random(11);
  const double length = 0.04, radius_a = 0.008, radius_b = 0.005;
  int crossing = 0;
  for (int trial = 0; trial < 100; ++trial)
  {
    const int n = 10;
    Points p(3, 2 * n);
    p.leftCols(n) = foldedRope(random, n, length);
    p.rightCols(n) = foldedRope(random, n, length).colwise() + random.unitVector() * 0.5 * length;
    std::vector<int> second(n);
    for (int i = 0; i < n; ++i)
      second[i] = n + i;
    const std::vector<SelfCollision> ropes = { { ropeOf(n), radius_a }, { second, radius_b } };
    const double margin = random.uniform(0.0, 0.02);
    std::set<std::tuple<int, int>> got, expected;
    for (const LinkPairContact& c : nearLinkPairs(ropes, p, margin))
    {
      const bool across = (c.first_a < n) != (c.first_b < n);
      EXPECT_DOUBLE_EQ(
          c.radius, across ? 0.5 * (radius_a + radius_b) : (c.first_a < n ? radius_a : radius_b));
      EXPECT_TRUE(got.emplace(c.first_a, c.first_b).second) << "listed twice";
    }
    auto distance = [&p](int a, int b)
    {
      const SegmentPairSample near =
          closestOnSegments(p.col(a), p.col(a + 1), p.col(b), p.col(b + 1));
      return ((1 - near.s) * p.col(a) + near.s * p.col(a + 1) - (1 - near.t) * p.col(b) -
              near.t * p.col(b + 1))
          .norm();
    };
    double closest = INFINITY;
    for (int a = 0; a + 1 < 2 * n; ++a)
      for (int b = a + 2; b + 1 < 2 * n; ++b)
      {
        if (a + 1 == n || b + 1 == n)  // no link joins the ropes
          continue;
        const bool across = a < n && b >= n;
        const double reach = across ? radius_a + radius_b : 2 * (a < n ? radius_a : radius_b);
        if (distance(a, b) <= reach + margin)
          expected.emplace(a, b);
        if (across)
          closest = std::min(closest, distance(a, b));
      }
    EXPECT_EQ(got, expected) << trial;
    // with every pair: each feature pair across the ropes one acting row's
    std::map<std::pair<int, int>, int> features;
    double closest_row = INFINITY;
    for (const LinkPairContact& c : nearLinkPairs(ropes, p, 1e3))
    {
      if ((c.first_a < n) == (c.first_b < n))
        continue;
      const LinkPairFrame f = linkPairGeometry(c, p);
      if (!f.between)
        continue;
      const auto [a, b] = featuresOf(c, f);
      EXPECT_EQ(++features[std::minmax(a, b)], 1) << "trial " << trial << ": " << a << ", " << b;
      closest_row = std::min(closest_row, f.gap + 2 * c.radius);
      ++crossing;
    }
    const double bound = std::pow(LINK_END_FRACTION * length, 2) / (2 * (radius_a + radius_b));
    EXPECT_GE(closest_row, closest - 1e-12) << trial;
    EXPECT_LE(closest_row, closest + bound + 1e-12) << trial;
  }
  EXPECT_GT(crossing, 100);
}

// A thin rope (r = 5 mm) dropped across a thick one (r = 1 cm) lying on a floor: at every step no
// link of one comes closer to a link of the other than r_a + r_b less the bound, with no failed
// step, and the thin rope's middle ends on the thick one; with the thick rope alone
// self-colliding (the thin one in no rope), the thin rope falls through it to the floor.
TEST(SelfCollision, ARopeDroppedAcrossAnotherLiesOnIt)
{
  const std::string text = R"(
shapes: {floor: {type: plane, position: [0, 0, 0]}}
chains:
  - {particles: 21, link_length: 0.05, start: [-0.5, 0, 0.01], direction: [1, 0, 0],
     obstacles: [floor], radius: 0.01, friction: 0.3, self_collision: true}
  - {particles: 21, link_length: 0.04, start: [0.025, -0.4, 0.08], direction: [0, 1, 0],
     obstacles: [floor], radius: 0.005, friction: 0.3, self_collision: true}
forces: [{type: gravity}]
)";
  const BuiltScene built = buildScene(parseScene(text, "crossing.yaml"));
  ASSERT_EQ(built.scene.self_collisions.size(), 2u);
  const int n = 21;
  auto closestAcross = [n](const Points& p)
  {
    double least = INFINITY;
    for (int a = 0; a + 1 < n; ++a)
      for (int b = n; b + 1 < 2 * n; ++b)
      {
        const SegmentPairSample near =
            closestOnSegments(p.col(a), p.col(a + 1), p.col(b), p.col(b + 1));
        least = std::min(least, ((1 - near.s) * p.col(a) + near.s * p.col(a + 1) -
                                 (1 - near.t) * p.col(b) - near.t * p.col(b + 1))
                                    .norm());
      }
    return least;
  };
  const double touching = 0.01 + 0.005;
  for (const char* integrator : { "rk4", "velocity_verlet" })
  {
    StepSettings settings;
    settings.integrator = integrator;
    Simulator simulator(built.scene, built.initial_state, settings);
    double closest = INFINITY;
    for (int k = 0; k < 1000; ++k)
    {
      ASSERT_EQ(simulator.step().failed_check, StepCheck::None) << integrator << " step " << k;
      closest = std::min(closest, closestAcross(simulator.state().positions));
    }
    const double bound =
        2 * settings.projection_tolerance + std::pow(LINK_END_FRACTION * 0.05, 2) / (2 * touching);
    EXPECT_GE(closest, touching - bound) << integrator;
    EXPECT_LT(closest, touching + 1e-3) << integrator;  // it lies on it
    // the thin rope's middle (particle 10 of it) over the thick rope, not on the floor
    EXPECT_GT(simulator.state().positions(2, n + 10), 0.02) << integrator;
    std::cout << integrator << ": closest links of the two ropes " << std::setprecision(10)
              << closest << " m (r_a + r_b " << touching << " m)\n";
  }
  Scene through = built.scene;
  through.self_collisions.pop_back();
  Simulator simulator(through, built.initial_state, StepSettings{});
  double closest = INFINITY;
  for (int k = 0; k < 1000; ++k)
  {
    simulator.step();
    closest = std::min(closest, closestAcross(simulator.state().positions));
  }
  EXPECT_LT(closest, 0.01);
  std::cout << "the thin rope in no rope: closest " << closest << " m\n";
}

// A particle on two ropes, and a pair listed between two ropes' links, are refused.
TEST(SelfCollision, TwoRopesSharingAParticleOrAListedPairAreRefused)
{
  BuiltScene built = buildScene(parseScene(R"(
chains:
  - {particles: 6, link_length: 0.04, start: [0, 0, 1], self_collision: true, radius: 0.01}
  - {particles: 6, link_length: 0.04, start: [0, 0.5, 1], self_collision: true, radius: 0.01}
)",
                                           "two.yaml"));
  EXPECT_EQ(refusal([&] { Model::compile(built.scene); }), "(accepted)");
  Scene bad = built.scene;
  bad.self_collisions[1].particles[2] = 3;
  EXPECT_NE(refusal([&] { Model::compile(bad); }).find("is in rope self_collisions[0] too"),
            std::string::npos);
  bad = built.scene;
  bad.constraints.push_back(LinkPairContact{ 0, 1, 8, 9, 0.01 });
  EXPECT_NE(refusal([&] { Model::compile(bad); }).find("ropes self_collisions[0] and [1]"),
            std::string::npos);
}
