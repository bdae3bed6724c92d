// Classical fourth-order Runge-Kutta on (p, v): four evaluations per step. Fourth order.
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
  const double dt = settings.dt, t = x.time;
  Points& p = x.positions;
  Points& v = x.velocities;
  // k1 = (v, a1) at t; k2 = (v2, a2) and k3 = (v3, a3) at t + dt/2; k4 = (v4, a4) at t + dt
  forward(model, data, settings, t, p, v, s.a1);
  s.v2 = v + 0.5 * dt * s.a1;
  s.p_stage = p + 0.5 * dt * v;
  forward(model, data, settings, t + 0.5 * dt, s.p_stage, s.v2, s.a2);
  s.v3 = v + 0.5 * dt * s.a2;
  s.p_stage = p + 0.5 * dt * s.v2;
  forward(model, data, settings, t + 0.5 * dt, s.p_stage, s.v3, s.a3);
  s.v4 = v + dt * s.a3;
  s.p_stage = p + dt * s.v3;
  forward(model, data, settings, t + dt, s.p_stage, s.v4, s.a4);
  p += (dt / 6.0) * (v + 2.0 * s.v2 + 2.0 * s.v3 + s.v4);
  v += (dt / 6.0) * (s.a1 + 2.0 * s.a2 + 2.0 * s.a3 + s.a4);
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo RK4_INTEGRATOR = { "rk4", 4,     false,
                                               false, 2.828, "classical Runge-Kutta, fourth order",
                                               &step };

}  // namespace constrained_particles
