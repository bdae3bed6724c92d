// Dormand-Prince 5(4) (Boost.Odeint's controlled runge_kutta_dopri5: a well-kept adaptive
// stepper; its error control is not ours to rewrite), integrating each dt adaptively with
// absolute and relative tolerance adaptive_tolerance per internal step. The stepper and its
// state live in Data and are reused step after step.
#include "../stages.hpp"
#include "dopri5.hpp"

#include "constrained_particles/core/integrators.hpp"

#include <limits>
#include <vector>

namespace constrained_particles
{
namespace odeint = boost::numeric::odeint;

namespace
{
void step(const Model& model, Data& data, const StepSettings& settings)
{
  std::unique_ptr<Dopri5Workspace>& workspace = data.dopri5();
  if (!workspace || workspace->tolerance != settings.adaptive_tolerance)
    workspace = std::make_unique<Dopri5Workspace>(settings.adaptive_tolerance);
  State& x = data.state;
  StageBuffers& s = data.stages;
  const int n = model.numParticles();
  Dopri5Workspace::OdeState& y = workspace->state;
  y.resize(6 * n);
  Eigen::Map<Points>(y.data(), 3, n) = x.positions;
  Eigen::Map<Points>(y.data() + 3 * n, 3, n) = x.velocities;
  auto system = [&](const Dopri5Workspace::OdeState& in, Dopri5Workspace::OdeState& dydt, double t)
  {
    s.p_stage = Eigen::Map<const Points>(in.data(), 3, n);
    s.v_stage = Eigen::Map<const Points>(in.data() + 3 * n, 3, n);
    forward(model, data, settings, t, s.p_stage, s.v_stage, s.a_stage);
    Eigen::Map<Points>(dydt.data(), 3, n) = s.v_stage;
    Eigen::Map<Points>(dydt.data() + 3 * n, 3, n) = s.a_stage;
  };
  // the state may have been projected since the last step: its stored derivative is stale
  workspace->stepper.reset();
  // as odeint's integrate_adaptive: from dt, clipped to the end of the step
  double t = x.time, h = settings.dt;
  const double end = x.time + settings.dt;
  long attempts = 0;
  while (end - t > std::numeric_limits<double>::epsilon())
  {
    if ((t + h) - end > std::numeric_limits<double>::epsilon())
      h = end - t;
    if (++attempts > DOPRI5_MAX_INTERNAL_STEPS || h < DOPRI5_MIN_INTERNAL_STEP * settings.dt)
    {
      workspace->stepper.stepper().do_step(system, y, t, end - t);
      ++data.statistics.forced_internal_steps;
      break;
    }
    if (workspace->stepper.try_step(system, y, t, h) == odeint::success)
      ++data.statistics.internal_steps;
    else
      ++data.statistics.rejected_internal_steps;
  }
  x.positions = Eigen::Map<const Points>(y.data(), 3, n);
  x.velocities = Eigen::Map<const Points>(y.data() + 3 * n, 3, n);
}

}  // namespace

extern const IntegratorInfo DOPRI5_INTEGRATOR = {
  "dopri5",
  5,
  false,
  true,
  UNBOUNDED_STABILITY,
  "adaptive Dormand-Prince 5(4), error per internal step <= tolerance",
  &step
};

}  // namespace constrained_particles
