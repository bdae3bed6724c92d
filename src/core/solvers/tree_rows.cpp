// Forests whose particles carry few rows (binary trees, branched chains, a chain with a bead):
// LDL^T of J W J^T itself, leaves first. Rooted at a particle, every row but a root's has a
// parent particle, the one it shares with the rows after it; eliminating a row, once the rows
// below it are gone, updates only the rows on its parent particle, which J W J^T couples already
// (they share that particle). So there is no fill, and a particle with d rows costs O(d^2)
// scalars, where tree.cpp inverts a 3 x 3 block per particle (the same elimination on the
// saddle-point matrix, which stays O(n) on a star too: this one takes over only while every
// particle has at most four rows, and only on StagePaths::Specialized: Model::solvesTreeByRows()).
// J W J^T is positive semi-definite, so pivots without pivoting only shrink towards zero, which is
// how singular systems show (as in tridiagonal.cpp, its one-parent special case). A switched-off
// contact or slack row (RowData::inactive) has zero blocks and diagonal 1: an identity row.
#include "solver.hpp"

#include <vector>

namespace constrained_particles
{
namespace
{
constexpr int MAX_ROWS = TREE_ROWS_PER_PARTICLE;

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
  /// Entry (b, a), b > a, of a clique's strictly lower triangle, packed row by row.
  static int lower(int b, int a)
  {
    return b * (b - 1) / 2 + a;
  }

  // the elimination order and cliques (Model::treeOrder(), treeEliminatedIn(), treeCliques())
  const std::vector<int>& order_;
  const std::vector<TreePlace>& eliminated_in_;
  const std::vector<TreeClique>& cliques_;
  std::vector<double> entries_;     // the cliques' lower triangles: J W J^T ([J]^2 / kg), then L
  Eigen::VectorXd pivots_;          // per place in order_: the pivot as the elimination goes
  Eigen::VectorXd inverse_pivots_;  // D^-1, per place in order_
  const Model& model_;
  const RowData* rows_ = nullptr;  // the rows of the last assembly
};

TreeRowSolver::TreeRowSolver(const Model& model)
  : ConstraintSolver(SolveMethod::Tree)
  , order_(model.treeOrder())
  , eliminated_in_(model.treeEliminatedIn())
  , cliques_(model.treeCliques())
  , entries_(model.treeCliqueEntries(), 0.0)
  , pivots_(Eigen::VectorXd::Zero(model.numRows()))
  , inverse_pivots_(Eigen::VectorXd::Zero(model.numRows()))
  , model_(model)
{
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
  for (const TreeClique& c : cliques_)
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
    const TreePlace place = eliminated_in_[k];
    if (place.clique < 0)
      continue;
    // the rows after it on its parent particle: L's column, and their update by l v^T
    const TreeClique& c = cliques_[place.clique];
    double* e = entries_.data() + c.offset;
    const int a = place.index;
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
    const TreePlace place = eliminated_in_[k];
    if (place.clique < 0)
      continue;
    const TreeClique& c = cliques_[place.clique];
    const double* e = entries_.data() + c.offset;
    const int a = place.index;
    const double y = b[order_[k]];
    for (int j = a + 1; j < c.size; ++j)
      b[c.rows[j]] -= e[lower(j, a)] * y;
  }
  for (int k = 0; k < m; ++k)
    b[order_[k]] *= inverse_pivots_[k];
  // L^T x = D^-1 y, the last row first
  for (int k = m - 1; k >= 0; --k)
  {
    const TreePlace place = eliminated_in_[k];
    if (place.clique < 0)
      continue;
    const TreeClique& c = cliques_[place.clique];
    const double* e = entries_.data() + c.offset;
    const int a = place.index;
    double x = b[order_[k]];
    for (int j = a + 1; j < c.size; ++j)
      x -= e[lower(j, a)] * b[c.rows[j]];
    b[order_[k]] = x;
  }
}

}  // namespace

std::unique_ptr<ConstraintSolver> makeTreeRowSolver(const Model& model)
{
  if (!model.solvesTreeByRows())
    return nullptr;
  return std::make_unique<TreeRowSolver>(model);
}

}  // namespace constrained_particles
