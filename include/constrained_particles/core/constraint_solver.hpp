/// @file constraint_solver.hpp
/// @brief Assembles and solves (J W J^T) x = b from evaluated constraint rows.
///
/// A single row is solved in closed form; tridiagonal systems (chains, a chain hanging from a
/// surface bead) are factorised in O(n) by LDL^T; systems whose particle-row graph is a forest
/// (branched chains, stars) in O(n) by block elimination of that graph; any other structure by a
/// sparse LDL^T whose ordering is analysed once per model.
/// A (near) singular matrix is detected from its pivots, reported, and solved regularised
/// (J W J^T + delta I), so the result stays finite.
#pragma once

#include "constrained_particles/core/model.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace constrained_particles
{
/// Evaluates the model's constraint row `r` at (p, v) into `row`. Stateless.
void evaluateModelRow(const Model& model, int r, const Points& positions, const Points& velocities,
                      ConstraintRow& row);

/// Largest metric position error of the rows [m] (infinite if any is NaN).
double maxPositionError(const std::vector<ConstraintRow>& rows);

/// Evaluates every constraint row of the model at (p, v). Stateless; rows is resized.
void evaluateRows(const Model& model, const Points& positions, const Points& velocities,
                  std::vector<ConstraintRow>& rows);

/// Outcome of one factorisation.
struct SolveReport
{
  SolveMethod method = SolveMethod::None;
  bool singular = false;         ///< (near) singular: solved with regularization added
  double min_pivot_ratio = 1.0;  ///< smallest pivot relative to its diagonal entry
  double regularization = 0.0;   ///< delta added to the diagonal (0 unless singular)
};

/// Pivots below this fraction of their diagonal entry mark J W J^T as singular.
constexpr double SINGULAR_PIVOT_RATIO = 1e-12;
/// Regularization added when singular, relative to the largest diagonal entry.
constexpr double SINGULAR_REGULARIZATION = 1e-9;

/// How often each effect and each solve was evaluated: proof that a scene pays only for what it
/// lists. Counted where the work is dispatched, not derived from the scene.
struct EffectCounters
{
  std::array<std::uint64_t, NUM_FORCE_KINDS> forces{};  ///< force records accumulated, by kind
  /// constraint records evaluated, by kind: rows for row kinds, pin applications for pins
  std::array<std::uint64_t, NUM_CONSTRAINT_KINDS> constraints{};
  std::array<std::uint64_t, NUM_SOLVE_METHODS> factorizations{};  ///< by SolveMethod

  /// Evaluations of the force kind `Kind` (e.g. QuadraticDragForce).
  template <typename Kind>
  std::uint64_t forceCount() const
  {
    return forces[Force(Kind{}).index()];
  }
  /// Evaluations of the constraint kind `Kind` (e.g. SurfaceConstraint).
  template <typename Kind>
  std::uint64_t constraintCount() const
  {
    return constraints[Constraint(Kind{}).index()];
  }
  /// Factorizations by `method`.
  std::uint64_t factorizationCount(SolveMethod method) const
  {
    return factorizations[static_cast<int>(method)];
  }
};

/// Workspace for one model: the evaluated rows and the factorisation of J W J^T.
/// Allocates in the constructor; evaluate/factorize/solve of a chain allocate nothing.
class ConstraintSolver
{
public:
  explicit ConstraintSolver(const Model& model);
  ~ConstraintSolver();
  ConstraintSolver(ConstraintSolver&&) noexcept;
  ConstraintSolver& operator=(ConstraintSolver&&) noexcept;

  const Model& model() const
  {
    return *model_;
  }

  /// Evaluates C, J and Jdot v of every row at positions [m] and velocities [m/s].
  void evaluate(const Points& positions, const Points& velocities);
  const std::vector<ConstraintRow>& rows() const
  {
    return rows_;
  }
  /// C of every evaluated row, compact (the rows hold the same values).
  const Eigen::VectorXd& values() const
  {
    return values_;
  }
  /// Jdot v of every evaluated row, compact.
  const Eigen::VectorXd& jdotV() const
  {
    return jdot_v_;
  }
  /// Largest metric position error of the evaluated rows [m] (infinite if any is NaN).
  double maxPositionError() const
  {
    return max_position_error_;
  }

  /// Assembles J W J^T from the evaluated rows and factorises it.
  SolveReport factorize();
  /// Solves (J W J^T) x = b in place, with the last factorisation.
  void solveInPlace(Eigen::VectorXd& b) const;

  /// y = (J W J^T) x, straight from the rows (for residuals).
  void multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const;
  /// y = J x, x one 3-vector per particle.
  void multiplyJacobian(const Points& x, Eigen::VectorXd& y) const;
  /// y = J W x, x one 3-vector per particle (pinned particles contribute nothing).
  void multiplyJacobianInverseMass(const Points& x, Eigen::VectorXd& y) const;
  /// out += J^T lambda, on free and pinned particles alike.
  void addJacobianTranspose(const Eigen::VectorXd& lambda, Points& out) const;
  /// out += scale W J^T lambda (zero on pinned particles).
  void addInverseMassJacobianTranspose(const Eigen::VectorXd& lambda, double scale,
                                       Points& out) const;
  /// J W J^T as a dense matrix (tests and small systems only).
  Eigen::MatrixXd denseMatrix() const;

  /// Evaluation counters of this workspace (rows and factorizations; Dynamics adds forces).
  EffectCounters& counters()
  {
    return counters_;
  }
  const EffectCounters& counters() const
  {
    return counters_;
  }

private:
  /// Adds row r's entries of J W J^T (diagonal, and the coupling to row r - 1).
  void assembleTridiagonalRow(int r, std::size_t& next_coupling);
  SolveReport factorizeTridiagonal();
  SolveReport factorizeSparse();
  SolveReport factorizeDense();
  void buildTree();
  SolveReport factorizeTree();
  void solveTree(Eigen::VectorXd& b) const;

  const Model* model_;
  std::vector<ConstraintRow> rows_;
  Eigen::VectorXd values_, jdot_v_;
  double max_position_error_ = 0.0;
  // tridiagonal: diagonal, super-diagonal, and LDL^T factors (inverse pivots)
  Eigen::VectorXd diagonal_, off_diagonal_, inverse_pivots_, lower_;
  /// A free particle shared by rows `upper` and `upper + 1` (tridiagonal assembly).
  struct Coupling
  {
    int particle, upper;
    double sign;  ///< product of the two rows' block signs at the particle (+1 or -1)
  };
  std::vector<Coupling> couplings_;
  struct SparseState;
  std::unique_ptr<SparseState> sparse_;
  struct DenseState;
  std::unique_ptr<DenseState> dense_;
  struct TreeState;
  std::unique_ptr<TreeState> tree_;
  EffectCounters counters_;
};

}  // namespace constrained_particles
