// Semi-implicit (symplectic) Euler: v += dt a(p, v), then p += dt v with the new velocity.
// First order; symplectic for conservative forces without constraints.
#include "../stages.hpp"

#include "constrained_particles/core/integrators.hpp"

namespace constrained_particles
{
namespace
{
void step(const Model& model, Data& data, const StepSettings& settings)
{
  State& x = data.state;
  Points& a = data.stages.a1;
  forward(model, data, settings, x.time, x.positions, x.velocities, a);
  x.velocities += settings.dt * a;
  x.positions += settings.dt * x.velocities;
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo SEMI_IMPLICIT_EULER_INTEGRATOR = {
  "semi_implicit_euler", 1, false, false, 2.0, "first order, symplectic", &step
};

}  // namespace constrained_particles
