#include "stabilization.hpp"

#include "solvers/solver.hpp"
#include "stages.hpp"

#include <cmath>

namespace constrained_particles
{
void baumgarteBias(const StepSettings& settings, RowData& rows)
{
  const double omega = 2.0 * M_PI * settings.baumgarte_frequency;
  const double damping = 2.0 * settings.baumgarte_damping_ratio * omega;
  rows.bias = damping * rows.velocity + (omega * omega) * rows.value;
}

ProjectionReport projectPositions(const Model& model, Data& data, double time, Points& positions,
                                  double tolerance, int max_iterations)
{
  ProjectionReport report;
  imposeEliminated(model, data, time, &positions, nullptr);
  const int m = model.numRows();
  for (int iteration = 0; m > 0; ++iteration)
  {
    rowStage(model, data, time, positions, data.stages.zero, data.rows);
    report.max_position_error = data.rows.max_violation;
    report.converged = report.max_position_error <= tolerance;
    if (report.converged || iteration >= max_iterations ||
        !std::isfinite(report.max_position_error))
      break;
    // dp = -W J^T (J W J^T)^-1 C
    data.rhs = data.rows.value;
    report.singular |= correctAlongRows(model, data, positions);
    report.iterations = iteration + 1;
  }
  return report;
}

bool correctAlongRows(const Model& model, Data& data, Points& out)
{
  const bool singular = factorizeRows(model, data).singular;
  data.solver().solveInPlace(data.rhs);
  addInverseMassJacobianTranspose(model, data.rows, data.rhs, -1.0, out);
  return singular;
}

double projectVelocities(const Model& model, Data& data, double time, const Points& positions,
                         Points& velocities, bool rows_current, bool measure_change, bool* singular)
{
  imposeEliminated(model, data, time, nullptr, &velocities);
  if (model.numRows() == 0)
    return 0.0;
  // dv = -W J^T (J W J^T)^-1 (J v + dC/dt); only J (and dC/dt) is needed, not Jdot v
  if (!rows_current)
    rowStage(model, data, time, positions, velocities, data.rows);
  multiplyJacobian(model, data.rows, velocities, data.rhs);
  if (model.hasCarriers())
    data.rhs += data.rows.time_rate;  // a carried shape's contact moves with it
  // the change is J^T-shaped: when measured, track its size separately, not as a difference of
  // velocities
  Points& change = data.stages.change;
  if (measure_change)
    change.setZero();
  const bool was_singular = correctAlongRows(model, data, measure_change ? change : velocities);
  if (singular)
    *singular = was_singular;
  if (!measure_change)
    return 0.0;
  velocities += change;
  return change.colwise().norm().maxCoeff();
}

ProjectionReport shakePositions(const Model& model, Data& data, double time,
                                const Points& reference, Points& positions, double tolerance,
                                int max_iterations, Points* corrections)
{
  ProjectionReport report;
  imposeEliminated(model, data, time, &positions, nullptr);
  if (model.numRows() == 0)
    return report;
  // directions W J(reference)^T stay fixed; J W J^T at the reference approximates the Jacobian
  rowStage(model, data, time, reference, data.stages.zero, data.rows);
  report.singular = factorizeRows(model, data).singular;
  for (int iteration = 0;; ++iteration)
  {
    // the trial rows give C only; the directions stay those of the reference
    evaluateRowRecords(model, time, positions, data.stages.zero, data.trial_rows, &data.counters,
                       false, &reference, &data.carriers);
    report.max_position_error = data.trial_rows.max_violation;
    report.converged = report.max_position_error <= tolerance;
    if (report.converged || iteration >= max_iterations ||
        !std::isfinite(report.max_position_error))
      break;
    data.rhs = data.trial_rows.value;
    data.solver().solveInPlace(data.rhs);
    addInverseMassJacobianTranspose(model, data.rows, data.rhs, -1.0, positions);
    if (corrections)
      addInverseMassJacobianTranspose(model, data.rows, data.rhs, -1.0, *corrections);
    report.iterations = iteration + 1;
  }
  if (!report.converged && std::isfinite(report.max_position_error))
  {
    const ProjectionReport shake = report;
    Points& before = data.stages.p_unprojected;
    if (corrections)
      before = positions;
    report = projectPositions(model, data, time, positions, tolerance, max_iterations);
    report.iterations += shake.iterations;
    report.singular = report.singular || shake.singular;  // either solve's warning stands
    if (corrections)
      *corrections += positions - before;
  }
  return report;
}

ProjectionReport projectStep(const Model& model, Data& data, ForwardPath path, double time,
                             Points& positions, Points& velocities, double tolerance,
                             int max_iterations)
{
  switch (path)
  {
    case ForwardPath::FusedChain:
      return chainProjectStep(model, data, time, positions, velocities, tolerance, max_iterations);
    case ForwardPath::FusedTree:
      return treeProjectStep(model, data, time, positions, velocities, tolerance, max_iterations);
    case ForwardPath::FusedContactTree:
      return contactTreeProjectStep(model, data, time, positions, velocities, tolerance,
                                    max_iterations);
    case ForwardPath::Generic:
      break;
  }
  const ProjectionReport report =
      projectPositions(model, data, time, positions, tolerance, max_iterations);
  return finishProjection(model, data, time, positions, velocities, true, false, report);
}

ProjectionReport fusedProjectStep(const Model& model, Data& data, double time, Points& positions,
                                  Points& velocities, double tolerance, int max_iterations,
                                  const FusedProjection& fused)
{
  ProjectionReport report;
  imposeEliminated(model, data, time, &positions, nullptr);
  imposeEliminated(model, data, time, nullptr, &velocities);
  bool factorised = false;
  double min_ratio = 1.0;
  for (int iteration = 0;; ++iteration)
  {
    factorised = fused.sweep(model, data, time, positions, velocities, min_ratio);
    fused.count_rows(model, data);
    // singular: the generic fallbacks below read every row's C and diagonal, which the sweep
    // does not store (evaluated at zero velocities, as projectPositions evaluates them)
    if (!factorised)
      evaluateRowRecords(model, time, positions, data.stages.zero, data.rows, nullptr, true,
                         nullptr, &data.carriers);
    report.max_position_error = data.rows.max_violation;
    report.converged = report.max_position_error <= tolerance;
    if (report.converged || iteration >= max_iterations ||
        !std::isfinite(report.max_position_error))
      break;
    // dp = -W J^T (J W J^T)^-1 C
    if (factorised)
    {
      countFusedFactorization(model, data, min_ratio);
      fused.correct(model, data, data.rhs, positions);
    }
    else
    {
      data.rhs = data.rows.value;
      report.singular |= correctAlongRows(model, data, positions);
    }
    report.iterations = iteration + 1;
  }
  // dv = -W J^T (J W J^T)^-1 J v at the final rows
  if (factorised)
  {
    countFusedFactorization(model, data, min_ratio);
    fused.correct(model, data, data.fused.velocity_rhs, velocities);
  }
  else
  {
    multiplyJacobian(model, data.rows, velocities, data.rhs);
    if (model.hasCarriers())
      data.rhs += data.rows.time_rate;
    report.singular |= correctAlongRows(model, data, velocities);
  }
  // the factorisation at the state's final positions serves the next step's first stage
  FactorizationCache& cache = data.fused.factorization;
  cache.state_version = factorised && &positions == &data.state.positions ? data.stateVersion() : 0;
  cache.time = time;
  cache.min_pivot_ratio = min_ratio;
  data.statistics.projection.merge(report);
  return report;
}

ProjectionReport finishProjection(const Model& model, Data& data, double time,
                                  const Points& positions, Points& velocities, bool rows_current,
                                  bool measure_change, ProjectionReport report)
{
  bool singular = false;
  report.max_velocity_change = projectVelocities(model, data, time, positions, velocities,
                                                 rows_current, measure_change, &singular);
  report.singular |= singular;
  data.statistics.projection.merge(report);
  return report;
}

}  // namespace constrained_particles
