// One row (a bead on a surface, a particle on a plane): lambda = b / (J W J^T), no matrix.
#include "solver.hpp"

#include <algorithm>

namespace constrained_particles
{
namespace
{
class SingleRowSolver : public ConstraintSolver
{
public:
  SingleRowSolver() : ConstraintSolver(SolveMethod::Single)
  {
  }

  void solveInPlace(Eigen::VectorXd& b) const override
  {
    b[0] *= inverse_pivot_;
  }

protected:
  void assemble(const Model& /*model*/, const RowData& rows) override
  {
    // J W J^T = sum over the row's blocks of w_i |J_i|^2, evaluated with the row
    diagonal_ = rows.diagonal[0];
  }

  double maxDiagonal() const override
  {
    return diagonal_;
  }

  Pivots factorizeShifted(double delta) override
  {
    const double pivot = diagonal_ + delta;
    const bool singular = isSingularPivot(pivot, diagonal_ + delta);
    inverse_pivot_ = 1.0 / std::max(pivot, delta);
    return { singular, diagonal_ > 0.0 ? 1.0 : 0.0 };
  }

private:
  double diagonal_ = 0.0;
  double inverse_pivot_ = 0.0;
};

}  // namespace

std::unique_ptr<ConstraintSolver> makeSingleRowSolver(const Model& /*model*/)
{
  return std::make_unique<SingleRowSolver>();
}

}  // namespace constrained_particles
