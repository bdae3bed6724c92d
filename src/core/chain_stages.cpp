// The fused chain stages (issue 17): for a model whose rows are all links with a tridiagonal
// J W J^T (Model::fusedChain()), the row, constraint-force and solve stages in two sweeps
// instead of seven: up the chain, each link's row (C, J, Jdot v, violation, diagonal), its
// right-hand side, its LDL^T pivot and its forward substitution; down the chain, the back
// substitution, the multipliers and J^T lambda. The arithmetic is the generic stages' (stages.cpp
// and solvers/tridiagonal.cpp) in the same order, so both give the same motion; the same
// counters move, by sweep rather than by row. A singular pivot hands the stage to the generic
// path, whose factorisation regularises it.
#include "solvers/solver.hpp"
#include "stabilization.hpp"
#include "stages.hpp"

#include <cmath>

namespace constrained_particles
{
namespace
{
// Link k's Jacobian blocks, C and diagonal entry of J W J^T at `positions`
// (link_constraint.hpp's evaluateRows, evaluateRowRecords' diagonal); returns |p_i - p_j|^2.
inline double evaluateLink(const ChainRow& link, int k, const Points& positions, RowData& rows)
{
  const int b = 2 * k;
  const double* pi = positions.data() + 3 * link.first;
  const double* pj = positions.data() + 3 * link.second;
  const Vec3 d(pi[0] - pj[0], pi[1] - pj[1], pi[2] - pj[2]);
  const double squared = d.x() * d.x() + d.y() * d.y() + d.z() * d.z();
  rows.jacobian[b] = d;
  rows.jacobian[b + 1] = -d;
  rows.value[k] = 0.5 * (squared - link.length * link.length);
  rows.diagonal[k] = link.w_first * rows.jacobian[b].squaredNorm() +
                     link.w_second * rows.jacobian[b + 1].squaredNorm();
  return squared;
}

// Row k's LDL^T pivot (tridiagonal.cpp's factorizeShifted at delta = 0): sets L's entry left of
// it and tracks min(pivot / diagonal); the caller checks it with isSingularPivot.
inline double pivotOf(const ChainRow& link, int k, const RowData& rows, Eigen::VectorXd& lower,
                      const Eigen::VectorXd& inverse_pivots, double& min_ratio)
{
  const double diagonal = rows.diagonal[k];
  double pivot = diagonal;
  if (k > 0)
  {
    const double off =
        link.coupling >= 0
            ? link.w_coupling * rows.jacobian[link.upper_block].dot(rows.jacobian[link.lower_block])
            : 0.0;
    lower[k - 1] = off * inverse_pivots[k - 1];
    pivot -= lower[k - 1] * off;
  }
  if (!(diagonal > 0.0))
    min_ratio = 0.0;
  else if (pivot < min_ratio * diagonal)
    min_ratio = pivot / diagonal;
  return pivot;
}

// Counts a fused factorisation and merges its report, as factorizeRows() does the solver's.
SolveReport countFusedFactorization(const Model& model, Data& data, double min_ratio)
{
  ++data.counters.factorizations[static_cast<int>(SolveMethod::Tridiagonal)];
  SolveReport report;
  report.method = model.solveMethod();
  report.min_pivot_ratio = min_ratio;
  data.statistics.solve.merge(report);
  return report;
}

// Up the chain; false at a singular pivot (data.rows then holds the rows before it only). The
// violations (a square root per link) are left: only a projection reads them, after its own
// evaluation of the rows.
bool chainSweepUp(const Model& model, Data& data, const Points& positions, const Points& velocities,
                  double& min_ratio)
{
  const std::vector<ChainRow>& links = model.chainRows();
  RowData& rows = data.rows;
  const Points& f = data.applied_forces;
  Eigen::VectorXd& rhs = data.rhs;
  Eigen::VectorXd& lower = data.chain_lower;
  Eigen::VectorXd& inverse_pivots = data.chain_inverse_pivots;
  min_ratio = 1.0;
  const int m = static_cast<int>(links.size());
  for (int k = 0; k < m; ++k)
  {
    const ChainRow& link = links[k];
    const int i = link.first, j = link.second, b = 2 * k;
    evaluateLink(link, k, positions, rows);
    const double* vi = velocities.data() + 3 * i;
    const double* vj = velocities.data() + 3 * j;
    const double ux = vi[0] - vj[0], uy = vi[1] - vj[1], uz = vi[2] - vj[2];
    const double jdot_v = ux * ux + uy * uy + uz * uz;
    rows.jdot_v[k] = jdot_v;
    // the right-hand side -(Jdot v + J W f) - J a_held (stages.cpp's constraintForceStage)
    double sum = jdot_v;
    sum += link.w_first * rows.jacobian[b].dot(f.col(i));
    sum += link.w_second * rows.jacobian[b + 1].dot(f.col(j));
    double r = -sum;
    if (link.held_first >= 0)
      r -= rows.jacobian[b].dot(data.imposed[link.held_first].acceleration);
    if (link.held_second >= 0)
      r -= rows.jacobian[b + 1].dot(data.imposed[link.held_second].acceleration);
    // the pivot and the forward substitution
    const double pivot = pivotOf(link, k, rows, lower, inverse_pivots, min_ratio);
    if (k > 0)
      r -= lower[k - 1] * rhs[k - 1];
    if (ConstraintSolver::isSingularPivot(pivot, rows.diagonal[k]))
      return false;
    inverse_pivots[k] = 1.0 / pivot;
    rhs[k] = r;
  }
  return true;
}

// Down the chain: lambda = D^-1 y - L^T lambda, the multipliers, f_c = J^T lambda.
void chainSweepDown(const Model& model, Data& data)
{
  const std::vector<ChainRow>& links = model.chainRows();
  const RowData& rows = data.rows;
  const Eigen::VectorXd& lower = data.chain_lower;
  const Eigen::VectorXd& inverse_pivots = data.chain_inverse_pivots;
  Eigen::VectorXd& rhs = data.rhs;
  Points& forces = data.constraint_forces;
  forces.setZero();
  const int m = static_cast<int>(links.size());
  for (int k = m - 1; k >= 0; --k)
  {
    double lambda = rhs[k] * inverse_pivots[k];
    if (k + 1 < m)
      lambda -= lower[k] * rhs[k + 1];
    rhs[k] = lambda;
    data.multipliers[k] = lambda;
    const ChainRow& link = links[k];
    forces.col(link.first) += lambda * rows.jacobian[2 * k];
    forces.col(link.second) += lambda * rows.jacobian[2 * k + 1];
  }
}

// Up the chain for a projection at `positions`: the rows (with violations, Jdot v = 0 as at zero
// velocities), LDL^T, and the forward substitutions of C into data.rhs and of J v into
// data.chain_velocity_rhs. Returns false at a singular pivot (the rows are still all evaluated;
// the factorisation is then unusable).
bool chainProjectionSweep(const Model& model, Data& data, const Points& positions,
                          const Points& velocities, double& min_ratio)
{
  const std::vector<ChainRow>& links = model.chainRows();
  RowData& rows = data.rows;
  Eigen::VectorXd& y = data.rhs;
  Eigen::VectorXd& z = data.chain_velocity_rhs;
  Eigen::VectorXd& lower = data.chain_lower;
  Eigen::VectorXd& inverse_pivots = data.chain_inverse_pivots;
  double max_violation = 0.0;
  bool factorised = true;
  min_ratio = 1.0;
  const int m = static_cast<int>(links.size());
  for (int k = 0; k < m; ++k)
  {
    const ChainRow& link = links[k];
    const int i = link.first, j = link.second, b = 2 * k;
    const double squared = evaluateLink(link, k, positions, rows);
    rows.jdot_v[k] = 0.0;
    rows.violation[k] = std::abs(std::sqrt(squared) - link.length);
    max_violation = worseError(max_violation, rows.violation[k]);
    if (!factorised)
      continue;
    // J v as multiplyJacobian sums it
    double jv = 0.0;
    jv += rows.jacobian[b].dot(velocities.col(i));
    jv += rows.jacobian[b + 1].dot(velocities.col(j));
    double c = rows.value[k];
    const double pivot = pivotOf(link, k, rows, lower, inverse_pivots, min_ratio);
    if (k > 0)
    {
      c -= lower[k - 1] * y[k - 1];
      jv -= lower[k - 1] * z[k - 1];
    }
    if (ConstraintSolver::isSingularPivot(pivot, rows.diagonal[k]))
    {
      factorised = false;
      continue;
    }
    inverse_pivots[k] = 1.0 / pivot;
    y[k] = c;
    z[k] = jv;
  }
  rows.max_violation = max_violation;
  return factorised;
}

// x = D^-1 x - L^T x from the bottom: the back half of the fused solve, in place.
void chainBackSubstitution(const Data& data, Eigen::VectorXd& x)
{
  const Eigen::VectorXd& lower = data.chain_lower;
  const Eigen::VectorXd& inverse_pivots = data.chain_inverse_pivots;
  const int m = static_cast<int>(x.size());
  for (int k = m - 1; k >= 0; --k)
  {
    x[k] *= inverse_pivots[k];
    if (k + 1 < m)
      x[k] -= lower[k] * x[k + 1];
  }
}

}  // namespace

ProjectionReport chainProjectStep(const Model& model, Data& data, double time, Points& positions,
                                  Points& velocities, double tolerance, int max_iterations)
{
  // projectPositions then projectVelocities at the final rows (stabilization.cpp), with each
  // check's sweep also factorising: the last check's factorisation projects the velocities
  ProjectionReport report;
  imposeEliminated(model, data, time, &positions, nullptr);
  imposeEliminated(model, data, time, nullptr, &velocities);
  const int m = model.numRows();
  auto& counted_rows = data.counters.constraints[constraintKindIndex<LinkConstraint>()];
  bool factorised = false;
  double min_ratio = 1.0;
  for (int iteration = 0;; ++iteration)
  {
    factorised = chainProjectionSweep(model, data, positions, velocities, min_ratio);
    counted_rows += m;
    report.max_position_error = data.rows.max_violation;
    report.converged = report.max_position_error <= tolerance;
    if (report.converged || iteration >= max_iterations ||
        !std::isfinite(report.max_position_error))
      break;
    // dp = -W J^T (J W J^T)^-1 C
    if (factorised)
    {
      countFusedFactorization(model, data, min_ratio);
      chainBackSubstitution(data, data.rhs);
    }
    else
    {
      report.singular |= factorizeRows(model, data).singular;
      data.rhs = data.rows.value;
      data.solver().solveInPlace(data.rhs);
    }
    addInverseMassJacobianTranspose(model, data.rows, data.rhs, -1.0, positions);
    report.iterations = iteration + 1;
  }
  // dv = -W J^T (J W J^T)^-1 J v at the final rows
  if (factorised)
  {
    countFusedFactorization(model, data, min_ratio);
    data.rhs = data.chain_velocity_rhs;
    chainBackSubstitution(data, data.rhs);
  }
  else
  {
    report.singular |= factorizeRows(model, data).singular;
    multiplyJacobian(model, data.rows, velocities, data.rhs);
    data.solver().solveInPlace(data.rhs);
  }
  addInverseMassJacobianTranspose(model, data.rows, data.rhs, -1.0, velocities);
  data.statistics.projection.merge(report);
  return report;
}

SolveReport chainForward(const Model& model, Data& data, double time, const Points& positions,
                         const Points& velocities, Points& accelerations)
{
  appliedForceStage(model, data, positions, velocities);
  const int m = model.numRows();
  double min_ratio = 1.0;
  // the rows are counted once, as rowStage counts them, whichever path finishes the stage
  data.counters.constraints[constraintKindIndex<LinkConstraint>()] += m;
  if (!chainSweepUp(model, data, positions, velocities, min_ratio))
  {
    // singular: the generic stages finish the rows and regularise the factorisation
    evaluateRowRecords(model, time, positions, velocities, data.rows, nullptr);
    const SolveReport report = constraintForceStage(model, data, nullptr);
    accelerationStage(model, data, accelerations);
    return report;
  }
  const SolveReport report = countFusedFactorization(model, data, min_ratio);
  chainSweepDown(model, data);
  addEliminatedReactions(model, data);
  accelerationStage(model, data, accelerations);
  return report;
}

}  // namespace constrained_particles
