/// @file test_link_pair_contact.cpp
/// @brief WIP (issue 48, item 2): two links as capsules, the row's geometry
/// (link_pair_contact.hpp): closest points against a dense sampling, Cdot and Cddot against
/// central differences along paths, with both closest points inside and with one at an end.
#include "test_helpers.hpp"

#include "constrained_particles/core/effects/link_pair_contact.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

using namespace constrained_particles;
using constrained_particles::testing::Random;

namespace
{
double gapAt(const LinkPairContact& c, const Points& p)
{
  return linkPairFrame(c, p, Points::Zero(3, 4)).gap;
}

TEST(LinkPairContact, ClosestPointsAreTheLeastDistanceBetweenTheSegments)
{
  Random random(7);
  const LinkPairContact c;
  for (int trial = 0; trial < 200; ++trial)
  {
    Points p(3, 4);
    for (int i = 0; i < 4; ++i)
      p.col(i) = random.vector(1.0);
    const double found = gapAt(c, p);
    double sampled = INFINITY;
    const int m = 300;
    for (int a = 0; a <= m; ++a)
      for (int b = 0; b <= m; ++b)
      {
        const double s = double(a) / m, t = double(b) / m;
        sampled = std::min(
            sampled,
            ((1 - s) * p.col(0) + s * p.col(1) - (1 - t) * p.col(2) - t * p.col(3)).norm());
      }
    EXPECT_LE(found, sampled + 1e-12) << trial;
    // the grid's points are within half a cell of the true closest ones
    const double cell = ((p.col(1) - p.col(0)).norm() + (p.col(3) - p.col(2)).norm()) / m;
    EXPECT_GE(found, sampled - cell) << trial;
  }
}

// Along p(tau) = p + tau v + tau^2 / 2 a: C's first and second derivatives at 0 against J v and
// J a + Jdot v. Cases: links crossing at a distance (both points inside), and one link's end
// nearest the other's middle (s* at its bound, t* inside). Without the minimiser's own motion
// (the -g^T H^-1 g term) the second derivative is off: checked, so the test can fail.
TEST(LinkPairContact, RowRatesMatchDifferencesAlongAPath)
{
  Random random(11);
  const LinkPairContact c;
  int inside = 0, one_end = 0, moving_minimiser = 0;
  for (int trial = 0; trial < 400; ++trial)
  {
    Points p(3, 4), v(3, 4), a(3, 4);
    const bool end_case = trial % 2 == 1;
    // link a along x around the origin, link b across it above (or its end over a's middle)
    const Vec3 centre_b(random.uniform(-0.2, 0.2), random.uniform(-0.2, 0.2),
                        random.uniform(0.1, 0.3));
    p.col(0) = Vec3(-0.5, random.uniform(-0.1, 0.1), 0.0);
    p.col(1) = Vec3(0.5, random.uniform(-0.1, 0.1), random.uniform(-0.05, 0.05));
    const Vec3 along_b =
        Vec3(random.uniform(-0.3, 0.3), 1.0, random.uniform(-0.2, 0.2)).normalized();
    if (end_case)
    {
      p.col(2) = centre_b;  // b starts above a's middle and rises away from it
      p.col(3) = centre_b + 0.5 * (along_b + Vec3(0, 0, 1.5)).normalized();
    }
    else
    {
      p.col(2) = centre_b - 0.5 * along_b;
      p.col(3) = centre_b + 0.5 * along_b;
    }
    for (int i = 0; i < 4; ++i)
    {
      v.col(i) = random.vector(1.0);
      a.col(i) = random.vector(3.0);
    }
    const LinkPairFrame f = linkPairFrame(c, p, v);
    if (!f.between)
      continue;
    const bool interior = f.s > 1e-6 && f.s < 1 - 1e-6 && f.t > 1e-6 && f.t < 1 - 1e-6;
    inside += interior ? 1 : 0;
    one_end += interior ? 0 : 1;
    const double h = 1e-4;
    auto gap = [&](double tau) { return gapAt(c, p + tau * v + 0.5 * tau * tau * a); };
    const double g0 = gap(0.0), gp = gap(h), gm = gap(-h);
    const std::array<Vec3, 4> jacobian = linkPairJacobian(f);
    double jv = 0.0, ja = 0.0;
    for (int i = 0; i < 4; ++i)
    {
      jv += jacobian[i].dot(v.col(i));
      ja += jacobian[i].dot(a.col(i));
    }
    const double cdot = (gap(0.1 * h) - gap(-0.1 * h)) / (0.2 * h),
                 cddot = (gp - 2 * g0 + gm) / (h * h);
    EXPECT_NEAR(jv, cdot, 1e-8 * (1 + std::abs(cdot))) << trial;
    EXPECT_NEAR(ja + f.curvature_term, cddot, 2e-3 * (1 + std::abs(cddot))) << trial;
    // the same without the minimiser's motion: off wherever that term is not small
    const LinkPairFrame fixed_point = f;
    const Vec3 dw = (1 - f.s) * v.col(0) + f.s * v.col(1) - (1 - f.t) * v.col(2) - f.t * v.col(3);
    const double d = f.gap + 2 * c.radius;
    const double plain = (dw.squaredNorm() - std::pow(f.normal.dot(dw), 2)) / d;
    if (std::abs(plain - fixed_point.curvature_term) > 0.1 * (1 + std::abs(cddot)))
    {
      ++moving_minimiser;
      EXPECT_GT(std::abs(ja + plain - cddot), 10 * 2e-3 * (1 + std::abs(cddot))) << trial;
    }
  }
  EXPECT_GT(inside, 100);
  EXPECT_GT(one_end, 100);
  EXPECT_GT(moving_minimiser, 100);  // the envelope term mattered in most cases
  std::cout << inside << " with both points inside, " << one_end << " with one at an end, "
            << moving_minimiser << " where the minimiser's motion mattered\n";
}

// Links near parallel (sin^2 of the angle under PARALLEL_SINE2), exactly parallel included, have
// their point put at an end of their overlap (the minimiser would sweep it as 1 / sin^2; exactly
// parallel, Ericson's choice is link a's end, outside the overlap when a is the longer): the gap
// is the overlap's, the row may act, its curvature term finite. Further from parallel both points
// are inside.
TEST(LinkPairContact, NearlyParallelLinksMeetAtTheirOverlapsEnd)
{
  const LinkPairContact c;
  Points p(3, 4), v = Points::Zero(3, 4);
  v.col(2) = Vec3(0.0, 0.3, 0.0);
  for (const double angle : { 0.0, 1e-5, 5e-4, 2e-3, 0.1 })
  {
    p.col(0) = Vec3(-0.5, 0, 0);
    p.col(1) = Vec3(0.5, 0, 0);
    p.col(2) = Vec3(-0.4 * std::cos(angle), -0.4 * std::sin(angle), 0.02);
    p.col(3) = Vec3(0.4 * std::cos(angle), 0.4 * std::sin(angle), 0.02);
    const LinkPairFrame f = linkPairFrame(c, p, v);
    const bool near_parallel = std::sin(angle) * std::sin(angle) < PARALLEL_SINE2;
    EXPECT_EQ(f.s_at_end || f.t_at_end, near_parallel) << angle;
    EXPECT_TRUE(f.between) << angle;
    EXPECT_TRUE(std::isfinite(f.curvature_term)) << angle;
    // they cross 2 cm apart (or overlap so); an overlap's end is further by at most
    // sin^2 |e_b|^2 / (2 d), under PARALLEL_SINE2 (0.8 m)^2 / (2 * 0.02 m)
    EXPECT_GE(f.gap, 0.02 - 1e-12) << angle;
    EXPECT_LE(f.gap, 0.02 + (near_parallel ? PARALLEL_SINE2 * 0.64 / 0.04 : 1e-12)) << angle;
  }
}

}  // namespace
