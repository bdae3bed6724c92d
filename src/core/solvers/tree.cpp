// Any forest (branched chains, stars, several chains, rows of any width): block LDL^T of the
// saddle-point matrix [M J^T; J -delta] over the particle-row graph, leaves first. A forest gives
// no fill, so factor and solve are O(n) whatever the branching (Baraff, "Linear-time dynamics
// using Lagrange multipliers", SIGGRAPH 1996). Nodes are free particles [0, n) and rows that
// touch two or more free particles [n, n + m). A row touching one free particle only (a surface,
// a link to a pin, a point on a line) would be a leaf with a zero pivot, so it joins its
// particle's node instead: that node's block is [A G; G^T -delta] with A = m I (+ updates) and G
// the rows' Jacobian blocks, eliminated through S = delta + G^T A^-1 G.
#include "solver.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <algorithm>
#include <vector>

namespace constrained_particles
{
namespace
{
/// A particle's own rows may remove at most 99% of its mobility along the row to its parent: past
/// that the subtraction has lost more than 2 digits, and the sparse solve of J W J^T takes over
/// (the system is not at fault, only this order of elimination).
constexpr double MOBILITY_KEPT = 1e-2;

class TreeSolver : public ConstraintSolver
{
public:
  explicit TreeSolver(const Model& model);

  /// The tree elimination, or the sparse LDL^T of J W J^T when the elimination order breaks down
  /// (a particle whose own rows lock it along the row to its parent, below the root, gives a
  /// zero pivot in a system that is not singular).
  SolveReport factorize(const Model& model, const RowData& rows, EffectCounters& counters) override;
  void solveInPlace(Eigen::VectorXd& b) const override;

protected:
  void assemble(const Model& model, const RowData& rows) override;
  double maxDiagonal() const override;
  Pivots factorizeShifted(double delta) override;

private:
  /// The top (particle) part of D^-1 [f; h] at particle node i; with `inner` also the rows
  /// inside it (written to inner_solution_).
  Vec3 solveParticle(int i, const Vec3& f, const Eigen::VectorXd& b, bool inner) const;

  const Model& model_;
  const RowData* rows_ = nullptr;               // the rows of the last assembly
  bool broke_down_ = false;                     // the last elimination lost its precision
  std::unique_ptr<ConstraintSolver> fallback_;  // the sparse solve, made if it may be needed
  bool use_fallback_ = false;                   // the last factorisation is the fallback's
  std::vector<int> order_;                      // every node, each after all of its children
  std::vector<int> parent_;         // parent node, -1 for a root, -2 for a row inside a particle
  std::vector<RowIncidence> edge_;  // the row and the particle's block of the edge to the parent
  std::vector<int> inner_start_;    // rows inside particle i: inner_[inner_start_[i] ..)
  std::vector<RowIncidence> inner_;
  std::vector<Eigen::Matrix3d> particle_inverse_;  // A^-1 of particle nodes
  // per particle with k > 1 inner rows, sized once: G (3 x k), A^-1 G, S and its LDL^T, and the
  // solve's right-hand side and solution (k)
  std::vector<Eigen::Matrix3Xd> inner_gradients_, inner_weighted_;
  std::vector<Eigen::MatrixXd> inner_matrix_;
  std::vector<Eigen::LDLT<Eigen::MatrixXd>> inner_ldlt_;
  mutable std::vector<Eigen::VectorXd> inner_rhs_, inner_solution_;
  std::vector<double> inner_scalar_;  // S for k = 1
  Eigen::VectorXd row_inverse_;       // D^-1 of row nodes
  double delta_ = 0.0;                // regularisation of the last factorisation
  mutable Points particle_rhs_;       // solve workspace
  mutable Eigen::VectorXd inner_result_;
};

TreeSolver::TreeSolver(const Model& model) : ConstraintSolver(SolveMethod::Tree), model_(model)
{
  const int n = model.numParticles();
  const int m = model.numRows();
  const auto& start = model.incidenceStart();
  const auto& incidence = model.incidence();
  const auto& row_start = model.rowStart();
  const auto& block_particle = model.blockParticle();
  const auto& w = model.inverseMasses();
  // rows with one free particle live inside that particle's node
  std::vector<int> free_touches(m, 0);
  for (const RowIncidence& touch : incidence)
    ++free_touches[touch.row];
  inner_start_.assign(n + 1, 0);
  for (int i = 0; i < n; ++i)
  {
    inner_start_[i + 1] = inner_start_[i];
    for (int a = start[i]; a < start[i + 1]; ++a)
      if (free_touches[incidence[a].row] == 1)
      {
        inner_.push_back(incidence[a]);
        ++inner_start_[i + 1];
      }
  }
  // breadth-first from each unvisited node; reversed, that order puts children first
  parent_.assign(n + m, -3);  // -3: not visited
  edge_.assign(n + m, RowIncidence{ -1, -1 });
  for (const RowIncidence& touch : inner_)
    parent_[n + touch.row] = -2;
  std::vector<int> queue;
  queue.reserve(n + m);
  // roots first at particles with rows of their own: a root's own rows never break the
  // elimination down (see factorize), so one such particle per tree needs no fallback
  std::vector<int> seeds;
  seeds.reserve(2 * n + m);
  for (int i = 0; i < n; ++i)
    if (inner_start_[i + 1] > inner_start_[i])
      seeds.push_back(i);
  for (int node = 0; node < n + m; ++node)
    seeds.push_back(node);
  for (const int seed : seeds)
  {
    if (parent_[seed] != -3 || (seed < n && w[seed] == 0.0))
      continue;
    parent_[seed] = -1;
    queue.push_back(seed);
    for (std::size_t head = queue.size() - 1; head < queue.size(); ++head)
    {
      const int node = queue[head];
      if (node < n)
      {
        for (int a = start[node]; a < start[node + 1]; ++a)
        {
          const int child = n + incidence[a].row;
          if (child == parent_[node] || parent_[child] == -2)
            continue;
          parent_[child] = node;
          edge_[child] = incidence[a];
          queue.push_back(child);
        }
        continue;
      }
      const int r = node - n;
      for (int b = row_start[r]; b < row_start[r + 1]; ++b)
      {
        const int i = block_particle[b];
        if (w[i] == 0.0 || i == parent_[node])
          continue;
        parent_[i] = node;
        edge_[i] = RowIncidence{ r, b };
        queue.push_back(i);
      }
    }
  }
  order_.assign(queue.rbegin(), queue.rend());
  particle_inverse_.assign(n, Eigen::Matrix3d::Zero());
  inner_scalar_.assign(n, 0.0);
  inner_gradients_.resize(n);
  inner_weighted_.resize(n);
  inner_matrix_.resize(n);
  inner_rhs_.resize(n);
  inner_solution_.resize(n);
  inner_ldlt_.resize(n);  // constructed in place: Eigen's LDLT copies an unset status on assignment
  for (int i = 0; i < n; ++i)
  {
    const int k = inner_start_[i + 1] - inner_start_[i];
    if (k == 0)
      continue;
    inner_gradients_[i].setZero(3, k);
    inner_weighted_[i].setZero(3, k);
    inner_rhs_[i].setZero(k);
    inner_solution_[i].setZero(k);
    if (k > 1)
    {
      inner_matrix_[i].setZero(k, k);
      inner_ldlt_[i].compute(Eigen::MatrixXd::Identity(k, k));  // sizes its workspace once
    }
  }
  row_inverse_.setZero(m);
  particle_rhs_.setZero(3, n);
  inner_result_.setZero(m);
  // a particle below the root with rows of its own may break the elimination down (see
  // factorize): its fallback is made now, so that a step never builds it
  for (int i = 0; i < n; ++i)
    if (parent_[i] >= 0 && inner_start_[i + 1] > inner_start_[i])
    {
      fallback_ = makeSparseSolver(model);
      break;
    }
}

void TreeSolver::assemble(const Model& /*model*/, const RowData& rows)
{
  // the blocks are read in place
  rows_ = &rows;
}

double TreeSolver::maxDiagonal() const
{
  return maxParticleRowWeight(model_, *rows_);
}

SolveReport TreeSolver::factorize(const Model& model, const RowData& rows, EffectCounters& counters)
{
  broke_down_ = false;
  use_fallback_ = false;
  SolveReport report = ConstraintSolver::factorize(model, rows, counters);
  // a singular system is factorised again regularised, where the breakdown check is off (the
  // shift hides it): where a breakdown is possible, the sparse solve takes those too
  if (!broke_down_ && !(report.singular && fallback_))
    return report;
  if (!fallback_)  // not reached: only the particles checked at construction can break down
    fallback_ = makeSparseSolver(model);
  use_fallback_ = true;
  report = fallback_->factorize(model, rows, counters);
  report.method = SolveMethod::Tree;
  report.fallback = true;
  return report;
}

ConstraintSolver::Pivots TreeSolver::factorizeShifted(double delta)
{
  const int n = model_.numParticles();
  const auto& w = model_.inverseMasses();
  const auto& row_start = model_.rowStart();
  const auto& block_particle = model_.blockParticle();
  const std::vector<Vec3>& jacobian = rows_->jacobian;
  // a switched-off contact or slack row (RowData::inactive) has zero blocks: an identity row,
  // pivot 1, which neither moves a particle nor judges the system
  const std::vector<std::uint8_t>& inactive = rows_->inactive;
  auto off = [&](int r) { return !inactive.empty() && inactive[r]; };
  delta_ = delta;
  // pivots start as the diagonal blocks m_i I and -delta, then take each child's update
  for (int i = 0; i < n; ++i)
    if (w[i] > 0.0)
      particle_inverse_[i] = Eigen::Matrix3d::Identity() * (1.0 / w[i]);
  row_inverse_.setConstant(-delta);
  double min_ratio = 1.0;
  bool singular = false;
  auto judge = [&](double pivot, double diagonal)
  {
    const double ratio = diagonal > 0.0 ? pivot / diagonal : 0.0;
    min_ratio = std::min(min_ratio, ratio);
    if (!(ratio > SINGULAR_PIVOT_RATIO) && delta == 0.0)
      singular = true;
  };
  for (const int node : order_)
  {
    const int parent = parent_[node];
    const RowIncidence& e = edge_[node];
    if (node < n)
    {
      // A = m_i I plus positive updates: always invertible
      Eigen::Matrix3d& inverse = particle_inverse_[node];
      inverse = inverse.inverse().eval();
      const int first = inner_start_[node], k = inner_start_[node + 1] - first;
      if (k > 0)
      {
        // rows inside the node: S = delta I + G^T A^-1 G, whose pivots say how singular
        Eigen::Matrix3Xd& g = inner_gradients_[node];
        for (int c = 0; c < k; ++c)
          g.col(c) = jacobian[inner_[first + c].block];
        double pivot = 0.0;
        bool acting = false;
        for (int c = 0; c < k; ++c)
          acting = acting || !off(inner_[first + c].row);
        if (k == 1)  // the usual case (a surface, a link to a pin): no matrix
        {
          pivot = acting ? g.col(0).dot(inverse * g.col(0)) + delta : 1.0;
          inner_scalar_[node] = pivot;
        }
        else
        {
          Eigen::Matrix3Xd& weighted = inner_weighted_[node];
          Eigen::MatrixXd& s = inner_matrix_[node];
          weighted.noalias() = inverse * g;
          s.noalias() = g.transpose() * weighted;
          s.diagonal().array() += delta;
          for (int c = 0; c < k; ++c)
            if (off(inner_[first + c].row))
              s(c, c) = 1.0;
          inner_ldlt_[node].compute(s);
          pivot = inner_ldlt_[node].vectorD().minCoeff();
        }
        if (acting)
          judge(pivot, w[node] * g.colwise().squaredNorm().maxCoeff() + delta);
      }
      if (parent >= 0)
      {
        // the parent row sees this node's mobility g^T K g, K = A^-1 - A^-1 G S^-1 G^T A^-1
        const Vec3& g = jacobian[e.block];
        const Vec3 u = inverse * g;
        const double free_mobility = g.dot(u);
        double mobility = free_mobility;
        if (k == 1)
        {
          const double projected = inner_gradients_[node].col(0).dot(u);
          mobility -= projected * projected / inner_scalar_[node];
        }
        else if (k > 1)
        {
          Eigen::VectorXd& projected = inner_rhs_[node];
          Eigen::VectorXd& solved = inner_solution_[node];
          projected.noalias() = inner_gradients_[node].transpose() * u;
          solved = inner_ldlt_[node].solve(projected);
          mobility -= projected.dot(solved);
        }
        // the particle's own rows cancel nearly all of its mobility along this row: the
        // difference has lost its digits, and this order of elimination cannot go on
        if (k > 0 && delta == 0.0 && !off(e.row) && !(mobility > MOBILITY_KEPT * free_mobility))
        {
          broke_down_ = true;
          return { false, min_ratio };
        }
        row_inverse_[e.row] -= mobility;
      }
      continue;
    }
    const int r = node - n;
    if (off(r))
    {
      row_inverse_[r] = -1.0;  // its blocks are zero: nothing to hand to the parent
      continue;
    }
    const double pivot = -row_inverse_[r];  // >= 0: the row's mobility through its children
    // a row is a root only when it touches no free particle: nothing moves it
    double diagonal = 0.0;
    if (parent >= 0)
      for (int b = row_start[r]; b < row_start[r + 1]; ++b)
        if (b != e.block)
          diagonal += w[block_particle[b]] * jacobian[b].squaredNorm();
    judge(pivot, diagonal + delta);
    if (singular)
      break;
    row_inverse_[r] = -1.0 / std::max(pivot, delta > 0.0 ? delta : pivot);
    if (parent >= 0)
    {
      // particle_inverse_ still holds the parent's pivot A (inverted when it is reached)
      const Vec3& g = jacobian[e.block];
      particle_inverse_[parent] -= row_inverse_[r] * g * g.transpose();
    }
  }
  return { singular, min_ratio };
}

Vec3 TreeSolver::solveParticle(int i, const Vec3& f, const Eigen::VectorXd& b, bool inner) const
{
  const Eigen::Matrix3d& inverse = particle_inverse_[i];
  const int first = inner_start_[i], k = inner_start_[i + 1] - first;
  Vec3 x = inverse * f;
  if (k == 0)
    return x;
  // y = -S^-1 (h - G^T A^-1 f), x = A^-1 (f - G y)
  if (k == 1)
  {
    const Vec3 g = inner_gradients_[i].col(0);
    const double y = -(b[inner_[first].row] - g.dot(x)) / inner_scalar_[i];
    x -= inverse * (g * y);
    if (inner)
      inner_result_[inner_[first].row] = y;
    return x;
  }
  Eigen::VectorXd& h = inner_rhs_[i];
  Eigen::VectorXd& y = inner_solution_[i];
  for (int c = 0; c < k; ++c)
    h[c] = b[inner_[first + c].row];
  h.noalias() -= inner_gradients_[i].transpose() * x;
  y = inner_ldlt_[i].solve(h);
  y = -y;
  x -= inverse * (inner_gradients_[i] * y);
  if (inner)
    for (int c = 0; c < k; ++c)
      inner_result_[inner_[first + c].row] = y[c];
  return x;
}

void TreeSolver::solveInPlace(Eigen::VectorXd& b) const
{
  if (use_fallback_)
  {
    fallback_->solveInPlace(b);
    return;
  }
  // [M J^T; J -delta] [y; z] = [0; b] gives (J W J^T + delta) (-z) = b
  const int n = model_.numParticles();
  const std::vector<Vec3>& jacobian = rows_->jacobian;
  particle_rhs_.setZero();
  // forward: each node hands its eliminated right-hand side to its parent
  for (const int node : order_)
  {
    const int parent = parent_[node];
    if (parent < 0)
      continue;
    const RowIncidence& e = edge_[node];
    const Vec3& g = jacobian[e.block];
    if (node < n)
      b[e.row] -= g.dot(solveParticle(node, particle_rhs_.col(node), b, false));
    else
      particle_rhs_.col(parent) -= g * (row_inverse_[node - n] * b[node - n]);
  }
  // backward, roots first: z_j = D_j^-1 (rhs_j - H_jp z_p)
  for (auto it = order_.rbegin(); it != order_.rend(); ++it)
  {
    const int node = *it;
    const int parent = parent_[node];
    const RowIncidence& e = edge_[node];
    if (node < n)
    {
      Vec3 rhs = particle_rhs_.col(node);
      if (parent >= 0)
        rhs -= jacobian[e.block] * b[e.row];
      particle_rhs_.col(node) = solveParticle(node, rhs, b, true);
    }
    else
    {
      const int r = node - n;
      double rhs = b[r];
      if (parent >= 0)
        rhs -= jacobian[e.block].dot(particle_rhs_.col(parent));
      b[r] = row_inverse_[r] * rhs;
    }
  }
  for (const RowIncidence& touch : inner_)
    b[touch.row] = inner_result_[touch.row];
  b = -b;
}

}  // namespace

std::unique_ptr<ConstraintSolver> makeTreeSolver(const Model& model)
{
  if (std::unique_ptr<ConstraintSolver> rows = makeTreeRowSolver(model))
    return rows;
  return std::make_unique<TreeSolver>(model);
}

}  // namespace constrained_particles
