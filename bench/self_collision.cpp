// What self-collision costs (issue 48, item 6): a rope of n particles (10 g, 1 cm links, radius
// 4 mm) folded on itself, lying at rest on a frictionless floor (the plane z = 0, a
// surface_contact each) in a serpentine of straight runs of `run` particles, each run touching
// the last (their centre lines 2 r apart), with self_collision on (Scene::self_collisions: the
// link pairs found at each step's start, their rows in the sparse solve); against the same rope
// without self_collision (its floor contacts only: the tree solve) and the same rope falling
// freely with no contact at all (the fused chain path, the "free chain" of the target). RK4 +
// projection, dt = 1 ms, tolerance 1e-10 m. Rounds of one batch of each, CPU time of this thread;
// the medians of the cost per particle-step and of the rounds' ratios, the link pairs the model
// holds, and whether the rope stayed folded (no two links closer than 2 r less 1e-8 m).
// Writes self_collision.csv into --out.
// Usage: bench_self_collision [--quick] [--out DIR]
//        (scripts/bench.sh --self-collision runs it into docs/bench)
#include "constrained_particles/core/self_collision.hpp"
#include "constrained_particles/core/simulator.hpp"

#include "bench_common.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <string>
#include <vector>

using namespace constrained_particles;

namespace
{
constexpr double LINK = 0.01;     // [m]
constexpr double RADIUS = 0.004;  // [m]
constexpr int RUN = 20;           // particles per straight run

// The serpentine: runs along +x and -x in turn, each 2 r further along y, joined by a link
// across (its x step sqrt(l^2 - 4 r^2) keeps it l long)
Points serpentine(int n)
{
  Points p = Points::Zero(3, n);
  const double across = std::sqrt(LINK * LINK - 4.0 * RADIUS * RADIUS);
  for (int i = 1; i < n; ++i)
  {
    const int run = (i - 1) / RUN, within = (i - 1) % RUN;
    const double direction = run % 2 == 0 ? 1.0 : -1.0;
    p.col(i) = p.col(i - 1);
    if (within == RUN - 1)  // the turn into the next run
    {
      p(0, i) += direction * across;
      p(1, i) += 2.0 * RADIUS;
    }
    else
      p(0, i) += direction * LINK;
  }
  return p;
}

enum class Variant
{
  SelfCollision,
  FloorOnly,
  Free
};

Simulator ropeOf(int n, Variant variant)
{
  Scene scene;
  scene.masses.assign(n, 0.01);
  scene.forces = { GravityForce{} };
  for (int i = 0; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, LINK });
  if (variant != Variant::Free)
  {
    scene.surfaces = { makeSurface(SurfaceType::Plane, { 0.0, 0.0, 0.0 }) };
    for (int i = 0; i < n; ++i)
      scene.constraints.push_back(SurfaceContact{ i, 0, 0.0, 0.0 });
  }
  if (variant == Variant::SelfCollision)
  {
    SelfCollision rope;
    rope.radius = RADIUS;
    for (int i = 0; i < n; ++i)
      rope.particles.push_back(i);
    scene.self_collisions = { rope };
  }
  State start;
  start.positions = serpentine(n);
  start.velocities.setZero(3, n);
  StepSettings settings;
  settings.dt = 1e-3;
  settings.integrator = "rk4";
  settings.max_substeps = 1;  // the step as asked: the comparison is of the stages, not the checks
  settings.energy_budget = 0.0;
  return Simulator(scene, start, settings);
}

double timeSteps(Simulator& sim, int steps)
{
  const double t0 = bench::threadCpuSeconds();
  sim.step(steps);
  return bench::threadCpuSeconds() - t0;
}

// the least distance between two links sharing no particle, less 2 r (the row's C), by every
// pair near enough to be the closest
double closestLinks(const Points& p)
{
  double least = 1e300;
  const int links = static_cast<int>(p.cols()) - 1;
  for (int a = 0; a < links; ++a)
    for (int b = a + 2; b < links; ++b)
    {
      // coarse cull: links more than two lengths apart cannot be the closest
      if ((p.col(a) - p.col(b)).norm() > 3.0 * LINK)
        continue;
      LinkPairContact pair{ a, a + 1, b, b + 1, RADIUS };
      least = std::min(least, linkPairGeometry(pair, p).gap);
    }
  return least;
}
}  // namespace

int main(int argc, char** argv)
{
  const bench::Options options = bench::parseOptions(argc, argv);
  const std::vector<int> sizes =
      options.quick ? std::vector<int>{ 200, 1000 } : std::vector<int>{ 200, 1000, 5000 };
  const int rounds = options.quick ? 3 : 7;
  std::ofstream csv(options.out + "/self_collision.csv");
  csv << "n,link_pairs,self_collision_us_per_particle_step,floor_only_us_per_particle_step,"
         "free_us_per_particle_step,self_collision_over_free,self_collision_over_floor_only,"
         "closest_links_less_2r_m\n";
  std::printf("%6s %6s %16s %12s %12s %10s %10s %14s\n", "n", "pairs", "self-coll. [us]",
              "floor [us]", "free [us]", "sc/free", "sc/floor", "closest - 2r");
  for (const int n : sizes)
  {
    const int steps = std::max(5, 50000 / n);
    Simulator folded = ropeOf(n, Variant::SelfCollision);
    Simulator floor = ropeOf(n, Variant::FloorOnly);
    Simulator free = ropeOf(n, Variant::Free);
    folded.step(2);  // its pairs found and compiled in
    std::vector<double> s, f, g, sg, sf;
    for (int r = 0; r < rounds; ++r)
    {
      const double ts = timeSteps(folded, steps), tf = timeSteps(floor, steps),
                   tg = timeSteps(free, steps);
      const double scale = 1e6 / (static_cast<double>(steps) * n);
      s.push_back(ts * scale);
      f.push_back(tf * scale);
      g.push_back(tg * scale);
      sg.push_back(ts / tg);
      sf.push_back(ts / tf);
    }
    const int pairs = folded.model().numContacts() - folded.model().numParticleContacts();
    const double closest = closestLinks(folded.state().positions);
    std::printf("%6d %6d %16.4f %12.4f %12.4f %10.2f %10.2f %14.3g\n", n, pairs, bench::median(s),
                bench::median(f), bench::median(g), bench::median(sg), bench::median(sf), closest);
    csv << n << "," << pairs << "," << bench::median(s) << "," << bench::median(f) << ","
        << bench::median(g) << "," << bench::median(sg) << "," << bench::median(sf) << ","
        << closest << "\n";
    if (closest < -1e-8)
      std::fprintf(stderr, "n = %d: two links %g m closer than 2 r\n", n, -closest);
  }
  return 0;
}
