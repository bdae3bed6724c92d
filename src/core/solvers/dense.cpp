// Dense LDL^T with pivoting (Eigen), O(m^3): the reference the other solves are tested against,
// and the benchmark's baseline.
#include "solver.hpp"

#include <Eigen/Cholesky>

namespace constrained_particles
{
namespace
{
class DenseSolver : public ConstraintSolver
{
public:
  explicit DenseSolver(const Model& model) : ConstraintSolver(SolveMethod::Dense)
  {
    assembled_.setZero(model.numRows(), model.numRows());
    shifted_.setZero(model.numRows(), model.numRows());
  }

  void solveInPlace(Eigen::VectorXd& b) const override
  {
    solveWith(ldlt_, b);
  }

protected:
  void assemble(const Model& model, const RowData& rows) override
  {
    const auto& w = model.inverseMasses();
    const auto& start = model.incidenceStart();
    const auto& incidence = model.incidence();
    assembled_.setZero();
    for (int i = 0; i < model.numParticles(); ++i)
      for (int a = start[i]; a < start[i + 1]; ++a)
        for (int b = start[i]; b < start[i + 1]; ++b)
          assembled_(incidence[a].row, incidence[b].row) +=
              w[i] * rows.jacobian[incidence[a].block].dot(rows.jacobian[incidence[b].block]);
    // a switched-off contact row (zero blocks) is the identity row: its multiplier is 0
    for (std::size_t r = 0; r < rows.inactive.size(); ++r)
      if (rows.inactive[r])
        assembled_(r, r) = 1.0;
    max_diagonal_ = assembled_.rows() > 0 ? assembled_.diagonal().maxCoeff() : 0.0;
  }

  double maxDiagonal() const override
  {
    return max_diagonal_;
  }

  Pivots factorizeShifted(double delta) override
  {
    shifted_ = assembled_;
    shifted_.diagonal().array() += delta;
    ldlt_.compute(shifted_);
    // with pivoting the order of D is not the row order: compare with the largest diagonal
    const double min_pivot = shifted_.rows() > 0 ? ldlt_.vectorD().minCoeff() : 1.0;
    const double min_ratio = max_diagonal_ > 0.0 ? min_pivot / max_diagonal_ : 0.0;
    return { !(ldlt_.info() == Eigen::Success && min_ratio > SINGULAR_PIVOT_RATIO), min_ratio };
  }

private:
  Eigen::MatrixXd assembled_, shifted_;
  double max_diagonal_ = 0.0;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
};

}  // namespace

std::unique_ptr<ConstraintSolver> makeDenseSolver(const Model& model)
{
  return std::make_unique<DenseSolver>(model);
}

}  // namespace constrained_particles
