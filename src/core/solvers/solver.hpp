/// @file solver.hpp
/// @brief The interface every solve of (J W J^T) x = b implements, one strategy per file:
/// single_row.cpp, tridiagonal.cpp, tree.cpp (and tree_rows.cpp), sparse.cpp, dense.cpp. Each
/// assembles J W J^T (or what it needs of it) from the rows' Jacobian blocks and factorises it; the
/// regularise-and-retry loop is written once, in factorize(). Private to the core.
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/statistics.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <memory>

namespace constrained_particles
{
/// Rows from which the sparse solve's pattern is of the acting rows only (sparse.cpp).
constexpr int SPARSE_ACTIVE_PATTERN_ROWS = 1024;

/// Factorisation of J W J^T for one model. Allocates when made; the single-row, tridiagonal and
/// tree solves allocate nothing after that, but for a tree's steps handed to its sparse fallback
/// (two particles of one tree with rows of their own, one locked along its parent link), which
/// allocate as the sparse solve does inside Eigen's factorisation.
class ConstraintSolver
{
public:
  virtual ~ConstraintSolver() = default;

  /// Assembles J W J^T from the evaluated rows and factorises it. A (near) singular matrix, a
  /// pivot below SINGULAR_PIVOT_RATIO of its diagonal entry, is factorised again as
  /// J W J^T + delta I, delta = SINGULAR_REGULARIZATION max(diag) (1 if the diagonal is zero),
  /// so the solution stays finite; the report keeps the unregularised pivot ratio.
  virtual SolveReport factorize(const Model& model, const RowData& rows, EffectCounters& counters);

  /// Solves (J W J^T) x = b in place (m), with the last factorisation.
  virtual void solveInPlace(Eigen::VectorXd& b) const = 0;

  /// True if `pivot` is too small against its diagonal entry `diagonal` (the fused chain
  /// stages apply the same rule).
  static bool isSingularPivot(double pivot, double diagonal)
  {
    return !(diagonal > 0.0) || !(pivot > SINGULAR_PIVOT_RATIO * diagonal);
  }

protected:
  /// Outcome of one attempt.
  struct Pivots
  {
    bool singular;           ///< a pivot at or below SINGULAR_PIVOT_RATIO of its diagonal
    double min_pivot_ratio;  ///< the smallest pivot relative to its diagonal entry
  };

  explicit ConstraintSolver(SolveMethod method) : method_(method)
  {
  }

  /// One LDL^T pivot of J W J^T + delta I against its diagonal entry `d`, in elimination order:
  /// lowers `min_ratio` to pivot / d; false if it is singular and delta = 0 (the attempt stops),
  /// else `pivot` is one to divide by (at least delta when regularised).
  static bool takePivot(double& pivot, double d, double delta, double& min_ratio)
  {
    if (!(d > 0.0))
      min_ratio = 0.0;
    else if (pivot < min_ratio * d)  // tracks min(pivot / d) without dividing every row
      min_ratio = pivot / d;
    if (!isSingularPivot(pivot, d))
      return true;
    if (delta == 0.0)
      return false;
    // regularised: exact pivots are >= delta; only rounding can push one below
    pivot = std::max(pivot, delta);
    return true;
  }

  /// Takes what the factorisation needs from the rows (it may read them until the next call).
  virtual void assemble(const Model& model, const RowData& rows) = 0;
  /// The largest diagonal entry of J W J^T last assembled (asked only when it is singular).
  virtual double maxDiagonal() const = 0;
  /// Factorises J W J^T + delta I. With delta = 0 it may stop at the first singular pivot; with
  /// delta > 0 it must leave a usable factorisation.
  virtual Pivots factorizeShifted(double delta) = 0;

private:
  SolveMethod method_;  ///< the method this strategy implements
};

/// b = F^-1 b with an Eigen factorisation F (sparse, dense); a failed factorisation gives no
/// force (b = 0) rather than NaN.
template <typename Factorization>
void solveWith(const Factorization& factorization, Eigen::VectorXd& b)
{
  if (factorization.info() == Eigen::Success)
    b = factorization.solve(b);
  else
    b.setZero();
}

/// The largest w_i |J_ri|^2 of any row on any free particle: the tree solves' measure of
/// J W J^T's diagonal for regularising (both alike, so they regularise a singular system alike).
double maxParticleRowWeight(const Model& model, const RowData& rows);

/// The strategy for model.solveMethod() (nullptr for SolveMethod::None).
std::unique_ptr<ConstraintSolver> makeSolver(const Model& model);

std::unique_ptr<ConstraintSolver> makeSingleRowSolver(const Model& model);
std::unique_ptr<ConstraintSolver> makeTridiagonalSolver(const Model& model);
std::unique_ptr<ConstraintSolver> makeTreeSolver(const Model& model);
/// The tree solve in row space (tree_rows.cpp) if Model::solvesTreeByRows(), else nullptr.
std::unique_ptr<ConstraintSolver> makeTreeRowSolver(const Model& model);
std::unique_ptr<ConstraintSolver> makeSparseSolver(const Model& model);
std::unique_ptr<ConstraintSolver> makeDenseSolver(const Model& model);

}  // namespace constrained_particles
