// How far the engine's chain step is from the machine (issue 17): the engine against the
// minimum-work kernel (bench/minimum_kernel.hpp) on the peer workload (bench_common.hpp's
// PeerChain: RK4 + projection, tolerance 1e-10 m, dt = 1 ms), in one process, interleaved.
// For each n: both follow the same trajectory (max position difference after 1 s of steps,
// 0.1 s with --quick), then rounds of one batch of engine steps and one of kernel steps, CPU
// time of this thread; the table gives the medians per step and the median of the rounds'
// ratios, for the engine as it runs (e/k) and on its generic stages (g/k: the engine before the
// fused chain stages, StagePaths::Generic) and at the node's default step settings (c/k: the
// stability estimate, sub-step retakes and energy budget on). Writes kernel.csv into --out.
// Usage: bench_kernel [--quick] [--out DIR]   (scripts/bench.sh --kernel runs it into docs/bench)
//        bench_kernel --profile engine|generic|checked|kernel N STEPS
//          (steps only, for callgrind: twice with different STEPS and divide the difference in
//          instructions by N times that in STEPS)
//        bench_kernel --kernel-time N SECONDS
//          (the kernel's median wall time per step, for scripts/node_kernel_ratio.py)
//        bench_kernel --engine-time N SECONDS [checked]
//          (the engine's, Simulator::step on the same chain: at max_substeps 1, or with
//          `checked` at the node's default step settings; for node_kernel_ratio.py --against)
#include "bench_common.hpp"
#include "minimum_kernel.hpp"

#include "constrained_particles/core/simulator.hpp"

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>

namespace cp = constrained_particles;

namespace
{
constexpr double TOLERANCE = 1e-10;  // projection tolerance [m], the peer table's
constexpr int ROUNDS = 7;            // interleaved rounds per size
constexpr double BATCH_CPU = 0.1;    // CPU time a batch aims at [s]

struct Pair
{
  std::unique_ptr<cp::Simulator> engine;
  std::unique_ptr<cp::Simulator> generic;  // the engine on its generic stages (before issue 17)
  std::unique_ptr<cp::Simulator> checked;  // the engine at the node's defaults: every step check
  std::unique_ptr<bench::MinimumChainKernel> kernel;
};

// the peer chain in both: laid out along +x from the pinned origin, at rest
Pair makePair(const bench::PeerChain& chain)
{
  const int n = chain.n;
  cp::Scene scene;
  scene.name = "pinned_chain";
  scene.masses.assign(n, chain.particle_mass);
  cp::GravityForce gravity;
  gravity.acceleration = cp::Vec3(0.0, 0.0, chain.gravity);
  scene.forces = { gravity };
  for (int k = 0; k + 1 < n; ++k)
    scene.constraints.push_back(cp::LinkConstraint{ k, k + 1, chain.link_length });
  scene.constraints.push_back(cp::PinConstraint{ 0, cp::Vec3::Zero() });
  cp::State start;
  start.positions.setZero(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
    start.positions(0, i) = chain.link_length * i;
  cp::StepSettings s;
  s.max_substeps = 1;  // the integrator itself, as in the peer table
  s.dt = chain.dt;
  s.integrator = "rk4";
  s.stabilization = cp::Stabilization::Projection;
  s.projection_tolerance = TOLERANCE;
  Pair pair;
  pair.engine = std::make_unique<cp::Simulator>(scene, start, s);
  pair.generic = std::make_unique<cp::Simulator>(scene, start, s, cp::SolveMethod::Automatic,
                                                 cp::StagePaths::Generic);
  // the node's defaults (StepSettings{}, config/default.yaml): the stability estimate, the
  // sub-step retakes and the energy budget on, as a user's node steps
  cp::StepSettings node = s;
  node.max_substeps = cp::StepSettings{}.max_substeps;
  node.energy_budget = cp::StepSettings{}.energy_budget;
  pair.checked = std::make_unique<cp::Simulator>(scene, start, node);
  pair.kernel = std::make_unique<bench::MinimumChainKernel>(
      n, chain.link_length, chain.particle_mass, chain.gravity, chain.dt, TOLERANCE,
      s.projection_max_iterations);
  const cp::State& x = pair.engine->state();
  pair.kernel->setState(x.positions.data(), x.velocities.data());
  return pair;
}

double maxDifference(const Pair& pair)
{
  const cp::Points& p = pair.engine->state().positions;
  const std::vector<double>& q = pair.kernel->positions();
  double worst = 0.0;
  for (int c = 0; c < p.size(); ++c)
    worst = std::max(worst, std::abs(p.data()[c] - q[c]));
  return worst;
}

template <typename Fn>
double timeBatch(int steps, Fn step)
{
  const double start = bench::threadCpuSeconds();
  for (int k = 0; k < steps; ++k)
    step();
  return (bench::threadCpuSeconds() - start) / steps;
}

int profile(const std::string& which, int n, int steps)
{
  if (which != "engine" && which != "generic" && which != "kernel" && which != "checked")
  {
    std::cerr << "--profile takes engine, generic, checked or kernel, not '" << which << "'\n";
    return 2;
  }
  bench::PeerChain chain;
  chain.n = n;
  Pair pair = makePair(chain);
  for (int k = 0; k < steps; ++k)
    which == "engine"    ? (void)pair.engine->step()
    : which == "generic" ? (void)pair.generic->step()
    : which == "checked" ? (void)pair.checked->step()
                         : pair.kernel->step();
  std::printf("%s n = %d: %d steps\n", which.c_str(), n, steps);
  return 0;
}

// `which` (kernel, engine or checked) alone for `seconds` of wall time, from rest, in batches of
// about BATCH_CPU: the median wall time per step [s] (scripts/node_kernel_ratio.py sets it beside
// the node's ~state.step_time, which is wall time too).
int wallTime(const std::string& which, int n, double seconds)
{
  if (n < 2 || !(seconds > 0.0))
  {
    std::cerr << "--" << which << "-time takes N >= 2 particles and SECONDS > 0, not " << n
              << " and " << seconds << "\n";
    return 2;
  }
  bench::PeerChain chain;
  chain.n = n;
  Pair pair = makePair(chain);
  const auto step = [&]
  {
    if (which == "kernel")
      pair.kernel->step();
    else if (which == "checked")
      pair.checked->step();
    else
      pair.engine->step();
  };
  const double estimate = timeBatch(1, step);
  const int batch = std::max(1, static_cast<int>(BATCH_CPU / std::max(estimate, 1e-9)));
  std::vector<double> per_step;
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < seconds)
  {
    const auto batch_start = std::chrono::steady_clock::now();
    for (int k = 0; k < batch; ++k)
      step();
    per_step.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - batch_start).count() /
        batch);
  }
  std::printf("%s n = %d: %.6e s/step (median of %zu batches of %d steps)\n", which.c_str(), n,
              bench::median(per_step), per_step.size(), batch);
  return 0;
}

}  // namespace

int main(int argc, char** argv)
{
  std::string out = ".";
  bool quick = false;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if (arg == "--out" && i + 1 < argc)
      out = argv[++i];
    else if (arg == "--quick")
      quick = true;
    else if (arg == "--kernel-time" && i + 2 < argc)
      return wallTime("kernel", std::atoi(argv[i + 1]), std::atof(argv[i + 2]));
    else if (arg == "--engine-time" && i + 2 < argc)
      return wallTime(i + 3 < argc && std::string(argv[i + 3]) == "checked" ? "checked" : "engine",
                      std::atoi(argv[i + 1]), std::atof(argv[i + 2]));
    else if (arg == "--profile" && i + 3 < argc)
      return profile(argv[i + 1], std::atoi(argv[i + 2]), std::atoi(argv[i + 3]));
    else
    {
      std::cerr << "unknown argument " << arg
                << "\nusage: bench_kernel [--quick] [--out DIR] | --profile "
                   "engine|generic|checked|kernel "
                   "N STEPS | --kernel-time N SECONDS | --engine-time N SECONDS [checked]\n";
      return 2;
    }
  }
  const std::vector<int> sizes =
      quick ? std::vector<int>{ 10, 100, 1000 } : std::vector<int>{ 10, 100, 1000, 10000, 100000 };
  std::ofstream csv(out + "/kernel.csv");
  csv << "n,steps_compared,max_position_difference_m,engine_s_per_step,kernel_s_per_step,"
         "ratio_median,ratio_min,ratio_max,engine_particle_steps_per_s,generic_s_per_step,"
         "generic_ratio_median,checked_s_per_step,checked_ratio_median\n";
  std::printf("%8s %11s %12s %12s %12s %12s %8s %8s %8s %10s\n", "n", "difference", "engine [us]",
              "kernel [us]", "generic [us]", "checked [us]", "e/k", "g/k", "c/k", "M p-st/s");
  for (int n : sizes)
  {
    bench::PeerChain chain;
    chain.n = n;
    Pair pair = makePair(chain);
    const int compared = static_cast<int>(std::lround((quick ? 0.1 : 1.0) / chain.dt));
    // the same trajectory first: every step both, then the largest difference of any coordinate
    for (int k = 0; k < compared; ++k)
    {
      pair.engine->step();
      pair.kernel->step();
      pair.generic->step();
      pair.checked->step();
    }
    const double difference = maxDifference(pair);
    // batch length from one step of each, so a batch takes about BATCH_CPU
    const double estimate = timeBatch(1, [&] { pair.engine->step(); });
    const int batch = std::max(1, static_cast<int>(BATCH_CPU / std::max(estimate, 1e-9)));
    std::vector<double> engine, kernel, generic, checked, ratios, generic_ratios, checked_ratios;
    for (int r = 0; r < ROUNDS; ++r)
    {
      engine.push_back(timeBatch(batch, [&] { pair.engine->step(); }));
      kernel.push_back(timeBatch(batch, [&] { pair.kernel->step(); }));
      generic.push_back(timeBatch(batch, [&] { pair.generic->step(); }));
      checked.push_back(timeBatch(batch, [&] { pair.checked->step(); }));
      ratios.push_back(engine.back() / kernel.back());
      generic_ratios.push_back(generic.back() / kernel.back());
      checked_ratios.push_back(checked.back() / kernel.back());
    }
    const double e = bench::median(engine), q = bench::median(kernel);
    const double g = bench::median(generic), c = bench::median(checked);
    const double ratio = bench::median(ratios), generic_ratio = bench::median(generic_ratios);
    const double checked_ratio = bench::median(checked_ratios);
    const double lowest = *std::min_element(ratios.begin(), ratios.end());
    const double highest = *std::max_element(ratios.begin(), ratios.end());
    std::printf("%8d %11.3g %12.2f %12.2f %12.2f %12.2f %8.2f %8.2f %8.2f %10.2f\n", n, difference,
                e * 1e6, q * 1e6, g * 1e6, c * 1e6, ratio, generic_ratio, checked_ratio,
                n / e * 1e-6);
    std::fflush(stdout);
    char line[320];
    std::snprintf(line, sizeof(line),
                  "%d,%d,%.3e,%.6e,%.6e,%.4f,%.4f,%.4f,%.4e,%.6e,%.4f,%.6e,%.4f", n, compared,
                  difference, e, q, ratio, lowest, highest, n / e, g, generic_ratio, c,
                  checked_ratio);
    csv << line << "\n";
    csv.flush();
  }
  std::fprintf(stderr, "wrote %s/kernel.csv\n", out.c_str());
  return 0;
}
