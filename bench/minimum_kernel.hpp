// The yardstick for a chain step (issue 17): the least work one RK4 + projection step of the
// pinned chain needs, written plainly for this one structure. Not a path of the engine: the
// benchmark (bench/kernel_ratio.cpp) reports the engine's step cost over this kernel's, and
// test/core/test_minimum_kernel.cpp checks both follow the same trajectory.
//
// The physics is the engine's (src/core/stages.hpp, Witkin's formulation) for n particles of
// mass m, particle 0 pinned (inverse mass 0, at rest), particle k joined to k + 1 by row k,
//   C_k = (|d_k|^2 - l^2) / 2,  d_k = p_k - p_{k+1},  J_k = (d_k at k, -d_k at k + 1),
//   (J W J^T) lambda = -(Jdot v + J a0),  a = a0 + W J^T lambda,  a0 = g (0 on the pin),
// with J W J^T tridiagonal: diagonal (w_k + w_{k+1}) |d_k|^2, off-diagonal -w_k d_{k-1}.d_k.
// Per stage two sweeps: up the chain, rows, assembly, LDL^T and forward substitution in one;
// down the chain, back substitution, accelerations and the integrator's stage combination in
// one. Projection (the engine's stopping rule: Newton on C until every |(|d_k| - l)| <= the
// tolerance, or the iteration limit) reuses its last check's factorisation, taken at the final
// positions, for the velocity projection dv = -W J^T (J W J^T)^-1 J v, and the next step's first
// stage, at those positions, reuses it too (only its right-hand side is new).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace bench
{
class MinimumChainKernel
{
public:
  /// n >= 2 particles of `mass` [kg], links of `link_length` [m], gravity (0, 0, gravity_z)
  /// [m/s^2], step dt [s], projection `tolerance` [m] and at most `max_iterations` Newton steps.
  MinimumChainKernel(int n, double link_length, double mass, double gravity_z, double dt,
                     double tolerance, int max_iterations)
    : n_(n)
    , m_(n - 1)
    , length_squared_(link_length * link_length)
    , length_(link_length)
    , w_(1.0 / mass)
    , g_(gravity_z)
    , dt_(dt)
    , tolerance_(tolerance)
    , max_iterations_(max_iterations)
    , p_(3 * n)
    , v_(3 * n)
    , p_stage_(3 * n)
    , v_stage_(3 * n)
    , sum_p_(3 * n)
    , sum_v_(3 * n)
    , rows_(m_)
  {
  }

  /// Positions and velocities, 3 n values each (x, y, z per particle); particle 0 stays where
  /// it is given, at rest.
  void setState(const double* positions, const double* velocities)
  {
    std::copy(positions, positions + 3 * n_, p_.begin());
    std::copy(velocities, velocities + 3 * n_, v_.begin());
    v_[0] = v_[1] = v_[2] = 0.0;
    factorised_ = false;  // rows_ are not of these positions
  }

  const std::vector<double>& positions() const
  {
    return p_;
  }
  const std::vector<double>& velocities() const
  {
    return v_;
  }

  /// One RK4 step of dt, then the projection of positions and velocities.
  void step()
  {
    const double h = dt_;
    // stage 1 at (p, v): v2 = v + h/2 a1, p2 = p + h/2 v; the sums start at (v, a1); J and its
    // LDL^T are the last projection's, at these positions
    const bool reuse = factorised_;
    factorised_ = false;
    stage(p_.data(), v_.data(), reuse,
          [&](int c, double a)
          {
            sum_p_[c] = v_[c];
            sum_v_[c] = a;
            p_stage_[c] = p_[c] + 0.5 * h * v_[c];
            v_stage_[c] = v_[c] + 0.5 * h * a;
          });
    // stage 2 at (p2, v2): v3 = v + h/2 a2, p3 = p + h/2 v2 (v2 read before it is overwritten)
    stage(p_stage_.data(), v_stage_.data(), false,
          [&](int c, double a)
          {
            sum_p_[c] += 2.0 * v_stage_[c];
            sum_v_[c] += 2.0 * a;
            p_stage_[c] = p_[c] + 0.5 * h * v_stage_[c];
            v_stage_[c] = v_[c] + 0.5 * h * a;
          });
    // stage 3 at (p3, v3): v4 = v + h a3, p4 = p + h v3
    stage(p_stage_.data(), v_stage_.data(), false,
          [&](int c, double a)
          {
            sum_p_[c] += 2.0 * v_stage_[c];
            sum_v_[c] += 2.0 * a;
            p_stage_[c] = p_[c] + h * v_stage_[c];
            v_stage_[c] = v_[c] + h * a;
          });
    // stage 4 at (p4, v4): the step, p += h/6 (v + 2 v2 + 2 v3 + v4), v += h/6 (a1 + ... + a4)
    stage(p_stage_.data(), v_stage_.data(), false,
          [&](int c, double a)
          {
            p_[c] += (h / 6.0) * (sum_p_[c] + v_stage_[c]);
            v_[c] += (h / 6.0) * (sum_v_[c] + a);
          });
    project();
  }

  /// max_k |(|d_k| - l)| [m] at the current positions.
  double maxLinkError() const
  {
    double worst = 0.0;
    for (int k = 0; k < m_; ++k)
    {
      const double* a = &p_[3 * k];
      const double dx = a[0] - a[3], dy = a[1] - a[4], dz = a[2] - a[5];
      worst = std::max(worst, std::abs(std::sqrt(dx * dx + dy * dy + dz * dz) - length_));
    }
    return worst;
  }

private:
  struct Row
  {
    double d[3];           // d_k = p_k - p_{k+1}
    double lower;          // L_{k+1,k}
    double inverse_pivot;  // 1 / D_k
    double y, z;           // forward-substituted right-hand sides (a second for projection)
  };

  double inverseMass(int i) const
  {
    return i == 0 ? 0.0 : w_;
  }

  /// Accelerations at (p, v): emit(component index 3 i + c, a) for every particle, last first.
  /// `reuse`: rows_ hold d and the LDL^T at p (the last projection's): the right-hand side only.
  template <typename Emit>
  void stage(const double* p, const double* v, bool reuse, Emit&& emit)
  {
    // up: rows, assembly, LDL^T and forward substitution of -(Jdot v + J a0)
    double previous_d[3] = { 0.0, 0.0, 0.0 }, previous_lower_y = 0.0;
    for (int k = 0; k < m_ && reuse; ++k)
    {
      Row& row = rows_[k];
      const double* u = v + 3 * k;
      const double ux = u[0] - u[3], uy = u[1] - u[4], uz = u[2] - u[5];
      double rhs = -(ux * ux + uy * uy + uz * uz + (k == 0 ? -row.d[2] * g_ : 0.0));
      if (k > 0)
        rhs -= rows_[k - 1].lower * previous_lower_y;
      row.y = previous_lower_y = rhs;
    }
    for (int k = 0; k < m_ && !reuse; ++k)
    {
      Row& row = rows_[k];
      const double* a = p + 3 * k;
      const double* u = v + 3 * k;
      row.d[0] = a[0] - a[3];
      row.d[1] = a[1] - a[4];
      row.d[2] = a[2] - a[5];
      const double ux = u[0] - u[3], uy = u[1] - u[4], uz = u[2] - u[5];
      const double squared = row.d[0] * row.d[0] + row.d[1] * row.d[1] + row.d[2] * row.d[2];
      const double wk = inverseMass(k);
      // J a0 = d.(a0_k - a0_{k+1}): gravity cancels except across the pin
      const double ja0 = k == 0 ? -row.d[2] * g_ : 0.0;
      double pivot = (wk + w_) * squared;
      double rhs = -(ux * ux + uy * uy + uz * uz + ja0);
      if (k > 0)
      {
        const double off =
            -wk * (previous_d[0] * row.d[0] + previous_d[1] * row.d[1] + previous_d[2] * row.d[2]);
        Row& above = rows_[k - 1];
        above.lower = off * above.inverse_pivot;
        pivot -= above.lower * off;
        rhs -= above.lower * previous_lower_y;
      }
      row.inverse_pivot = 1.0 / pivot;
      row.y = rhs;
      previous_lower_y = rhs;
      previous_d[0] = row.d[0];
      previous_d[1] = row.d[1];
      previous_d[2] = row.d[2];
    }
    // down: lambda, a = a0 + W J^T lambda, (J^T lambda)_i = lambda_i d_i - lambda_{i-1} d_{i-1}
    double lambda_below = 0.0;
    const double* d_below = nullptr;
    for (int k = m_ - 1; k >= 0; --k)
    {
      const Row& row = rows_[k];
      const double lambda =
          row.y * row.inverse_pivot - (k + 1 < m_ ? row.lower * lambda_below : 0.0);
      const int i = k + 1;  // the particle below row k
      for (int c = 0; c < 3; ++c)
      {
        const double below = d_below ? lambda_below * d_below[c] : 0.0;
        const double a0 = c == 2 ? g_ : 0.0;
        emit(3 * i + c, a0 + w_ * (below - lambda * row.d[c]));
      }
      lambda_below = lambda;
      d_below = row.d;
    }
    for (int c = 0; c < 3; ++c)
      emit(c, 0.0);  // the pin
  }

  /// Newton on the positions, then the velocities with the final check's factorisation.
  void project()
  {
    for (int iteration = 0;; ++iteration)
    {
      // up: rows at p, LDL^T, forward substitution of C (y) and of J v (z)
      double worst = 0.0, previous_d[3] = { 0.0, 0.0, 0.0 }, previous_y = 0.0, previous_z = 0.0;
      for (int k = 0; k < m_; ++k)
      {
        Row& row = rows_[k];
        const double* a = &p_[3 * k];
        const double* u = &v_[3 * k];
        row.d[0] = a[0] - a[3];
        row.d[1] = a[1] - a[4];
        row.d[2] = a[2] - a[5];
        const double squared = row.d[0] * row.d[0] + row.d[1] * row.d[1] + row.d[2] * row.d[2];
        worst = std::max(worst, std::abs(std::sqrt(squared) - length_));
        const double wk = inverseMass(k);
        double pivot = (wk + w_) * squared;
        double y = 0.5 * (squared - length_squared_);
        double z = row.d[0] * (u[0] - u[3]) + row.d[1] * (u[1] - u[4]) + row.d[2] * (u[2] - u[5]);
        if (k > 0)
        {
          const double off = -wk * (previous_d[0] * row.d[0] + previous_d[1] * row.d[1] +
                                    previous_d[2] * row.d[2]);
          Row& above = rows_[k - 1];
          above.lower = off * above.inverse_pivot;
          pivot -= above.lower * off;
          y -= above.lower * previous_y;
          z -= above.lower * previous_z;
        }
        row.inverse_pivot = 1.0 / pivot;
        row.y = previous_y = y;
        row.z = previous_z = z;
        previous_d[0] = row.d[0];
        previous_d[1] = row.d[1];
        previous_d[2] = row.d[2];
      }
      const bool done =
          worst <= tolerance_ || iteration >= max_iterations_ || !std::isfinite(worst);
      // down: x -= W J^T (J W J^T)^-1 r, r = C (positions) or J v (velocities, when done)
      std::vector<double>& x = done ? v_ : p_;
      double mu_below = 0.0;
      const double* d_below = nullptr;
      for (int k = m_ - 1; k >= 0; --k)
      {
        const Row& row = rows_[k];
        const double r = done ? row.z : row.y;
        const double mu = r * row.inverse_pivot - (k + 1 < m_ ? row.lower * mu_below : 0.0);
        double* xi = &x[3 * (k + 1)];
        for (int c = 0; c < 3; ++c)
          xi[c] -= w_ * ((d_below ? mu_below * d_below[c] : 0.0) - mu * row.d[c]);
        mu_below = mu;
        d_below = row.d;
      }
      if (done)
      {
        factorised_ = true;  // of the final positions: the next step's first stage takes it
        return;
      }
    }
  }

  int n_, m_;
  double length_squared_, length_, w_, g_, dt_, tolerance_;
  int max_iterations_;
  std::vector<double> p_, v_, p_stage_, v_stage_, sum_p_, sum_v_;
  std::vector<Row> rows_;
  bool factorised_ = false;  // rows_ hold d and the LDL^T at p_ (set by project())
};

}  // namespace bench
