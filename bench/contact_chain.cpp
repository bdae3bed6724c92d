// What contact costs (issue 35): a chain of n particles (10 g, 1 cm links) lying at rest on the
// plane z = 0 with a surface_contact each (friction 0.3; the solve it takes, the tree's
// elimination, and the sparse LDL^T), against the same chain with no contact (falling freely: the
// fused chain path) and the same chain with no contact on the generic stages and the sparse solve
// (what a contact scene's path costs without the contacts). RK4 + projection, dt = 1 ms,
// tolerance 1e-10 m. For each n, rounds of one batch of each, CPU time of this thread; the table
// gives the median cost per particle-step of each and the median of the rounds' ratios, and the
// exponent of each one's cost per step against n fitted by least squares over log n (the chain
// without contact's exponent is the machine's memory hierarchy: its work per particle is fixed).
// Writes contact.csv into --out.
// Usage: bench_contact [--quick] [--out DIR]   (scripts/bench.sh --contact runs it into docs/bench)
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
// n particles along +x on z = 0, linked, each with a contact on the plane if `contact`
Simulator chainOnPlane(int n, bool contact, StagePaths paths, SolveMethod method)
{
  Scene scene;
  scene.masses.assign(n, 0.01);
  scene.surfaces = { makeSurface(SurfaceType::Plane, { 0.0, 0.0, 0.0 }) };
  scene.forces = { GravityForce{} };
  for (int i = 0; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, 0.01 });
  if (contact)
    for (int i = 0; i < n; ++i)
      scene.constraints.push_back(SurfaceContact{ i, 0, 0.3, 0.0 });
  State start;
  start.positions.setZero(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
    start.positions(0, i) = 0.01 * i;
  StepSettings settings;
  settings.dt = 1e-3;
  settings.integrator = "rk4";
  settings.max_substeps = 1;  // the step as asked: the comparison is of the stages, not the checks
  settings.energy_budget = 0.0;
  return Simulator(scene, start, settings, method, paths);
}

// least-squares slope of y against x
double slopeOf(const std::vector<double>& x, const std::vector<double>& y)
{
  double mx = 0, my = 0;
  for (std::size_t k = 0; k < x.size(); ++k)
  {
    mx += x[k] / x.size();
    my += y[k] / x.size();
  }
  double sxy = 0, sxx = 0;
  for (std::size_t k = 0; k < x.size(); ++k)
  {
    sxy += (x[k] - mx) * (y[k] - my);
    sxx += (x[k] - mx) * (x[k] - mx);
  }
  return sxy / sxx;
}

double timeSteps(Simulator& sim, int steps)
{
  const double t0 = bench::threadCpuSeconds();
  sim.step(steps);
  return bench::threadCpuSeconds() - t0;
}
}  // namespace

int main(int argc, char** argv)
{
  const bench::Options options = bench::parseOptions(argc, argv);
  // the exponent is fitted over 1,000 to 100,000 (issue 35's range); 10^6, past every cache, gives
  // the slope from 10^5 on its own
  const std::vector<int> sizes = options.quick ? std::vector<int>{ 1000, 10000 }
                                               : std::vector<int>{ 1000, 10000, 100000, 1000000 };
  const int rounds = options.quick ? 3 : 7;
  std::ofstream csv(options.out + "/contact.csv");
  csv << "n,contact_us_per_particle_step,contact_sparse_us_per_particle_step,"
         "free_fused_us_per_particle_step,free_generic_sparse_us_per_particle_step,"
         "contact_over_fused,contact_over_generic\n";
  std::printf("%8s %14s %14s %14s %14s %10s %10s\n", "n", "contact [us]", "c, sparse", "no contact",
              "generic sparse", "c/fused", "c/generic");
  std::vector<double> log_n;
  std::vector<double> log_cost[4];  // contact, contact sparse, fused, generic sparse
  for (const int n : sizes)
  {
    const int steps = std::max(2, 200000 / n);
    Simulator with = chainOnPlane(n, true, StagePaths::Specialized, SolveMethod::Automatic);
    Simulator with_sparse = chainOnPlane(n, true, StagePaths::Specialized, SolveMethod::Sparse);
    Simulator fused = chainOnPlane(n, false, StagePaths::Specialized, SolveMethod::Automatic);
    Simulator generic = chainOnPlane(n, false, StagePaths::Generic, SolveMethod::Sparse);
    std::vector<double> c, cs, f, g, cf, cg;
    for (int r = 0; r < rounds; ++r)
    {
      const double tc = timeSteps(with, steps), ts = timeSteps(with_sparse, steps),
                   tf = timeSteps(fused, steps), tg = timeSteps(generic, steps);
      const double scale = 1e6 / (static_cast<double>(steps) * n);
      c.push_back(tc * scale);
      cs.push_back(ts * scale);
      f.push_back(tf * scale);
      g.push_back(tg * scale);
      cf.push_back(tc / tf);
      cg.push_back(tc / tg);
    }
    // the chain still lies on the plane, its links exact: the figures are of the case named
    for (const Simulator* sim : { &with, &with_sparse })
    {
      const Points& p = sim->state().positions;
      if (p.row(2).minCoeff() < -1e-9 || p.row(2).maxCoeff() > 1e-9)
        std::fprintf(stderr, "n = %d: the chain left the plane (z in [%g, %g])\n", n,
                     p.row(2).minCoeff(), p.row(2).maxCoeff());
    }
    std::printf("%8d %14.4f %14.4f %14.4f %14.4f %10.2f %10.2f\n", n, bench::median(c),
                bench::median(cs), bench::median(f), bench::median(g), bench::median(cf),
                bench::median(cg));
    csv << n << "," << bench::median(c) << "," << bench::median(cs) << "," << bench::median(f)
        << "," << bench::median(g) << "," << bench::median(cf) << "," << bench::median(cg) << "\n";
    log_n.push_back(std::log(static_cast<double>(n)));
    const double per_step[4] = { bench::median(c), bench::median(cs), bench::median(f),
                                 bench::median(g) };
    for (int k = 0; k < 4; ++k)
      log_cost[k].push_back(std::log(per_step[k] * n));  // cost per step
  }
  // fitted over n <= 10^5, and from 10^5 to 10^6 where that was run
  const std::size_t fitted = std::min<std::size_t>(log_n.size(), 3);
  auto slope = [&](int k, std::size_t from, std::size_t to)
  {
    return slopeOf(std::vector<double>(log_n.begin() + from, log_n.begin() + to),
                   std::vector<double>(log_cost[k].begin() + from, log_cost[k].begin() + to));
  };
  const char* names[4] = { "contact chain (tree solve)", "contact chain (sparse solve)",
                           "chain without contact (fused)",
                           "chain without contact (generic sparse)" };
  for (int k = 0; k < 4; ++k)
  {
    std::printf("exponent of the %s's cost per step in n, n <= 100000: %.3f\n", names[k],
                slope(k, 0, fitted));
    csv << "# exponent " << names[k] << "," << slope(k, 0, fitted) << "\n";
  }
  if (log_n.size() > 3)
    for (int k = 0; k < 4; ++k)
    {
      std::printf("exponent of the %s's cost per step from 100000 to 1000000: %.3f\n", names[k],
                  slope(k, 2, 4));
      csv << "# exponent beyond the caches " << names[k] << "," << slope(k, 2, 4) << "\n";
    }
  return 0;
}
