// Any structure (rings, meshes, anything with a cycle): Eigen's SimplicialLDLT, a sparse LDL^T
// with a fill-reducing ordering. Eigen does the factorisation (a well-kept library beats ours).
// In a model of SPARSE_ACTIVE_PATTERN_ROWS rows or more the pattern of J W J^T couples only the
// rows that act: a switched-off contact row is an identity row, and its structural entries would
// cost the factor their fill (a folded rope's link pairs within the broad phase's margin outnumber
// those that touch 3 to 1, and the factor took 75 % of its step). Its pattern is then built and
// analysed again when the set of acting rows changes; a smaller model's pattern, every row's, is
// analysed once (its factor is cheap, and contacts switching many times a step made the analyses
// cost a pile of 30 particles 4.5 times its steps). Either way each factorisation between analyses
// only writes the values into the pattern, and the result is a function of the rows alone.
#include "solver.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace constrained_particles
{
namespace
{
class SparseSolver : public ConstraintSolver
{
public:
  explicit SparseSolver(const Model& model)
    : ConstraintSolver(SolveMethod::Sparse)
    , active_pattern_(model.numRows() >= SPARSE_ACTIVE_PATTERN_ROWS)
  {
    diagonal_.setZero(model.numRows());
    permuted_diagonal_.setZero(model.numRows());
    build(model, {});
  }

  void solveInPlace(Eigen::VectorXd& b) const override
  {
    solveWith(ldlt_, b);
  }

protected:
  void assemble(const Model& model, const RowData& rows) override
  {
    if (active_pattern_ && rows.inactive != pattern_inactive_)
      build(model, rows.inactive);
    const auto& w = model.inverseMasses();
    double* values = matrix_.valuePtr();
    std::fill(values, values + matrix_.nonZeros(), 0.0);
    for (const Term& t : terms_)
      values[t.slot] += w[t.particle] * rows.jacobian[t.block_a].dot(rows.jacobian[t.block_b]);
    for (int r = 0; r < diagonal_.size(); ++r)
      diagonal_[r] = values[diagonal_slot_[r]];
    // a switched-off contact row (zero blocks) is the identity row: its multiplier is 0
    for (std::size_t r = 0; r < rows.inactive.size(); ++r)
      if (rows.inactive[r])
        diagonal_[r] = values[diagonal_slot_[r]] = 1.0;
    // the factor's pivots come in the ordering's sequence: compare each with its own diagonal
    for (int r = 0; r < diagonal_.size(); ++r)
      permuted_diagonal_[ldlt_.permutationP().indices()[r]] = diagonal_[r];
  }

  double maxDiagonal() const override
  {
    return diagonal_.size() > 0 ? diagonal_.maxCoeff() : 0.0;
  }

  Pivots factorizeShifted(double delta) override
  {
    double* values = matrix_.valuePtr();
    for (int r = 0; r < diagonal_.size(); ++r)
      values[diagonal_slot_[r]] = diagonal_[r] + delta;
    ldlt_.factorize(matrix_);
    double min_ratio = ldlt_.info() == Eigen::Success ? 1.0 : 0.0;
    if (ldlt_.info() == Eigen::Success)
    {
      const Eigen::VectorXd& pivots = ldlt_.vectorD();
      for (int k = 0; k < pivots.size(); ++k)
      {
        const double d = permuted_diagonal_[k] + delta;
        min_ratio = std::min(min_ratio, d > 0.0 ? pivots[k] / d : 0.0);
      }
    }
    return { !(min_ratio > SINGULAR_PIVOT_RATIO), min_ratio };
  }

private:
  /// The lower triangle of J W J^T for the rows acting (`inactive` empty: all): (r, r) for every
  /// row, and (s, r), s > r, for every pair of acting rows sharing a free particle; where each
  /// contribution w_i J_a . J_b lands in its values; and the ordering and symbolic factor
  void build(const Model& model, const std::vector<std::uint8_t>& inactive)
  {
    pattern_inactive_ = inactive;
    auto acting = [&inactive](int row) { return inactive.empty() || !inactive[row]; };
    const int m = model.numRows();
    const auto& start = model.incidenceStart();
    const auto& incidence = model.incidence();
    std::vector<Eigen::Triplet<double>> pattern;
    for (int r = 0; r < m; ++r)
      pattern.emplace_back(r, r, 0.0);
    for (int i = 0; i < model.numParticles(); ++i)
      for (int a = start[i]; a < start[i + 1]; ++a)
        for (int b = start[i]; b < start[i + 1]; ++b)
          if (incidence[b].row > incidence[a].row && acting(incidence[a].row) &&
              acting(incidence[b].row))
            pattern.emplace_back(incidence[b].row, incidence[a].row, 0.0);
    matrix_.resize(m, m);
    matrix_.setFromTriplets(pattern.begin(), pattern.end());
    matrix_.makeCompressed();
    auto slot = [this](int row, int column)
    {
      const int* first = matrix_.innerIndexPtr() + matrix_.outerIndexPtr()[column];
      const int* last = matrix_.innerIndexPtr() + matrix_.outerIndexPtr()[column + 1];
      return static_cast<int>(std::lower_bound(first, last, row) - matrix_.innerIndexPtr());
    };
    terms_.clear();
    for (int i = 0; i < model.numParticles(); ++i)
      for (int a = start[i]; a < start[i + 1]; ++a)
        for (int b = start[i]; b < start[i + 1]; ++b)
          if (incidence[b].row >= incidence[a].row && acting(incidence[a].row) &&
              acting(incidence[b].row))
            terms_.push_back(Term{ slot(incidence[b].row, incidence[a].row), i, incidence[a].block,
                                   incidence[b].block });
    diagonal_slot_.resize(m);
    for (int r = 0; r < m; ++r)
      diagonal_slot_[r] = slot(r, r);
    ldlt_.analyzePattern(matrix_);
  }

  /// One contribution w_i J_a . J_b of particle i to the entry at values[slot].
  struct Term
  {
    int slot, particle, block_a, block_b;
  };
  const bool active_pattern_;                   // the pattern of the acting rows only
  Eigen::SparseMatrix<double> matrix_;          // lower triangle, pattern of the rows acting
  std::vector<std::uint8_t> pattern_inactive_;  // the rows switched off when it was built
  std::vector<Term> terms_;
  std::vector<int> diagonal_slot_;
  Eigen::VectorXd diagonal_, permuted_diagonal_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> ldlt_;
};

}  // namespace

std::unique_ptr<ConstraintSolver> makeSparseSolver(const Model& model)
{
  return std::make_unique<SparseSolver>(model);
}

}  // namespace constrained_particles
