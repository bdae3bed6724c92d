// Headless run of every shipped scene without ROS: prints sim time, energy and max constraint
// error. Usage: constrained_particles_demo [seconds] [scene directory]
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace constrained_particles;

int main(int argc, char** argv)
{
  const double duration = argc > 1 ? std::atof(argv[1]) : 5.0;  // simulated seconds
  const std::string directory = argc > 2 ? argv[2] : SCENES_DIR;
  bool all_finite = true;
  for (const std::string& name : listScenes(directory))
  {
    const SceneDescription description = loadSceneFile(resolveScene(name, directory));
    const BuiltScene built = buildScene(description);
    const StepSettings settings = description.solver.applyTo(StepSettings{});
    Simulator simulator(built.scene, built.initial_state, settings,
                        description.solver.solve_method);
    std::printf("== %s: %d particles, %s + %s, dt = %g s, solve %s\n", name.c_str(),
                simulator.model().numParticles(), settings.integrator.c_str(),
                stabilizationName(settings.stabilization), settings.dt,
                solveMethodName(simulator.model().solveMethod()));
    const int steps_per_report = static_cast<int>(1.0 / settings.dt + 0.5);
    const Diagnostics start = simulator.diagnostics();
    const auto wall_start = std::chrono::steady_clock::now();
    while (simulator.state().time < duration - 0.5 * settings.dt)
    {
      simulator.step(steps_per_report);
      const Diagnostics d = simulator.diagnostics();
      all_finite = all_finite && d.finite();
      std::printf("t = %6.3f s  energy = %12.6f J (drift %+.3e J)  max error = %.3e m, %.3e m/s\n",
                  simulator.state().time, d.totalEnergy(), d.totalEnergy() - start.totalEnergy(),
                  d.max_position_error, d.max_velocity_error);
    }
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    std::printf("   %llu steps in %.3f s wall (%.2f us/step)\n",
                static_cast<unsigned long long>(simulator.state().steps), wall,
                1e6 * wall / static_cast<double>(simulator.state().steps));
  }
  return all_finite ? EXIT_SUCCESS : EXIT_FAILURE;
}
