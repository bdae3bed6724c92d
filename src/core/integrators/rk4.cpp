// Classical fourth-order Runge-Kutta on (p, v): four evaluations per step. Fourth order.
#include "../stages.hpp"

#include "constrained_particles/core/integrators.hpp"

namespace constrained_particles
{
namespace
{
// RK4 with running sums of the slopes, as the minimum-work kernel (bench/minimum_kernel.hpp)
// keeps them: each stage's (p, v) is updated in place into the next stage's, so a step streams
// the state, one stage's (p, v, a) and the two sums: 168 bytes a particle where v2, v3, v4 and a1
// to a4 took 240 (7.2 MB less at 10^5 particles). The sums are the textbook form's
// p += h/6 (v1 + 2 v2 + 2 v3 + v4), term for term and left to right, so the motion is the same
// bit for bit (2 x is exact, so even FMA contraction could not part them). Each sweep is a
// function of __restrict parameters (no buffer is read through another pointer), which GCC
// honours on parameters and uses to vectorise.

// After stage 1 (at the state; its accelerations a1 written into sum_v): p_stage = p + c v,
// v_stage = v + c a1.
void afterFirst(Eigen::Index size, double c, const double* __restrict p, const double* __restrict v,
                const double* __restrict a1, double* __restrict p_stage, double* __restrict v_stage)
{
  for (Eigen::Index k = 0; k < size; ++k)
  {
    p_stage[k] = p[k] + c * v[k];
    v_stage[k] = v[k] + c * a1[k];
  }
}

// After stage 2 or 3 (at p_stage, v_stage; accelerations a): the sums take 2 v_stage and 2 a
// (stage 2 starts sum_p at v: `first`), then p_stage = p + c v_stage, v_stage = v + c a.
void afterMiddle(Eigen::Index size, double c, bool first, const double* __restrict p,
                 const double* __restrict v, const double* __restrict a, double* __restrict p_stage,
                 double* __restrict v_stage, double* __restrict sum_p, double* __restrict sum_v)
{
  for (Eigen::Index k = 0; k < size; ++k)
  {
    const double u = v_stage[k];  // the stage's velocity, read before it becomes the next's
    sum_p[k] = (first ? v[k] : sum_p[k]) + 2.0 * u;
    sum_v[k] += 2.0 * a[k];
    p_stage[k] = p[k] + c * u;
    v_stage[k] = v[k] + c * a[k];
  }
}

// After stage 4: p += h/6 (sum_p + v4), v += h/6 (sum_v + a4).
void afterLast(Eigen::Index size, double sixth, double* __restrict p, double* __restrict v,
               const double* __restrict v4, const double* __restrict a4,
               const double* __restrict sum_p, const double* __restrict sum_v)
{
  for (Eigen::Index k = 0; k < size; ++k)
  {
    p[k] += sixth * (sum_p[k] + v4[k]);
    v[k] += sixth * (sum_v[k] + a4[k]);
  }
}

void step(const Model& model, Data& data, const StepSettings& settings)
{
  State& x = data.state;
  StageBuffers& s = data.stages;
  const double dt = settings.dt, t = x.time;
  double* p = x.positions.data();
  double* v = x.velocities.data();
  const Eigen::Index size = x.positions.size();
  // k1 at (p, v, t); k2 and k3 at t + dt/2; k4 at t + dt, each at the (p_stage, v_stage) the
  // stage before left
  forward(model, data, settings, t, x.positions, x.velocities, s.sum_v);
  afterFirst(size, 0.5 * dt, p, v, s.sum_v.data(), s.p_stage.data(), s.v_stage.data());
  forward(model, data, settings, t + 0.5 * dt, s.p_stage, s.v_stage, s.a_stage);
  afterMiddle(size, 0.5 * dt, true, p, v, s.a_stage.data(), s.p_stage.data(), s.v_stage.data(),
              s.sum_p.data(), s.sum_v.data());
  forward(model, data, settings, t + 0.5 * dt, s.p_stage, s.v_stage, s.a_stage);
  afterMiddle(size, dt, false, p, v, s.a_stage.data(), s.p_stage.data(), s.v_stage.data(),
              s.sum_p.data(), s.sum_v.data());
  forward(model, data, settings, t + dt, s.p_stage, s.v_stage, s.a_stage);
  afterLast(size, dt / 6.0, p, v, s.v_stage.data(), s.a_stage.data(), s.sum_p.data(),
            s.sum_v.data());
  ++data.statistics.internal_steps;
}

}  // namespace

extern const IntegratorInfo RK4_INTEGRATOR = { "rk4", 4,     false,
                                               false, 2.828, "classical Runge-Kutta, fourth order",
                                               &step };

}  // namespace constrained_particles
