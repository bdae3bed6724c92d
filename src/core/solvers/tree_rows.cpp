// Forests whose particles carry few rows (binary trees, branched chains, a chain with a bead):
// LDL^T of J W J^T itself, leaves first. Rooted at a particle, every row but a root's has a
// parent particle, the one it shares with the rows after it; eliminating a row, once the rows
// below it are gone, updates only the rows on its parent particle, which J W J^T couples already
// (they share that particle). So there is no fill, and a particle with d rows costs O(d^2)
// scalars, where tree.cpp inverts a 3 x 3 block per particle (the same elimination on the
// saddle-point matrix, which stays O(n) on a star too: this one takes over only while every
// particle has at most four rows, and only on StagePaths::Specialized: Model::treeRows()). J W J^T
// is positive semi-definite, so pivots without pivoting only shrink towards zero, which is how
// singular systems show (as in tridiagonal.cpp, its one-parent special case).
#include "solver.hpp"

#include <algorithm>
#include <cassert>
#include <vector>

namespace constrained_particles
{
namespace
{
constexpr int MAX_ROWS = Model::TREE_ROWS_PER_PARTICLE;

class TreeRowSolver : public ConstraintSolver
{
public:
  explicit TreeRowSolver(const Model& model);

  void solveInPlace(Eigen::VectorXd& b) const override;

protected:
  void assemble(const Model& model, const RowData& rows) override;
  double maxDiagonal() const override;
  Pivots factorizeShifted(double delta) override;

private:
  /// The rows on one particle, in elimination order (its parent row, if any, last), and the
  /// strictly lower triangle of their block of J W J^T (then of L) at entries_[offset ..).
  struct Clique
  {
    int particle;
    int size;    ///< d <= MAX_ROWS
    int offset;  ///< entry (b, a), b > a, at entries_[offset + lower(b, a)]
    int rows[MAX_ROWS];
    int blocks[MAX_ROWS];     ///< each row's Jacobian block on the particle
    int positions[MAX_ROWS];  ///< each row's place in order_
  };

  /// Entry (b, a), b > a, of a clique's strictly lower triangle, packed row by row.
  static int lower(int b, int a)
  {
    return b * (b - 1) / 2 + a;
  }

  std::vector<int> order_;            // rows, each after every row below it
  std::vector<int> clique_of_;        // per place in order_: the clique it is eliminated in, or -1
  std::vector<int> index_in_clique_;  // per place in order_: its index in that clique
  std::vector<Clique> cliques_;       // one per free particle with two or more rows
  std::vector<double> entries_;       // the cliques' lower triangles: J W J^T ([J]^2 / kg), then L
  Eigen::VectorXd pivots_;            // per place in order_: the pivot as the elimination goes
  Eigen::VectorXd inverse_pivots_;    // D^-1, per place in order_
  const Model& model_;
  const RowData* rows_ = nullptr;  // the rows of the last assembly
};

TreeRowSolver::TreeRowSolver(const Model& model)
  : ConstraintSolver(SolveMethod::Tree), model_(model)
{
  const int n = model.numParticles();
  const int m = model.numRows();
  const auto& start = model.incidenceStart();
  const auto& incidence = model.incidence();
  const auto& row_start = model.rowStart();
  const auto& block_particle = model.blockParticle();
  const auto& w = model.inverseMasses();
  // breadth-first from a particle of each tree: a row's parent particle is the one it is reached
  // from; its other free particle (if any) is reached through it, so hangs below it
  std::vector<int> parent_particle(m, -1);
  std::vector<char> seen_particle(n, 0), seen_row(m, 0);
  std::vector<int> queue, reached;
  queue.reserve(n);
  reached.reserve(m);
  for (int root = 0; root < n; ++root)
  {
    if (seen_particle[root] || w[root] == 0.0)
      continue;
    seen_particle[root] = 1;
    queue.assign(1, root);
    for (std::size_t head = 0; head < queue.size(); ++head)
    {
      const int p = queue[head];
      for (int a = start[p]; a < start[p + 1]; ++a)
      {
        const int r = incidence[a].row;
        if (seen_row[r])
          continue;
        seen_row[r] = 1;
        parent_particle[r] = p;
        reached.push_back(r);
        for (int b = row_start[r]; b < row_start[r + 1]; ++b)
        {
          const int i = block_particle[b];
          if (w[i] > 0.0 && !seen_particle[i])  // a forest: an unseen particle hangs below
          {
            seen_particle[i] = 1;
            queue.push_back(i);
          }
        }
      }
    }
  }
  // reversed, every row comes after the rows below it; rows touching no free particle last
  order_.assign(reached.rbegin(), reached.rend());
  for (int r = 0; r < m; ++r)
    if (!seen_row[r])
      order_.push_back(r);
  std::vector<int> position(m);
  for (int k = 0; k < m; ++k)
    position[order_[k]] = k;
  // a clique per particle with two or more rows, in elimination order
  clique_of_.assign(m, -1);
  index_in_clique_.assign(m, 0);
  int offset = 0;
  std::vector<RowIncidence> touches;
  for (int p = 0; p < n; ++p)
  {
    const int d = start[p + 1] - start[p];
    if (d < 2)
      continue;
    assert(d <= MAX_ROWS);  // Model::treeRows()
    Clique clique{ p, d, offset, {}, {}, {} };
    touches.assign(incidence.begin() + start[p], incidence.begin() + start[p + 1]);
    std::sort(touches.begin(), touches.end(),
              [&](const RowIncidence& x, const RowIncidence& y)
              { return position[x.row] < position[y.row]; });
    for (int a = 0; a < d; ++a)
    {
      clique.rows[a] = touches[a].row;
      clique.blocks[a] = touches[a].block;
      clique.positions[a] = position[touches[a].row];
      if (parent_particle[touches[a].row] == p)
      {
        clique_of_[clique.positions[a]] = static_cast<int>(cliques_.size());
        index_in_clique_[clique.positions[a]] = a;
      }
    }
    cliques_.push_back(clique);
    offset += d * (d - 1) / 2;
  }
  entries_.assign(offset, 0.0);
  pivots_.setZero(m);
  inverse_pivots_.setZero(m);
}

void TreeRowSolver::assemble(const Model& /*model*/, const RowData& rows)
{
  // the diagonal comes with the rows (RowData::diagonal); each clique's other entries are formed
  // at the start of the factorisation
  rows_ = &rows;
}

double TreeRowSolver::maxDiagonal() const
{
  return maxParticleRowWeight(model_, *rows_);
}

ConstraintSolver::Pivots TreeRowSolver::factorizeShifted(double delta)
{
  const Eigen::VectorXd& diagonal = rows_->diagonal;
  const std::vector<Vec3>& jacobian = rows_->jacobian;
  const std::vector<double>& w = model_.inverseMasses();
  // (J W J^T)_ab = w_p J_ap . J_bp for rows a, b sharing particle p (a forest: only that one)
  for (const Clique& c : cliques_)
  {
    double* e = entries_.data() + c.offset;
    for (int b = 1; b < c.size; ++b)
      for (int a = 0; a < b; ++a)
        e[lower(b, a)] = w[c.particle] * jacobian[c.blocks[b]].dot(jacobian[c.blocks[a]]);
  }
  const int m = static_cast<int>(order_.size());
  for (int k = 0; k < m; ++k)
    pivots_[k] = diagonal[order_[k]] + delta;
  // the ratio of the unregularised attempt says how singular the system is
  double min_ratio = 1.0;
  for (int k = 0; k < m; ++k)
  {
    const double d = diagonal[order_[k]] + delta;
    double pivot = pivots_[k];
    if (!takePivot(pivot, d, delta, min_ratio))
      return { true, min_ratio };
    const double inverse = inverse_pivots_[k] = 1.0 / pivot;
    if (clique_of_[k] < 0)
      continue;
    // the rows after it on its parent particle: L's column, and their update by l v^T
    const Clique& c = cliques_[clique_of_[k]];
    double* e = entries_.data() + c.offset;
    const int a = index_in_clique_[k];
    double v[MAX_ROWS];
    for (int b = a + 1; b < c.size; ++b)
      v[b] = e[lower(b, a)];
    for (int b = a + 1; b < c.size; ++b)
    {
      const double l = v[b] * inverse;
      e[lower(b, a)] = l;
      for (int j = a + 1; j < b; ++j)
        e[lower(b, j)] -= l * v[j];
      pivots_[c.positions[b]] -= l * v[b];
    }
  }
  return { false, min_ratio };
}

void TreeRowSolver::solveInPlace(Eigen::VectorXd& b) const
{
  const int m = static_cast<int>(order_.size());
  // L y = b: each row hands its value to the rows after it on its parent particle
  for (int k = 0; k < m; ++k)
  {
    if (clique_of_[k] < 0)
      continue;
    const Clique& c = cliques_[clique_of_[k]];
    const double* e = entries_.data() + c.offset;
    const int a = index_in_clique_[k];
    const double y = b[order_[k]];
    for (int j = a + 1; j < c.size; ++j)
      b[c.rows[j]] -= e[lower(j, a)] * y;
  }
  for (int k = 0; k < m; ++k)
    b[order_[k]] *= inverse_pivots_[k];
  // L^T x = D^-1 y, the last row first
  for (int k = m - 1; k >= 0; --k)
  {
    if (clique_of_[k] < 0)
      continue;
    const Clique& c = cliques_[clique_of_[k]];
    const double* e = entries_.data() + c.offset;
    const int a = index_in_clique_[k];
    double x = b[order_[k]];
    for (int j = a + 1; j < c.size; ++j)
      x -= e[lower(j, a)] * b[c.rows[j]];
    b[order_[k]] = x;
  }
}

}  // namespace

std::unique_ptr<ConstraintSolver> makeTreeRowSolver(const Model& model)
{
  if (!model.treeRows())
    return nullptr;
  return std::make_unique<TreeRowSolver>(model);
}

}  // namespace constrained_particles
