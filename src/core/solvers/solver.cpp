#include "solver.hpp"

namespace constrained_particles
{
SolveReport ConstraintSolver::factorize(const Model& model, const RowData& rows,
                                        EffectCounters& counters)
{
  ++counters.factorizations[static_cast<int>(method_)];
  SolveReport report;
  report.method = method_;
  assemble(model, rows);
  const Pivots first = factorizeShifted(0.0);
  report.min_pivot_ratio = first.min_pivot_ratio;
  if (!first.singular)
    return report;
  report.singular = true;
  const double max_diagonal = maxDiagonal();
  report.regularization = max_diagonal > 0.0 ? SINGULAR_REGULARIZATION * max_diagonal : 1.0;
  factorizeShifted(report.regularization);
  return report;
}

double maxParticleRowWeight(const Model& model, const RowData& rows)
{
  const auto& w = model.inverseMasses();
  const auto& start = model.incidenceStart();
  const auto& incidence = model.incidence();
  double max_diagonal = 0.0;
  for (int i = 0; i < model.numParticles(); ++i)
    for (int a = start[i]; a < start[i + 1]; ++a)
      max_diagonal = std::max(max_diagonal, w[i] * rows.jacobian[incidence[a].block].squaredNorm());
  return max_diagonal;
}

std::unique_ptr<ConstraintSolver> makeSolver(const Model& model)
{
  switch (model.solveMethod())
  {
    case SolveMethod::Single:
      return makeSingleRowSolver(model);
    case SolveMethod::Tridiagonal:
      return makeTridiagonalSolver(model);
    case SolveMethod::Tree:
      return makeTreeSolver(model);
    case SolveMethod::Sparse:
      return makeSparseSolver(model);
    case SolveMethod::Dense:
      return makeDenseSolver(model);
    case SolveMethod::None:
    case SolveMethod::Automatic:
      break;
  }
  return nullptr;
}

}  // namespace constrained_particles
