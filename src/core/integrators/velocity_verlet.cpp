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
// v += dt/2 W f (eliminated particles: W = 0), f the applied forces and the contacts' friction
// at the step's start (contact.hpp)
void halfKick(const Model& model, Data& data, double dt, Points& velocities)
{
  const auto& w = model.inverseMasses();
  for (int i = 0; i < model.numParticles(); ++i)
    velocities.col(i) += (0.5 * dt * w[i]) * data.applied_forces.col(i);
  kickFriction(model, data, 0.5 * dt, velocities);  // none without contacts
}

void step(const Model& model, Data& data, const StepSettings& settings)
{
  State& x = data.state;
  StageBuffers& s = data.stages;
  const double dt = settings.dt, t_end = x.time + dt;
  Points& p = x.positions;
  Points& v = x.velocities;
  s.p_start = p;
  appliedForceStage(model, data, p, v);
  halfKick(model, data, dt, v);
  p += dt * v;
  // v_n+1/2 = (p_n+1 - p_n) / dt, formed as v + correction / dt: subtracting positions would
  // turn their round-off into a velocity error that grows like 1 / dt
  s.correction.setZero();
  const ProjectionReport report =
      shakePositions(model, data, t_end, s.p_start, p, settings.projection_tolerance,
                     settings.projection_max_iterations, &s.correction);
  v += s.correction / dt;
  appliedForceStage(model, data, p, v);
  halfKick(model, data, dt, v);
  finishProjection(model, data, t_end, p, v, false, true, report);
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo VELOCITY_VERLET_INTEGRATOR = {
  "velocity_verlet", 2, true, false, 2.0, "symplectic, SHAKE/RATTLE projections", &step
};

}  // namespace constrained_particles
