// Velocity Verlet with SHAKE/RATTLE (Andersen 1983): a half kick with the applied forces, a
// drift, SHAKE onto C = 0 (the constraint impulse), a half kick, RATTLE onto J v = 0. Second
// order, symplectic; holds the constraints to projection_tolerance every step itself, so it
// ignores `stabilization`.
#include "../contact.hpp"
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
  const double dt = settings.dt, t_end = x.time + dt;
  Points& p = x.positions;
  Points& v = x.velocities;
  s.p_start = p;
  appliedForceStage(model, data, p, v);
  kickForces(model, data, 0.5 * dt, v);  // the applied forces and the start's friction
  p += dt * v;
  // v_n+1/2 = (p_n+1 - p_n) / dt, formed as v + correction / dt: subtracting positions would
  // turn their round-off into a velocity error that grows like 1 / dt
  s.correction.setZero();
  const ProjectionReport report =
      shakePositions(model, data, t_end, s.p_start, p, settings.projection_tolerance,
                     settings.projection_max_iterations, &s.correction);
  v += s.correction / dt;
  appliedForceStage(model, data, p, v);
  kickForces(model, data, 0.5 * dt, v);  // the applied forces and the start's friction
  finishProjection(model, data, t_end, p, v, false, true, report);
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo VELOCITY_VERLET_INTEGRATOR = {
  "velocity_verlet", 2, true, false, 2.0, "symplectic, SHAKE/RATTLE projections", &step
};

}  // namespace constrained_particles
