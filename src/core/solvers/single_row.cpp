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
  void solveInPlace(Eigen::VectorXd& b) const override
  {
    b[0] *= inverse_pivot_;
  }

protected:
  SolveMethod method() const override
  {
    return SolveMethod::Single;
  }

  double assemble(const Model& model, const RowData& rows) override
  {
    // J W J^T = sum over the row's blocks of w_i |J_i|^2
    const auto& w = model.inverseMasses();
    const auto& particle = model.blockParticle();
    diagonal_ = 0.0;
    for (int b = 0; b < model.numBlocks(); ++b)
      diagonal_ += w[particle[b]] * rows.jacobian[b].squaredNorm();
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
