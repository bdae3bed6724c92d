// Classical fourth-order Runge-Kutta on (p, v): four evaluations per step. Fourth order.
#include "../stages.hpp"

#include "constrained_particles/core/integrators.hpp"

namespace constrained_particles
{
namespace
{
// The next stage's velocities v_k = v + c a and positions p + c u (u the last stage's
// velocities) in one sweep instead of two Eigen expressions: the same sums (c is a scalar
// formed first, as `0.5 * dt * a` forms it), each of v read once. At 10^5 particles a sweep
// moves 7 MB. No buffer written is read through another pointer (`u` is `v` in the first stage:
// both only read), so __restrict holds and lets the compiler vectorise as Eigen did. Identical to
// Eigen's sums only without FMA contraction (no -march flag in this build).
void nextStage(Eigen::Index size, double c, const double* __restrict p, const double* __restrict v,
               const double* __restrict u, const double* __restrict a, double* __restrict v_next,
               double* __restrict p_next)
{
  for (Eigen::Index k = 0; k < size; ++k)
  {
    v_next[k] = v[k] + c * a[k];
    p_next[k] = p[k] + c * u[k];
  }
}

// p += h/6 (v + 2 v2 + 2 v3 + v4), v += h/6 (a1 + 2 a2 + 2 a3 + a4) in one sweep, summed as
// Eigen's expressions sum (left to right); p first, from the velocities before the update.
void combine(Eigen::Index size, double sixth, double* __restrict p, double* __restrict v,
             const double* __restrict v2, const double* __restrict v3, const double* __restrict v4,
             const double* __restrict a1, const double* __restrict a2, const double* __restrict a3,
             const double* __restrict a4)
{
  for (Eigen::Index k = 0; k < size; ++k)
  {
    p[k] += sixth * (v[k] + 2.0 * v2[k] + 2.0 * v3[k] + v4[k]);
    v[k] += sixth * (a1[k] + 2.0 * a2[k] + 2.0 * a3[k] + a4[k]);
  }
}

void step(const Model& model, Data& data, const StepSettings& settings)
{
  State& x = data.state;
  StageBuffers& s = data.stages;
  const double dt = settings.dt, t = x.time;
  Points& p = x.positions;
  Points& v = x.velocities;
  const Eigen::Index size = p.size();
  // k1 = (v, a1) at t; k2 = (v2, a2) and k3 = (v3, a3) at t + dt/2; k4 = (v4, a4) at t + dt
  forward(model, data, settings, t, p, v, s.a1);
  nextStage(size, 0.5 * dt, p.data(), v.data(), v.data(), s.a1.data(), s.v2.data(),
            s.p_stage.data());
  forward(model, data, settings, t + 0.5 * dt, s.p_stage, s.v2, s.a2);
  nextStage(size, 0.5 * dt, p.data(), v.data(), s.v2.data(), s.a2.data(), s.v3.data(),
            s.p_stage.data());
  forward(model, data, settings, t + 0.5 * dt, s.p_stage, s.v3, s.a3);
  nextStage(size, dt, p.data(), v.data(), s.v3.data(), s.a3.data(), s.v4.data(), s.p_stage.data());
  forward(model, data, settings, t + dt, s.p_stage, s.v4, s.a4);
  combine(size, dt / 6.0, p.data(), v.data(), s.v2.data(), s.v3.data(), s.v4.data(), s.a1.data(),
          s.a2.data(), s.a3.data(), s.a4.data());
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo RK4_INTEGRATOR = { "rk4", 4,     false,
                                               false, 2.828, "classical Runge-Kutta, fourth order",
                                               &step };

}  // namespace constrained_particles
