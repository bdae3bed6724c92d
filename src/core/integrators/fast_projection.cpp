// Fast projection (Goldenthal, Harmon, Fattal, Bercovier, Grinspun 2007, "Efficient Simulation of
// Inextensible Cloth", section 4; XPBD with zero compliance and an exact direct solve is the same
// step): an implicit constrained Euler step. Predict p* = p + dt v + dt^2 W f with the applied
// forces at the start, move p* onto C = 0 by mass-weighted Newton projection (the existing O(n)
// chain and tree solves), set v = (p_new - p) / dt and project v onto J v = 0. The constraint
// forces are implicit, so the step stays bounded at any dt however stiff the links make the
// chain; it is first order and dissipative (energy is lost at O(dt) per unit time). Applied
// forces are explicit: a stiff spring still needs a small dt. Holds the constraints itself.
#include "../contact.hpp"
#include "../stabilization.hpp"
#include "../stages.hpp"

#include "constrained_particles/core/integrators.hpp"

#include <algorithm>

namespace constrained_particles
{
namespace
{
// The projection is this method's solve, not a drift correction: from a straight chain's
// predicted positions Newton converges only linearly (the links' transverse rows are
// degenerate there), so it gets at least this many iterations.
constexpr int MIN_ITERATIONS = 100;

void step(const Model& model, Data& data, const StepSettings& settings)
{
  State& x = data.state;
  StageBuffers& s = data.stages;
  const double dt = settings.dt, t_end = x.time + dt;
  Points& p = x.positions;
  Points& v = x.velocities;
  appliedForceStage(model, data, p, v);
  kickForces(model, data, dt, v);  // friction as it stood at the step's start (contact.hpp)
  p += dt * v;
  s.p_unprojected = p;  // p*
  const ProjectionReport report =
      projectPositions(model, data, t_end, p, settings.projection_tolerance,
                       std::max(settings.projection_max_iterations, MIN_ITERATIONS));
  // v = (p_new - p_n) / dt = v* + (p_new - p*) / dt
  v += (p - s.p_unprojected) / dt;
  finishProjection(model, data, t_end, p, v, true, true, report);
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo FAST_PROJECTION_INTEGRATOR = {
  "fast_projection",
  1,
  true,
  false,
  UNBOUNDED_STABILITY,
  "implicit constrained Euler (fast projection): first order, dissipative, bounded at any dt",
  &step
};

}  // namespace constrained_particles
