// Semi-implicit (symplectic) Euler: v += dt a(p, v), then p += dt v with the new velocity.
// First order; symplectic for conservative forces without constraints. Under `projection` the
// drift is followed by SHAKE along the step's start Jacobian, its displacement fed back into
// the velocity (v = (p_n+1 - p_n) / dt), and the step's velocity projection (attemptStep) then
// completes RATTLE: the constrained symplectic Euler of Hairer, Lubich and Wanner (Geometric
// Numerical Integration, VII.1). Projecting p_n+1 along its own Jacobian instead, with v left as
// it was, turns the centripetal part of dt a (normal to the links at p_n) partly tangential at
// p_n+1: speed gains a factor 1 + dt^2 omega^2 / 2 a step, and energy grows without bound
// (docs/physics.md, "What each method conserves").
#include "../stabilization.hpp"
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
  Points& a = s.a_stage;
  forward(model, data, settings, x.time, x.positions, x.velocities, a);
  x.velocities += settings.dt * a;
  if (settings.stabilization != Stabilization::Projection || model.numRows() == 0)
  {
    x.positions += settings.dt * x.velocities;
    ++data.statistics.internal_steps;
    return;
  }
  s.p_start = x.positions;
  x.positions += settings.dt * x.velocities;
  // as velocity Verlet: the correction summed from its own small terms, not p_n+1 - p_n
  s.correction.setZero();
  const ProjectionReport report = shakePositions(model, data, x.time + settings.dt, s.p_start,
                                                 x.positions, settings.projection_tolerance,
                                                 settings.projection_max_iterations, &s.correction);
  x.velocities += s.correction / settings.dt;
  data.statistics.projection.merge(report);
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo SEMI_IMPLICIT_EULER_INTEGRATOR = {
  "semi_implicit_euler",
  1,
  false,
  false,
  2.0,
  "first order, symplectic (SHAKE/RATTLE under projection)",
  &step
};

}  // namespace constrained_particles
