// What contact costs (issue 35): a chain of n particles (10 g, 1 cm links) lying at rest on the
// plane z = 0 with a surface_contact each (friction 0.3), against the same chain with no contact
// (falling freely: the fused chain path) and the same chain with no contact on the generic stages
// and the sparse solve (what a contact scene's path costs without the contacts). RK4 +
// projection, dt = 1 ms, tolerance 1e-10 m. For each n, rounds of one batch of each, CPU time of
// this thread; the table gives the median cost per particle-step of each and the median of the
// rounds' ratios, and the exponent of the contact chain's cost per step against n fitted by least
// squares over log n. Writes contact.csv into --out.
// Usage: bench_contact [--quick] [--out DIR]   (scripts/bench.sh --contact runs it into docs/bench)
#include "constrained_particles/core/simulator.hpp"

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
double cpuSeconds()
{
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

double median(std::vector<double> v)
{
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

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

double timeSteps(Simulator& sim, int steps)
{
  const double t0 = cpuSeconds();
  sim.step(steps);
  return cpuSeconds() - t0;
}
}  // namespace

int main(int argc, char** argv)
{
  bool quick = false;
  std::string out = ".";
  for (int k = 1; k < argc; ++k)
  {
    const std::string arg = argv[k];
    if (arg == "--quick")
      quick = true;
    else if (arg == "--out" && k + 1 < argc)
      out = argv[++k];
  }
  const std::vector<int> sizes =
      quick ? std::vector<int>{ 1000, 10000 } : std::vector<int>{ 1000, 10000, 100000 };
  const int rounds = quick ? 3 : 7;
  std::ofstream csv(out + "/contact.csv");
  csv << "n,contact_us_per_particle_step,free_fused_us_per_particle_step,"
         "free_generic_sparse_us_per_particle_step,contact_over_fused,contact_over_generic\n";
  std::printf("%8s %14s %14s %14s %10s %10s\n", "n", "contact [us]", "no contact", "generic sparse",
              "c/fused", "c/generic");
  std::vector<double> log_n, log_cost;
  for (const int n : sizes)
  {
    const int steps = std::max(2, 200000 / n);
    Simulator with = chainOnPlane(n, true, StagePaths::Specialized, SolveMethod::Automatic);
    Simulator fused = chainOnPlane(n, false, StagePaths::Specialized, SolveMethod::Automatic);
    Simulator generic = chainOnPlane(n, false, StagePaths::Generic, SolveMethod::Sparse);
    std::vector<double> c, f, g, cf, cg;
    for (int r = 0; r < rounds; ++r)
    {
      const double tc = timeSteps(with, steps), tf = timeSteps(fused, steps),
                   tg = timeSteps(generic, steps);
      const double scale = 1e6 / (static_cast<double>(steps) * n);
      c.push_back(tc * scale);
      f.push_back(tf * scale);
      g.push_back(tg * scale);
      cf.push_back(tc / tf);
      cg.push_back(tc / tg);
    }
    // the chain still lies on the plane, its links exact: the figures are of the case named
    const Points& p = with.state().positions;
    if (p.row(2).minCoeff() < -1e-9 || p.row(2).maxCoeff() > 1e-9)
      std::fprintf(stderr, "n = %d: the chain left the plane (z in [%g, %g])\n", n,
                   p.row(2).minCoeff(), p.row(2).maxCoeff());
    std::printf("%8d %14.4f %14.4f %14.4f %10.2f %10.2f\n", n, median(c), median(f), median(g),
                median(cf), median(cg));
    csv << n << "," << median(c) << "," << median(f) << "," << median(g) << "," << median(cf) << ","
        << median(cg) << "\n";
    log_n.push_back(std::log(static_cast<double>(n)));
    log_cost.push_back(std::log(median(c) * n));  // cost per step
  }
  // least-squares slope of log(cost per step) against log n
  double mx = 0, my = 0;
  for (std::size_t k = 0; k < log_n.size(); ++k)
  {
    mx += log_n[k] / log_n.size();
    my += log_cost[k] / log_n.size();
  }
  double sxy = 0, sxx = 0;
  for (std::size_t k = 0; k < log_n.size(); ++k)
  {
    sxy += (log_n[k] - mx) * (log_cost[k] - my);
    sxx += (log_n[k] - mx) * (log_n[k] - mx);
  }
  std::printf("exponent of the contact chain's cost per step in n: %.3f\n", sxy / sxx);
  csv << "# exponent," << sxy / sxx << "\n";
  return 0;
}
