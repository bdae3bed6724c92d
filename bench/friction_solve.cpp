// What Coulomb friction costs, and whether its solve holds (issue 48, item 3): each shipped scene
// with friction stepped 2 s from its start (the median over 3 runs of the wall time a step, and
// the friction solves stopped short, ~state's unconverged_friction), and a rope over a fixed
// cylinder pulled at both ends at 0.999 and 1.001 of the capstan ratio (the discrete one, within
// 6e-4 of e^(mu pi)) for 0.5 s: how far its heavier end moved (held: under 1e-9 m; slipped: mm).
// Usage: bench_friction [SCENES_DIR]   (about 1 minute on 2 cores)
#include "bench_common.hpp"
#include "capstan_rope.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

using namespace constrained_particles;

namespace
{
struct Run
{
  double step_us;    ///< wall time a step [us]
  long unconverged;  ///< friction solves stopped short
  double end_moved;  ///< the first particle's distance from its start [m]
};

// `steps` steps of `scene` from `start` at dt 1 ms, rk4 (or the scene file's settings)
Run runOf(const Scene& scene, const State& start, const StepSettings& settings, long steps)
{
  Simulator sim(scene, start, settings);
  const auto t0 = std::chrono::steady_clock::now();
  const StepStatistics taken = sim.step(steps);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return { 1e6 * seconds / static_cast<double>(steps), taken.unconverged_friction,
           (sim.state().positions.col(0) - start.positions.col(0)).norm() };
}

// `runOf` three times: the median wall time a step (bench_common.hpp's median), the rest of the
// last run (the counts are the same in every run: the steps are deterministic)
Run medianOf3(const Scene& scene, const State& start, const StepSettings& settings, long steps)
{
  std::vector<double> times;
  Run run{};
  for (int k = 0; k < 3; ++k)
  {
    run = runOf(scene, start, settings, steps);
    times.push_back(run.step_us);
  }
  run.step_us = bench::median(times);
  return run;
}

// the capstan rope (capstan_rope.hpp) at `load` times its ratio, 0.5 s at dt 1 ms (rk4)
Run capstanRun(double mu, double load)
{
  const CapstanRope rope = capstanRope(mu, load);
  StepSettings settings;
  settings.dt = 1e-3;
  return runOf(rope.scene, rope.start, settings, 500);
}
}  // namespace

int main(int argc, char** argv)
{
  const std::string directory = argc > 1 ? argv[1] : SCENES_DIR;
  std::printf("shipped scenes with friction, 2 s from the start (median of 3 runs)\n");
  std::printf("%-24s %12s %14s\n", "scene", "us/step", "unconverged");
  for (const char* name : { "friction_ramp", "dome", "surface_chain_contact", "rope_on_table",
                            "rope_over_edge", "rope_over_post", "rope_pile" })
  {
    const SceneDescription description = loadSceneFile(directory + "/" + name + ".yaml");
    const BuiltScene built = buildScene(description);
    const StepSettings settings = description.solver.applyTo(StepSettings{});
    const long steps = std::lround(2.0 / settings.dt);
    const Run run = medianOf3(built.scene, built.initial_state, settings, steps);
    std::printf("%-24s %12.1f %14ld\n", name, run.step_us, run.unconverged);
  }
  std::printf("\nrope over a cylinder, half a turn, 0.5 s at dt 1 ms (rk4)\n");
  std::printf("%6s %8s %14s %14s %12s\n", "mu", "load", "end moved [m]", "unconverged", "us/step");
  for (double mu : { 0.1, 0.2, 0.3, 0.4, 0.5 })
    for (double load : { 0.999, 1.001 })
    {
      const Run run = capstanRun(mu, load);
      std::printf("%6.2f %8.3f %14.3g %14ld %12.1f\n", mu, load, run.end_moved, run.unconverged,
                  run.step_us);
    }
  return 0;
}
