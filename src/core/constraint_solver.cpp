#include "constrained_particles/core/constraint_solver.hpp"

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
void evaluateModelRow(const Model& model, int r, const Points& positions, const Points& velocities,
                      ConstraintRow& row)
{
  const Scene& scene = model.scene();
  const Constraint& c = scene.constraints[model.rowConstraints()[r]];
  if (const auto* link = std::get_if<LinkConstraint>(&c))
    evaluateRow(*link, positions, velocities, row);
  else if (const auto* surface = std::get_if<SurfaceConstraint>(&c))
    evaluateRow(*surface, scene.surfaces[surface->surface], positions, velocities, row);
}

double maxPositionError(const std::vector<ConstraintRow>& rows)
{
  double max_error = 0.0;
  for (const ConstraintRow& row : rows)
    max_error = worseError(max_error, row.metric_error);
  return max_error;
}

void evaluateRows(const Model& model, const Points& positions, const Points& velocities,
                  std::vector<ConstraintRow>& rows)
{
  rows.resize(model.rowConstraints().size());
  for (std::size_t r = 0; r < rows.size(); ++r)
    evaluateModelRow(model, static_cast<int>(r), positions, velocities, rows[r]);
}

struct ConstraintSolver::SparseState
{
  Eigen::SparseMatrix<double> matrix;
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> ldlt;
  Eigen::VectorXd permuted_diagonal;
};

struct ConstraintSolver::DenseState
{
  Eigen::LDLT<Eigen::MatrixXd> ldlt;
};

ConstraintSolver::ConstraintSolver(const Model& model) : model_(&model)
{
  const int m = model.numRows();
  rows_.resize(m);
  diagonal_.setZero(m);
  off_diagonal_.setZero(std::max(m - 1, 0));
  inverse_pivots_.setZero(m);
  lower_.setZero(std::max(m - 1, 0));
  if (model.solveMethod() == SolveMethod::Tridiagonal)
  {
    const auto& start = model.incidenceStart();
    const auto& incidence = model.incidence();
    for (int i = 0; i < model.numParticles(); ++i)
      if (start[i + 1] - start[i] == 2)
      {
        RowIncidence a = incidence[start[i]], b = incidence[start[i] + 1];
        if (a.row > b.row)
          std::swap(a, b);
        couplings_.push_back(Coupling{ i, a.row, (a.slot == b.slot) ? 1.0 : -1.0 });
      }
    std::stable_sort(couplings_.begin(), couplings_.end(),
                     [](const Coupling& x, const Coupling& y) { return x.upper < y.upper; });
  }
  values_.setZero(m);
  jdot_v_.setZero(m);
  if (model.solveMethod() == SolveMethod::Sparse)
  {
    sparse_ = std::make_unique<SparseState>();
    sparse_->matrix.resize(m, m);
  }
  else if (model.solveMethod() == SolveMethod::Dense)
  {
    dense_ = std::make_unique<DenseState>();
  }
}

ConstraintSolver::~ConstraintSolver() = default;
ConstraintSolver::ConstraintSolver(ConstraintSolver&&) noexcept = default;
ConstraintSolver& ConstraintSolver::operator=(ConstraintSolver&&) noexcept = default;

void ConstraintSolver::evaluate(const Points& positions, const Points& velocities)
{
  // one pass: each row is evaluated, summarised and (tridiagonal) assembled while in cache
  const int m = model_->numRows();
  const bool tridiagonal = model_->solveMethod() == SolveMethod::Tridiagonal;
  std::size_t next_coupling = 0;
  double max_error = 0.0;
  for (int r = 0; r < m; ++r)
  {
    ConstraintRow& row = rows_[r];
    evaluateModelRow(*model_, r, positions, velocities, row);
    values_[r] = row.value;
    jdot_v_[r] = row.jdot_v;
    max_error = worseError(max_error, row.metric_error);
    if (tridiagonal)
      assembleTridiagonalRow(r, next_coupling);
  }
  max_position_error_ = max_error;
}

void ConstraintSolver::assembleTridiagonalRow(int r, std::size_t& next_coupling)
{
  // diagonal: the row's own touches; off-diagonal: the particle it shares with row r - 1
  const auto& w = model_->inverseMasses();
  const ConstraintRow& row = rows_[r];
  double d = w[row.particle[0]];
  if (row.particle[1] >= 0)
    d += w[row.particle[1]];
  d *= row.gradient.squaredNorm();
  diagonal_[r] = d;
  if (r == 0)
    return;
  double off = 0.0;
  for (; next_coupling < couplings_.size() && couplings_[next_coupling].upper == r - 1;
       ++next_coupling)
  {
    const Coupling& c = couplings_[next_coupling];
    off += c.sign * w[c.particle] * rows_[r - 1].gradient.dot(row.gradient);
  }
  off_diagonal_[r - 1] = off;
}

SolveReport ConstraintSolver::factorize()
{
  switch (model_->solveMethod())
  {
    case SolveMethod::Tridiagonal:
      return factorizeTridiagonal();
    case SolveMethod::Sparse:
      return factorizeSparse();
    case SolveMethod::Dense:
      return factorizeDense();
    default:
      return SolveReport{};
  }
}

SolveReport ConstraintSolver::factorizeTridiagonal()
{
  // assembled by evaluate()
  const int m = static_cast<int>(diagonal_.size());
  SolveReport report;
  report.method = SolveMethod::Tridiagonal;
  const double max_diagonal = m > 0 ? diagonal_.maxCoeff() : 0.0;
  double delta = 0.0;
  // LDL^T without pivoting: J W J^T is positive semi-definite, so pivots only shrink to zero
  for (int attempt = 0; attempt < 2; ++attempt)
  {
    // the report keeps the unregularised pivots: they say how singular the system is
    double min_ratio = 1.0;
    bool singular = false;
    for (int k = 0; k < m; ++k)
    {
      const double d = diagonal_[k] + delta;
      double pivot = d;
      if (k > 0)
      {
        lower_[k - 1] = off_diagonal_[k - 1] * inverse_pivots_[k - 1];
        pivot -= lower_[k - 1] * off_diagonal_[k - 1];
      }
      if (!(d > 0.0))
        min_ratio = 0.0;
      else if (pivot < min_ratio * d)  // tracks min(pivot / d) without dividing every row
        min_ratio = pivot / d;
      if (!(pivot > SINGULAR_PIVOT_RATIO * d) || !(d > 0.0))
      {
        if (delta == 0.0)
        {
          singular = true;
          break;
        }
        // regularised: exact pivots are >= delta; only rounding can push one below
        pivot = std::max(pivot, delta);
      }
      inverse_pivots_[k] = 1.0 / pivot;
    }
    if (attempt == 0)
      report.min_pivot_ratio = min_ratio;
    if (!singular)
      return report;
    report.singular = true;
    delta = max_diagonal > 0.0 ? SINGULAR_REGULARIZATION * max_diagonal : 1.0;
    report.regularization = delta;
  }
  return report;
}

SolveReport ConstraintSolver::factorizeSparse()
{
  SolveReport report;
  report.method = SolveMethod::Sparse;
  const int m = model_->numRows();
  const auto& w = model_->inverseMasses();
  const auto& start = model_->incidenceStart();
  const auto& incidence = model_->incidence();
  auto& s = *sparse_;
  const bool first = s.triplets.empty();
  s.triplets.clear();
  for (int r = 0; r < m; ++r)
    s.triplets.emplace_back(r, r, 0.0);
  for (int i = 0; i < model_->numParticles(); ++i)
    for (int a = start[i]; a < start[i + 1]; ++a)
    {
      const RowIncidence& ra = incidence[a];
      const Vec3 ga = rows_[ra.row].gradientOf(ra.slot);
      s.triplets.emplace_back(ra.row, ra.row, w[i] * ga.squaredNorm());
      for (int b = start[i]; b < start[i + 1]; ++b)
      {
        const RowIncidence& rb = incidence[b];
        if (rb.row > ra.row)  // lower triangle only
          s.triplets.emplace_back(rb.row, ra.row, w[i] * ga.dot(rows_[rb.row].gradientOf(rb.slot)));
      }
    }
  s.matrix.setFromTriplets(s.triplets.begin(), s.triplets.end());
  if (first)
    s.ldlt.analyzePattern(s.matrix);
  const Eigen::VectorXd diagonal = s.matrix.diagonal();
  const double max_diagonal = m > 0 ? diagonal.maxCoeff() : 0.0;
  s.permuted_diagonal.resize(m);
  for (int r = 0; r < m; ++r)
    s.permuted_diagonal[s.ldlt.permutationP().indices()[r]] = diagonal[r];
  for (int attempt = 0; attempt < 2; ++attempt)
  {
    s.ldlt.factorize(s.matrix);
    double min_ratio = s.ldlt.info() == Eigen::Success ? 1.0 : 0.0;
    if (s.ldlt.info() == Eigen::Success)
    {
      const Eigen::VectorXd& pivots = s.ldlt.vectorD();
      for (int k = 0; k < m; ++k)
      {
        const double d = s.permuted_diagonal[k] + report.regularization;
        min_ratio = std::min(min_ratio, d > 0.0 ? pivots[k] / d : 0.0);
      }
    }
    const bool singular = !(min_ratio > SINGULAR_PIVOT_RATIO);
    if (attempt == 0)
      report.min_pivot_ratio = min_ratio;
    if (!singular)
      return report;
    report.singular = true;
    const double delta = max_diagonal > 0.0 ? SINGULAR_REGULARIZATION * max_diagonal : 1.0;
    report.regularization = delta;
    for (int r = 0; r < m; ++r)
      s.matrix.coeffRef(r, r) = diagonal[r] + delta;
  }
  return report;
}

SolveReport ConstraintSolver::factorizeDense()
{
  SolveReport report;
  report.method = SolveMethod::Dense;
  Eigen::MatrixXd matrix = denseMatrix();
  const int m = static_cast<int>(matrix.rows());
  const double max_diagonal = m > 0 ? matrix.diagonal().maxCoeff() : 0.0;
  for (int attempt = 0; attempt < 2; ++attempt)
  {
    dense_->ldlt.compute(matrix);
    // with pivoting the order of D is not the row order: compare with the largest diagonal
    const double min_pivot = m > 0 ? dense_->ldlt.vectorD().minCoeff() : 1.0;
    const double min_ratio = max_diagonal > 0.0 ? min_pivot / max_diagonal : 0.0;
    if (attempt == 0)
      report.min_pivot_ratio = min_ratio;
    if (dense_->ldlt.info() == Eigen::Success && min_ratio > SINGULAR_PIVOT_RATIO)
      return report;
    report.singular = true;
    report.regularization = max_diagonal > 0.0 ? SINGULAR_REGULARIZATION * max_diagonal : 1.0;
    matrix.diagonal().array() += report.regularization;
  }
  return report;
}

void ConstraintSolver::solveInPlace(Eigen::VectorXd& b) const
{
  switch (model_->solveMethod())
  {
    case SolveMethod::Tridiagonal:
    {
      const int m = static_cast<int>(b.size());
      for (int k = 1; k < m; ++k)
        b[k] -= lower_[k - 1] * b[k - 1];
      for (int k = 0; k < m; ++k)
        b[k] *= inverse_pivots_[k];
      for (int k = m - 2; k >= 0; --k)
        b[k] -= lower_[k] * b[k + 1];
      break;
    }
    case SolveMethod::Sparse:
      // a failed factorisation gives no force rather than NaN
      if (sparse_->ldlt.info() == Eigen::Success)
        b = sparse_->ldlt.solve(b);
      else
        b.setZero();
      break;
    case SolveMethod::Dense:
      if (dense_->ldlt.info() == Eigen::Success)
        b = dense_->ldlt.solve(b);
      else
        b.setZero();
      break;
    default:
      break;
  }
}

void ConstraintSolver::multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const
{
  // y = J (W (J^T x)), particle by particle
  const auto& w = model_->inverseMasses();
  const auto& start = model_->incidenceStart();
  const auto& incidence = model_->incidence();
  y.setZero(model_->numRows());
  for (int i = 0; i < model_->numParticles(); ++i)
  {
    Vec3 force = Vec3::Zero();
    for (int a = start[i]; a < start[i + 1]; ++a)
      force += rows_[incidence[a].row].gradientOf(incidence[a].slot) * x[incidence[a].row];
    for (int a = start[i]; a < start[i + 1]; ++a)
      y[incidence[a].row] +=
          w[i] * rows_[incidence[a].row].gradientOf(incidence[a].slot).dot(force);
  }
}

void ConstraintSolver::multiplyJacobian(const Points& x, Eigen::VectorXd& y) const
{
  y.resize(static_cast<int>(rows_.size()));
  for (std::size_t r = 0; r < rows_.size(); ++r)
  {
    const ConstraintRow& row = rows_[r];
    Vec3 relative = x.col(row.particle[0]);
    if (row.particle[1] >= 0)
      relative -= x.col(row.particle[1]);
    const double sum = row.gradient.dot(relative);
    y[r] = sum;
  }
}

void ConstraintSolver::multiplyJacobianInverseMass(const Points& x, Eigen::VectorXd& y) const
{
  const auto& w = model_->inverseMasses();
  y.resize(static_cast<int>(rows_.size()));
  for (std::size_t r = 0; r < rows_.size(); ++r)
  {
    const ConstraintRow& row = rows_[r];
    Vec3 weighted = w[row.particle[0]] * x.col(row.particle[0]);
    if (row.particle[1] >= 0)
      weighted -= w[row.particle[1]] * x.col(row.particle[1]);
    const double sum = row.gradient.dot(weighted);
    y[r] = sum;
  }
}

void ConstraintSolver::addJacobianTranspose(const Eigen::VectorXd& lambda, Points& out) const
{
  for (std::size_t r = 0; r < rows_.size(); ++r)
  {
    const ConstraintRow& row = rows_[r];
    const Vec3 force = row.gradient * lambda[r];
    out.col(row.particle[0]) += force;
    if (row.particle[1] >= 0)
      out.col(row.particle[1]) -= force;
  }
}

void ConstraintSolver::addInverseMassJacobianTranspose(const Eigen::VectorXd& lambda, double scale,
                                                       Points& out) const
{
  const auto& w = model_->inverseMasses();
  for (std::size_t r = 0; r < rows_.size(); ++r)
  {
    const ConstraintRow& row = rows_[r];
    const double s = scale * lambda[r];
    out.col(row.particle[0]) += (w[row.particle[0]] * s) * row.gradient;
    if (row.particle[1] >= 0)
      out.col(row.particle[1]) -= (w[row.particle[1]] * s) * row.gradient;
  }
}

Eigen::MatrixXd ConstraintSolver::denseMatrix() const
{
  const auto& w = model_->inverseMasses();
  const auto& start = model_->incidenceStart();
  const auto& incidence = model_->incidence();
  const int m = model_->numRows();
  Eigen::MatrixXd matrix = Eigen::MatrixXd::Zero(m, m);
  for (int i = 0; i < model_->numParticles(); ++i)
    for (int a = start[i]; a < start[i + 1]; ++a)
      for (int b = start[i]; b < start[i + 1]; ++b)
      {
        const RowIncidence& ra = incidence[a];
        const RowIncidence& rb = incidence[b];
        matrix(ra.row, rb.row) +=
            w[i] * rows_[ra.row].gradientOf(ra.slot).dot(rows_[rb.row].gradientOf(rb.slot));
      }
  return matrix;
}

}  // namespace constrained_particles
