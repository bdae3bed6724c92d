// Chains (and a chain hanging from a surface bead, and several chains in turn): every free
// particle is touched by at most two rows, and those adjacent, so J W J^T is tridiagonal in row
// order. LDL^T without pivoting, O(m): J W J^T is positive semi-definite, so pivots only shrink
// towards zero, which is how singular systems show.
#include "solver.hpp"

#include <algorithm>
#include <vector>

namespace constrained_particles
{
namespace
{
class TridiagonalSolver : public ConstraintSolver
{
public:
  explicit TridiagonalSolver(const Model& model)
  {
    const int m = model.numRows();
    diagonal_.setZero(m);
    off_diagonal_.setZero(std::max(m - 1, 0));
    inverse_pivots_.setZero(m);
    lower_.setZero(std::max(m - 1, 0));
    // a free particle shared by rows r and r + 1 couples them
    const auto& start = model.incidenceStart();
    const auto& incidence = model.incidence();
    for (int i = 0; i < model.numParticles(); ++i)
      if (start[i + 1] - start[i] == 2)
      {
        RowIncidence a = incidence[start[i]], b = incidence[start[i] + 1];
        if (a.row > b.row)
          std::swap(a, b);
        couplings_.push_back(Coupling{ i, a.row, a.block, b.block });
      }
    std::stable_sort(couplings_.begin(), couplings_.end(),
                     [](const Coupling& x, const Coupling& y) { return x.upper < y.upper; });
  }

  void solveInPlace(Eigen::VectorXd& b) const override
  {
    const int m = static_cast<int>(b.size());
    for (int k = 1; k < m; ++k)
      b[k] -= lower_[k - 1] * b[k - 1];
    for (int k = 0; k < m; ++k)
      b[k] *= inverse_pivots_[k];
    for (int k = m - 2; k >= 0; --k)
      b[k] -= lower_[k] * b[k + 1];
  }

protected:
  SolveMethod method() const override
  {
    return SolveMethod::Tridiagonal;
  }

  double assemble(const Model& model, const RowData& rows) override
  {
    // diagonal: each row's own touches; off-diagonal: the particles it shares with the next
    const auto& w = model.inverseMasses();
    const auto& start = model.rowStart();
    const auto& particle = model.blockParticle();
    const int m = model.numRows();
    double max_diagonal = 0.0;
    for (int r = 0; r < m; ++r)
    {
      double d = 0.0;
      for (int b = start[r]; b < start[r + 1]; ++b)
        d += w[particle[b]] * rows.jacobian[b].squaredNorm();
      diagonal_[r] = d;
      max_diagonal = std::max(max_diagonal, d);
    }
    off_diagonal_.setZero();
    for (const Coupling& c : couplings_)
      off_diagonal_[c.upper] +=
          w[c.particle] * rows.jacobian[c.upper_block].dot(rows.jacobian[c.lower_block]);
    return max_diagonal;
  }

  Pivots factorizeShifted(double delta) override
  {
    const int m = static_cast<int>(diagonal_.size());
    // the ratio of the unregularised attempt says how singular the system is
    double min_ratio = 1.0;
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
      if (isSingularPivot(pivot, d))
      {
        if (delta == 0.0)
          return { true, min_ratio };
        // regularised: exact pivots are >= delta; only rounding can push one below
        pivot = std::max(pivot, delta);
      }
      inverse_pivots_[k] = 1.0 / pivot;
    }
    return { false, min_ratio };
  }

private:
  /// A free particle shared by rows `upper` and `upper + 1`, through one block of each.
  struct Coupling
  {
    int particle, upper, upper_block, lower_block;
  };
  std::vector<Coupling> couplings_;
  Eigen::VectorXd diagonal_, off_diagonal_;  // of J W J^T
  Eigen::VectorXd inverse_pivots_, lower_;   // D^-1 and the sub-diagonal of L
};

}  // namespace

std::unique_ptr<ConstraintSolver> makeTridiagonalSolver(const Model& model)
{
  return std::make_unique<TridiagonalSolver>(model);
}

}  // namespace constrained_particles
