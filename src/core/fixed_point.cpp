#include "fixed_point.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <limits>

namespace constrained_particles
{
namespace
{
using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, MAX_ANDERSON_DEPTH,
                            MAX_ANDERSON_DEPTH>;
using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, MAX_ANDERSON_DEPTH, 1>;
// Tikhonov's weight on gamma, a fraction of the normal matrix's trace plus the residual's square:
// it bounds the mixing's gain where a fit's columns are all but parallel, or all but 0 (1e-6 held
// test_shapes' capstan rope at rest where 1e-10 let its friction stop short)
constexpr double REGULARISATION = 1e-6;
}  // namespace

void resizeHistory(FixedPointHistory& history, int dimension, int depth)
{
  depth = std::clamp(depth, 1, MAX_ANDERSON_DEPTH);
  history.last_x.setZero(dimension);
  history.last_r.setZero(dimension);
  history.dx.setZero(dimension, depth);
  history.dr.setZero(dimension, depth);
  clearHistory(history);
}

void andersonStep(FixedPointHistory& history, const Eigen::VectorXd& x, const Eigen::VectorXd& g,
                  Eigen::VectorXd& next)
{
  eigen_assert(&next != &x && &next != &g);
  const int depth = static_cast<int>(history.dx.cols());
  next = g - x;  // the residual r, held in next until the fit (then next is written from g)
  if (history.has_last)
  {
    history.dx.col(history.head) = x - history.last_x;
    history.dr.col(history.head) = next - history.last_r;
    history.head = (history.head + 1) % depth;
    history.count = std::min(history.count + 1, depth);
  }
  history.last_x = x;
  history.last_r = next;
  history.has_last = true;
  if (history.count == 0)
  {
    next = g;
    return;
  }
  const int m = history.count;
  Small normal(m, m);
  SmallVector fit(m);
  const auto dr = history.dr.leftCols(m);
  normal.noalias() = dr.transpose() * dr;
  fit.noalias() = dr.transpose() * history.last_r;
  // Tikhonov's term keeps nearly parallel differences from blowing gamma up (and rounding in
  // them from steering it)
  normal.diagonal().array() += REGULARISATION * (normal.trace() + history.last_r.squaredNorm()) +
                               std::numeric_limits<double>::min();
  const SmallVector gamma = normal.ldlt().solve(fit);
  if (!gamma.allFinite())
  {
    clearHistory(history);
    next = g;
    return;
  }
  next = g;
  next.noalias() -= history.dx.leftCols(m) * gamma;
  next.noalias() -= dr * gamma;
}

}  // namespace constrained_particles
