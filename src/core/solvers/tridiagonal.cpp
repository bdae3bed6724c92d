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
  explicit TridiagonalSolver(const Model& model) : ConstraintSolver(SolveMethod::Tridiagonal)
  {
    const int m = model.numRows();
    inverse_pivots_.setZero(m);
    lower_.setZero(std::max(m - 1, 0));
    // a free particle shared by rows r and r + 1 couples them
    for (const SharedParticle& shared : sharedParticles(model))
      couplings_.push_back(Coupling{ shared.particle, shared.earlier.row, shared.earlier.block,
                                     shared.later.block });
    std::stable_sort(couplings_.begin(), couplings_.end(),
                     [](const Coupling& x, const Coupling& y) { return x.upper < y.upper; });
    // rows k - 1 and k share couplings_[coupling_start_[k - 1] .. coupling_start_[k])
    coupling_start_.assign(std::max(m, 1), 0);
    for (const Coupling& c : couplings_)
      ++coupling_start_[c.upper + 1];
    for (int k = 1; k < m; ++k)
      coupling_start_[k] += coupling_start_[k - 1];
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
  void assemble(const Model& model, const RowData& rows) override
  {
    // the diagonal comes with the rows (RowData::diagonal); the off-diagonal entries are formed
    // in the factorisation's own sweep, from the particles adjacent rows share
    rows_ = &rows;
    w_ = &model.inverseMasses();
  }

  double maxDiagonal() const override
  {
    return rows_->diagonal.size() > 0 ? rows_->diagonal.maxCoeff() : 0.0;
  }

  Pivots factorizeShifted(double delta) override
  {
    const Eigen::VectorXd& diagonal = rows_->diagonal;
    const std::vector<Vec3>& jacobian = rows_->jacobian;
    const std::vector<double>& w = *w_;
    const int m = static_cast<int>(diagonal.size());
    // the ratio of the unregularised attempt says how singular the system is
    double min_ratio = 1.0;
    for (int k = 0; k < m; ++k)
    {
      const double d = diagonal[k] + delta;
      double pivot = d;
      if (k > 0)
      {
        // (J W J^T)_{k-1,k}: what rows k - 1 and k share through common free particles
        double off = 0.0;
        for (int next = coupling_start_[k - 1]; next < coupling_start_[k]; ++next)
        {
          const Coupling& c = couplings_[next];
          off += w[c.particle] * jacobian[c.upper_block].dot(jacobian[c.lower_block]);
        }
        lower_[k - 1] = off * inverse_pivots_[k - 1];
        pivot -= lower_[k - 1] * off;
      }
      if (!takePivot(pivot, d, delta, min_ratio))
        return { true, min_ratio };
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
  std::vector<int> coupling_start_;         // couplings_ of rows (k - 1, k) start at [k - 1]
  const RowData* rows_ = nullptr;           // the rows of the last assembly
  const std::vector<double>* w_ = nullptr;  // inverse masses
  Eigen::VectorXd inverse_pivots_, lower_;  // D^-1 and the sub-diagonal of L
};

}  // namespace

std::unique_ptr<ConstraintSolver> makeTridiagonalSolver(const Model& model)
{
  return std::make_unique<TridiagonalSolver>(model);
}

}  // namespace constrained_particles
