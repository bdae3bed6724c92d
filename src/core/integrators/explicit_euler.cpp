// Explicit (forward) Euler: p += dt v, v += dt a(p, v). First order; energy grows.
#include "../stages.hpp"

#include "constrained_particles/core/integrators.hpp"

namespace constrained_particles
{
namespace
{
void step(const Model& model, Data& data, const StepSettings& settings)
{
  State& x = data.state;
  Points& a = data.stages.a_stage;
  forward(model, data, settings, x.time, x.positions, x.velocities, a);
  x.positions += settings.dt * x.velocities;
  x.velocities += settings.dt * a;
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo EXPLICIT_EULER_INTEGRATOR = {
  "explicit_euler", 1, false, false, 0.1, "first order, energy grows", &step
};

}  // namespace constrained_particles
