// Explicit midpoint (RK2): a full step with the slope at the half step. Second order.
#include "../stages.hpp"

#include "constrained_particles/core/integrators.hpp"

namespace constrained_particles
{
namespace
{
void step(const Model& model, Data& data, const StepSettings& settings)
{
  State& x = data.state;
  StageBuffers& s = data.stages;
  const double dt = settings.dt;
  forward(model, data, settings, x.time, x.positions, x.velocities, s.a_stage);
  s.p_stage = x.positions + 0.5 * dt * x.velocities;
  s.v_stage = x.velocities + 0.5 * dt * s.a_stage;
  forward(model, data, settings, x.time + 0.5 * dt, s.p_stage, s.v_stage, s.a_midpoint);
  x.positions += dt * s.v_stage;
  x.velocities += dt * s.a_midpoint;
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo MIDPOINT_INTEGRATOR = {
  "midpoint", 2, false, false, 0.45, "explicit midpoint (RK2), second order", &step
};

}  // namespace constrained_particles
