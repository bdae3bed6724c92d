// Where a contact scene's error goes as dt shrinks, below the decades ~compare_methods runs
// (issue 35): each named integrator (+ projection) from the scene file's start to `horizon` s at
// dt = 1e-4, 1e-5 and 2e-6 s, its largest particle distance from RK4 + projection at 1e-6 s (the
// reference) at the end. Events (landings, lift-offs, stick and slip) are found at step ends, so
// a run's branch at a grazing event (a multiplier near 0) is decided by its dt.
// Usage: bench_contact_convergence SCENE.yaml HORIZON INTEGRATOR [INTEGRATOR ...]
//        (docs/accuracy.md: surface_chain_contact, 1 s, semi_implicit_euler: about 2 minutes)
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace constrained_particles;

namespace
{
// the positions at `horizon` [s] (3 x n), or NaN where a step failed its checks
Points positionsAt(const BuiltScene& built, const std::string& integrator, double dt,
                   double horizon)
{
  StepSettings settings;
  settings.dt = dt;
  settings.integrator = integrator;
  Simulator sim(built.scene, built.initial_state, settings);
  const long steps = std::lround(horizon / dt);
  for (long k = 0; k < steps; ++k)
    if (sim.step().failed_check != StepCheck::None)
    {
      std::printf("%s at dt %.0e: a step failed its checks at t = %g s\n", integrator.c_str(), dt,
                  sim.state().time);
      return Points::Constant(3, sim.model().numParticles(), NAN);
    }
  return sim.state().positions;
}
}  // namespace

int main(int argc, char** argv)
{
  if (argc < 4)
  {
    std::fprintf(stderr, "usage: %s SCENE.yaml HORIZON INTEGRATOR [INTEGRATOR ...]\n", argv[0]);
    return 2;
  }
  try
  {
    const BuiltScene built = buildScene(loadSceneFile(argv[1]));
    const double horizon = std::atof(argv[2]);
    if (!(horizon > 0.0 && horizon <= 100.0))
    {
      std::fprintf(stderr, "HORIZON = %s: must be in (0, 100] s\n", argv[2]);
      return 2;
    }
    const Points reference = positionsAt(built, "rk4", 1e-6, horizon);
    std::printf("%s, %g s: largest distance from rk4 + projection at dt 1e-6 s [m]\n", argv[1],
                horizon);
    for (int a = 3; a < argc; ++a)
      for (const double dt : { 1e-4, 1e-5, 2e-6 })
        std::printf(
            "%-22s dt %.0e s  %.2e\n", argv[a], dt,
            (positionsAt(built, argv[a], dt, horizon) - reference).colwise().norm().maxCoeff());
  }
  catch (const InvalidInput& e)
  {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  return 0;
}
