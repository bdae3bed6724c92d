#include "constrained_particles/core/constraint_solver.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
void evaluateModelRow(const Model& model, int r, const Points& positions, const Points& velocities,
                      ConstraintRow& row)
{
  const Scene& scene = model.scene();
  evaluateRow(scene.constraints[model.rowConstraints()[r]], scene.surfaces, positions, velocities,
              row);
}

double maxPositionError(const std::vector<ConstraintRow>& rows)
{
  double max_error = 0.0;
  for (const ConstraintRow& row : rows)
    max_error = worseError(max_error, row.metric_error);
  return max_error;
}

namespace
{
// delta added to the diagonal of a singular J W J^T (1 if every diagonal entry is 0)
double singularRegularization(double max_diagonal)
{
  return max_diagonal > 0.0 ? SINGULAR_REGULARIZATION * max_diagonal : 1.0;
}

}  // namespace

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

// Block LDL^T of the saddle-point matrix [M J^T; J -delta] over the particle-row graph, leaves
// first: a forest gives no fill, so factor and solve are O(n) whatever the branching (Baraff,
// "Linear-time dynamics using Lagrange multipliers", 1996). Nodes are free particles [0, n) and
// rows joining two free particles [n, n + m). A row touching one free particle only (a surface,
// a link to a pin) would be a leaf with a zero pivot, so it joins its particle's node instead:
// that node's block is [A G; G^T -delta] with A = m I (+ updates) and G the rows' gradients.
struct ConstraintSolver::TreeState
{
  std::vector<int> order;          // every node, each after all of its children
  std::vector<int> parent;         // parent node, -1 for a root, -2 for a row inside a particle
  std::vector<RowIncidence> edge;  // the row and the particle's slot of the edge to the parent
  std::vector<int> inner_start;    // rows inside particle i: inner[inner_start[i] ..)
  std::vector<RowIncidence> inner;
  std::vector<Eigen::Matrix3d> particle_inverse;         // A^-1 of particle nodes
  std::vector<Eigen::LDLT<Eigen::MatrixXd>> inner_ldlt;  // of delta I + G^T A^-1 G (k > 1)
  std::vector<double> inner_scalar;                      // the same for k = 1
  std::vector<Eigen::Matrix3Xd> inner_gradients;         // G of each particle with inner rows
  Eigen::VectorXd row_inverse;                           // D^-1 of row nodes
  mutable Points particle_rhs;                           // solve workspace
  mutable Eigen::VectorXd inner_rhs;                     // solve workspace
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
  else if (model.solveMethod() == SolveMethod::Tree)
  {
    buildTree();
  }
}

ConstraintSolver::~ConstraintSolver() = default;
ConstraintSolver::ConstraintSolver(ConstraintSolver&&) noexcept = default;
ConstraintSolver& ConstraintSolver::operator=(ConstraintSolver&&) noexcept = default;

void ConstraintSolver::evaluate(const Points& positions, const Points& velocities)
{
  // one pass: each row is evaluated, summarised and (tridiagonal) assembled while in cache
  const int m = model_->numRows();
  const bool tridiagonal = model_->solveMethod() == SolveMethod::Tridiagonal ||
                           model_->solveMethod() == SolveMethod::Single;
  const auto& constraints = model_->scene().constraints;
  const auto& row_constraint = model_->rowConstraints();
  std::size_t next_coupling = 0;
  double max_error = 0.0;
  for (int r = 0; r < m; ++r)
  {
    ConstraintRow& row = rows_[r];
    const Constraint& constraint = constraints[row_constraint[r]];
    evaluateRow(constraint, model_->scene().surfaces, positions, velocities, row);
    ++counters_.constraints[constraint.index()];
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
  ++counters_.factorizations[static_cast<int>(model_->solveMethod())];
  switch (model_->solveMethod())
  {
    case SolveMethod::Single:
    {
      // the 1 x 1 case of the tridiagonal factorisation: lambda = b / (J W J^T)
      SolveReport report = factorizeTridiagonal();
      report.method = SolveMethod::Single;
      return report;
    }
    case SolveMethod::Tree:
      return factorizeTree();
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
    delta = singularRegularization(max_diagonal);
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
    const double delta = singularRegularization(max_diagonal);
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
    report.regularization = singularRegularization(max_diagonal);
    matrix.diagonal().array() += report.regularization;
  }
  return report;
}

void ConstraintSolver::buildTree()
{
  const Model& model = *model_;
  const int n = model.numParticles();
  const int m = model.numRows();
  const auto& start = model.incidenceStart();
  const auto& incidence = model.incidence();
  tree_ = std::make_unique<TreeState>();
  TreeState& t = *tree_;
  // rows with one free particle live inside that particle's node
  std::vector<int> free_touches(m, 0);
  for (const RowIncidence& touch : incidence)
    ++free_touches[touch.row];
  t.inner_start.assign(n + 1, 0);
  for (int i = 0; i < n; ++i)
  {
    t.inner_start[i + 1] = t.inner_start[i];
    for (int a = start[i]; a < start[i + 1]; ++a)
      if (free_touches[incidence[a].row] == 1)
      {
        t.inner.push_back(incidence[a]);
        ++t.inner_start[i + 1];
      }
  }
  // breadth-first from each unvisited node; reversed, that order puts children first
  t.parent.assign(n + m, -3);  // -3: not visited
  t.edge.assign(n + m, RowIncidence{ -1, -1 });
  for (const RowIncidence& touch : t.inner)
    t.parent[n + touch.row] = -2;
  std::vector<int> queue;
  queue.reserve(n + m);
  const auto& w = model.inverseMasses();
  const auto& constraints = model.scene().constraints;
  const auto& row_constraint = model.rowConstraints();
  for (int seed = 0; seed < n + m; ++seed)
  {
    if (t.parent[seed] != -3 || (seed < n && w[seed] == 0.0))
      continue;
    t.parent[seed] = -1;
    queue.push_back(seed);
    for (std::size_t head = queue.size() - 1; head < queue.size(); ++head)
    {
      const int node = queue[head];
      if (node < n)
      {
        for (int a = start[node]; a < start[node + 1]; ++a)
        {
          const int child = n + incidence[a].row;
          if (child == t.parent[node] || t.parent[child] == -2)
            continue;
          t.parent[child] = node;
          t.edge[child] = incidence[a];
          queue.push_back(child);
        }
        continue;
      }
      const int r = node - n;
      const auto particles = rowParticles(constraints[row_constraint[r]]);
      for (int slot = 0; slot < 2; ++slot)
      {
        const int i = particles[slot];
        if (i < 0 || w[i] == 0.0 || i == t.parent[node])
          continue;
        t.parent[i] = node;
        t.edge[i] = RowIncidence{ r, slot };
        queue.push_back(i);
      }
    }
  }
  t.order.assign(queue.rbegin(), queue.rend());
  t.particle_inverse.assign(n, Eigen::Matrix3d::Zero());
  t.inner_ldlt.resize(
      n);  // constructed in place: Eigen's LDLT copies an unset status on assignment
  t.inner_scalar.assign(n, 0.0);
  t.inner_gradients.resize(n);
  for (int i = 0; i < n; ++i)
  {
    const int k = t.inner_start[i + 1] - t.inner_start[i];
    if (k > 0)
      t.inner_gradients[i].resize(3, k);
  }
  t.row_inverse.setZero(m);
  t.particle_rhs.setZero(3, n);
  t.inner_rhs.setZero(m);
}

SolveReport ConstraintSolver::factorizeTree()
{
  SolveReport report;
  report.method = SolveMethod::Tree;
  TreeState& t = *tree_;
  const int n = model_->numParticles();
  const int m = model_->numRows();
  const auto& w = model_->inverseMasses();
  double max_diagonal = 0.0;
  for (int i = 0; i < n; ++i)
    for (int a = model_->incidenceStart()[i]; a < model_->incidenceStart()[i + 1]; ++a)
      max_diagonal =
          std::max(max_diagonal, w[i] * rows_[model_->incidence()[a].row].gradient.squaredNorm());
  double delta = 0.0;
  for (int attempt = 0; attempt < 2; ++attempt)
  {
    // pivots start as the diagonal blocks m_i I and -delta, then take each child's update
    for (int i = 0; i < n; ++i)
      if (w[i] > 0.0)
        t.particle_inverse[i] = Eigen::Matrix3d::Identity() * (1.0 / w[i]);
    t.row_inverse.setConstant(m, -delta);
    double min_ratio = 1.0;
    bool singular = false;
    auto judge = [&](double pivot, double diagonal)
    {
      const double ratio = diagonal > 0.0 ? pivot / diagonal : 0.0;
      min_ratio = std::min(min_ratio, ratio);
      if (!(ratio > SINGULAR_PIVOT_RATIO) && delta == 0.0)
        singular = true;
    };
    for (const int node : t.order)
    {
      const int parent = t.parent[node];
      const RowIncidence& e = t.edge[node];
      if (node < n)
      {
        // A = m_i I plus positive updates: always invertible
        Eigen::Matrix3d& inverse = t.particle_inverse[node];
        inverse = inverse.inverse().eval();
        const int first = t.inner_start[node], k = t.inner_start[node + 1] - first;
        if (k > 0)
        {
          // rows inside the node: S = delta I + G^T A^-1 G, whose pivots say how singular
          Eigen::Matrix3Xd& g = t.inner_gradients[node];
          for (int c = 0; c < k; ++c)
            g.col(c) = rows_[t.inner[first + c].row].gradientOf(t.inner[first + c].slot);
          double pivot = 0.0;
          if (k == 1)  // the usual case (a surface, a link to a pin): no matrix
          {
            pivot = g.col(0).dot(inverse * g.col(0)) + delta;
            t.inner_scalar[node] = pivot;
          }
          else
          {
            Eigen::MatrixXd s = g.transpose() * inverse * g;
            s.diagonal().array() += delta;
            t.inner_ldlt[node].compute(s);
            pivot = t.inner_ldlt[node].vectorD().minCoeff();
          }
          judge(pivot, w[node] * g.colwise().squaredNorm().maxCoeff() + delta);
        }
        if (parent >= 0)
        {
          // the parent row sees this node's mobility g^T K g, K = A^-1 - A^-1 G S^-1 G^T A^-1
          const Vec3 g = rows_[e.row].gradientOf(e.slot);
          const Vec3 u = inverse * g;
          double mobility = g.dot(u);
          if (k == 1)
          {
            const double projected = t.inner_gradients[node].col(0).dot(u);
            mobility -= projected * projected / t.inner_scalar[node];
          }
          else if (k > 1)
          {
            const Eigen::VectorXd projected = t.inner_gradients[node].transpose() * u;
            mobility -= projected.dot(t.inner_ldlt[node].solve(projected));
          }
          t.row_inverse[e.row] -= mobility;
        }
        continue;
      }
      const int r = node - n;
      const double pivot = -t.row_inverse[r];  // >= 0: the row's mobility through its children
      // a row is a root only when it touches no free particle: nothing moves it
      const double diagonal =
          parent >= 0 ? w[rows_[r].particle[1 - e.slot]] * rows_[r].gradient.squaredNorm() : 0.0;
      judge(pivot, diagonal + delta);
      if (singular)
        break;
      t.row_inverse[r] = -1.0 / std::max(pivot, delta > 0.0 ? delta : pivot);
      if (parent >= 0)
      {
        // particle_inverse still holds the parent's pivot A (inverted when it is reached)
        const Vec3 g = rows_[r].gradientOf(e.slot);
        t.particle_inverse[parent] -= t.row_inverse[r] * g * g.transpose();
      }
    }
    if (attempt == 0)
      report.min_pivot_ratio = min_ratio;
    if (!singular)
      return report;
    report.singular = true;
    delta = singularRegularization(max_diagonal);
    report.regularization = delta;
  }
  return report;
}

void ConstraintSolver::solveTree(Eigen::VectorXd& b) const
{
  // [M J^T; J -delta] [y; z] = [0; b] gives (J W J^T + delta) (-z) = b
  const TreeState& t = *tree_;
  const int n = model_->numParticles();
  Points& particle_rhs = t.particle_rhs;
  particle_rhs.setZero();
  // the top (particle) part of D^-1 [f; h] for a particle node with inner rows; fills y too
  auto solveParticle = [&](int i, const Vec3& f, Eigen::VectorXd* y) -> Vec3
  {
    const Eigen::Matrix3d& inverse = t.particle_inverse[i];
    const int first = t.inner_start[i], k = t.inner_start[i + 1] - first;
    Vec3 x = inverse * f;
    if (k == 0)
      return x;
    // y = -S^-1 (h - G^T A^-1 f), x = A^-1 (f - G y)
    if (k == 1)
    {
      const Vec3 g = t.inner_gradients[i].col(0);
      const double inner = -(b[t.inner[first].row] - g.dot(x)) / t.inner_scalar[i];
      x -= inverse * (g * inner);
      if (y)
        y->setConstant(1, inner);
      return x;
    }
    Eigen::VectorXd h(k);
    for (int c = 0; c < k; ++c)
      h[c] = b[t.inner[first + c].row];
    const Eigen::VectorXd inner = -t.inner_ldlt[i].solve(h - t.inner_gradients[i].transpose() * x);
    x -= inverse * (t.inner_gradients[i] * inner);
    if (y)
      *y = inner;
    return x;
  };
  // forward: each node hands its eliminated right-hand side to its parent
  for (const int node : t.order)
  {
    const int parent = t.parent[node];
    if (parent < 0)
      continue;
    const RowIncidence& e = t.edge[node];
    const Vec3 g = rows_[e.row].gradientOf(e.slot);
    if (node < n)
      b[e.row] -= g.dot(solveParticle(node, particle_rhs.col(node), nullptr));
    else
      particle_rhs.col(parent) -= g * (t.row_inverse[node - n] * b[node - n]);
  }
  // backward, roots first: z_j = D_j^-1 (rhs_j - H_jp z_p)
  Eigen::VectorXd inner;
  for (auto it = t.order.rbegin(); it != t.order.rend(); ++it)
  {
    const int node = *it;
    const int parent = t.parent[node];
    const RowIncidence& e = t.edge[node];
    if (node < n)
    {
      Vec3 rhs = particle_rhs.col(node);
      if (parent >= 0)
        rhs -= rows_[e.row].gradientOf(e.slot) * b[e.row];
      particle_rhs.col(node) = solveParticle(node, rhs, &inner);
      const int first = t.inner_start[node];
      for (int c = 0; c < t.inner_start[node + 1] - first; ++c)
        t.inner_rhs[t.inner[first + c].row] = inner[c];
    }
    else
    {
      const int r = node - n;
      double rhs = b[r];
      if (parent >= 0)
        rhs -= rows_[r].gradientOf(e.slot).dot(particle_rhs.col(parent));
      b[r] = t.row_inverse[r] * rhs;
    }
  }
  for (const RowIncidence& touch : t.inner)
    b[touch.row] = t.inner_rhs[touch.row];
  b = -b;
}

void ConstraintSolver::solveInPlace(Eigen::VectorXd& b) const
{
  switch (model_->solveMethod())
  {
    case SolveMethod::Tree:
      solveTree(b);
      break;
    case SolveMethod::Single:
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
