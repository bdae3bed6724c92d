// Headless run of every shipped scene (or of the scenes named) without ROS: prints sim time,
// energy and max constraint error.
// Usage: constrained_particles_demo [seconds] [scene directory or file] [scene name or file ...]
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include <sys/stat.h>

using namespace constrained_particles;

int main(int argc, char** argv)
{
  double duration = 5.0;  // simulated seconds
  if (argc > 1)
  {
    char* end = nullptr;
    duration = std::strtod(argv[1], &end);
    if (end == argv[1] || *end != '\0' || !std::isfinite(duration) || duration < 0.0 ||
        duration > 1e6)
    {
      std::fprintf(
          stderr,
          "usage: constrained_particles_demo [seconds] [scene directory or file] [scene ...]\n"
          "seconds: simulated time per scene, in [0, 1e6] s (got '%s')\n",
          argv[1]);
      return 2;
    }
  }
  // a scene file in the directory's place is a scene, read with the shipped ones beside it
  std::string directory = SCENES_DIR;
  std::vector<std::string> names;
  struct stat info;
  if (argc > 2 && stat(argv[2], &info) == 0 && S_ISREG(info.st_mode))
    names.push_back(argv[2]);
  else if (argc > 2 && !(stat(argv[2], &info) == 0 && S_ISDIR(info.st_mode)))
  {
    std::fprintf(stderr, "scene directory '%s': no such directory or scene file\n", argv[2]);
    return 2;
  }
  else if (argc > 2)
    directory = argv[2];
  names.insert(names.end(), argv + std::min(argc, 3), argv + argc);
  if (names.empty())
    names = listScenes(directory);
  bool all_finite = true;
  for (const std::string& name : names)
  {
    std::unique_ptr<Simulator> made;
    StepSettings settings;
    try  // a bad file is reported by name and the other scenes still run
    {
      const SceneDescription description = loadSceneFile(resolveScene(name, directory));
      const BuiltScene built = buildScene(description);
      settings = description.solver.applyTo(StepSettings{});
      made = std::make_unique<Simulator>(built.scene, built.initial_state, settings,
                                         description.solver.solve_method);
    }
    catch (const std::exception& error)
    {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), error.what());
      all_finite = false;
      continue;
    }
    Simulator& simulator = *made;
    std::printf("== %s: %d particles, %s + %s, dt = %g s, solve %s\n", name.c_str(),
                simulator.model().numParticles(), settings.integrator.c_str(),
                stabilizationName(settings.stabilization), settings.dt,
                solveMethodName(simulator.model().solveMethod()));
    const int steps_per_report = std::max(1, static_cast<int>(1.0 / settings.dt + 0.5));
    const Diagnostics start = simulator.diagnostics();
    const auto wall_start = std::chrono::steady_clock::now();
    const long total_steps = std::lround(duration / settings.dt);  // the duration, to one dt
    while (static_cast<long>(simulator.state().steps) < total_steps)
    {
      const StepStatistics taken = simulator.step(static_cast<int>(std::min<long>(
          steps_per_report, total_steps - static_cast<long>(simulator.state().steps))));
      // a failed check puts the step back (max_substeps > 1): the run cannot go on from here
      if (taken.failed_check != StepCheck::None && settings.max_substeps > 1)
      {
        std::printf("stopped: step check %s failed at t = %.6f s\n",
                    stepCheckName(taken.failed_check), simulator.state().time);
        all_finite = false;
        break;
      }
      const Diagnostics d = simulator.diagnostics();
      all_finite = all_finite && d.finite();
      std::printf("t = %6.3f s  energy = %12.6f J (drift %+.3e J)  max error = %.3e m, %.3e m/s\n",
                  simulator.state().time, d.totalEnergy(), d.totalEnergy() - start.totalEnergy(),
                  d.max_position_error, d.max_velocity_error);
    }
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    const unsigned long long steps = simulator.state().steps;
    std::printf("   %llu steps in %.3f s wall (%.2f us/step)\n", steps, wall,
                steps > 0 ? 1e6 * wall / static_cast<double>(steps) : 0.0);
  }
  return all_finite ? EXIT_SUCCESS : EXIT_FAILURE;
}
