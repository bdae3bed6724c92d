#include "stages.hpp"

#include "solvers/solver.hpp"
#include "stabilization.hpp"

namespace constrained_particles
{
void evaluateRowRecords(const Model& model, double time, const Points& positions,
                        const Points& velocities, RowData& rows, EffectCounters* counters)
{
  const Scene& scene = model.scene();
  const EffectContext context{ scene.surfaces, time };
  double max_violation = 0.0;
  for (const RowRecord& record : model.rowRecords())
  {
    const Constraint& constraint = scene.constraints[record.constraint];
    evaluateRows(
        constraint, context, positions, velocities,
        RowBlock{ rows.value.data() + record.first_row, rows.jdot_v.data() + record.first_row,
                  rows.violation.data() + record.first_row,
                  rows.jacobian.data() + record.first_block });
    if (counters)
      ++counters->constraints[constraint.index()];
    for (int r = record.first_row; r < record.first_row + record.rows; ++r)
      max_violation = worseError(max_violation, rows.violation[r]);
  }
  rows.max_violation = max_violation;
}

void rowStage(const Model& model, Data& data, double time, const Points& positions,
              const Points& velocities, RowData& rows)
{
  evaluateRowRecords(model, time, positions, velocities, rows, &data.counters);
}

void appliedForceStage(const Model& model, Data& data, const Points& positions,
                       const Points& velocities)
{
  const Scene& scene = model.scene();
  data.applied_forces.setZero();
  for (const Force& force : scene.forces)
  {
    accumulateForce(force, scene.masses, positions, velocities, data.applied_forces);
    ++data.counters.forces[force.index()];
  }
}

void rowVelocityStage(const Model& model, Data& data, const Points& velocities)
{
  multiplyJacobian(model, data.rows, velocities, data.rows.velocity);
}

SolveReport factorizeRows(const Model& model, Data& data)
{
  const SolveReport report = data.solver().factorize(model, data.rows, data.counters);
  data.statistics.solve.merge(report);
  return report;
}

SolveReport constraintForceStage(const Model& model, Data& data, double time,
                                 const Eigen::VectorXd* bias)
{
  const Scene& scene = model.scene();
  const auto& w = model.inverseMasses();
  const int n = model.numParticles();
  const int m = model.numRows();
  // a0: what each particle would do without the rows
  Points& a0 = data.unconstrained_accelerations;
  for (int i = 0; i < n; ++i)
    a0.col(i) = w[i] * data.applied_forces.col(i);
  for (int k : model.eliminated())
  {
    const Constraint& constraint = scene.constraints[k];
    a0.col(eliminatedParticle(constraint)) = imposedMotion(constraint, time).acceleration;
    ++data.counters.constraints[constraint.index()];
  }

  // (J W J^T) lambda = -(Jdot v + J a0) - bias
  SolveReport report;
  report.method = model.solveMethod();
  data.constraint_forces.setZero();
  if (m > 0)
  {
    report = factorizeRows(model, data);
    multiplyJacobian(model, data.rows, a0, data.rhs);
    data.rhs = -(data.rows.jdot_v + data.rhs);
    if (bias)
      data.rhs -= *bias;
    data.solver().solveInPlace(data.rhs);
    data.multipliers.head(m) = data.rhs;
    addJacobianTranspose(model, data.rows, data.rhs, 1.0, data.constraint_forces);
  }

  // an eliminated particle's reaction makes it follow its imposed motion: m a - f - J^T lambda
  const auto& eliminated = model.eliminated();
  for (std::size_t k = 0; k < eliminated.size(); ++k)
  {
    const int i = eliminatedParticle(scene.constraints[eliminated[k]]);
    const Vec3 reaction =
        scene.masses[i] * a0.col(i) - data.applied_forces.col(i) - data.constraint_forces.col(i);
    data.constraint_forces.col(i) += reaction;
    data.multipliers.segment<3>(m + 3 * static_cast<int>(k)) = reaction;
  }
  return report;
}

void accelerationStage(const Model& model, Data& data, Points& accelerations)
{
  const auto& w = model.inverseMasses();
  const Points& a0 = data.unconstrained_accelerations;
  for (int i = 0; i < model.numParticles(); ++i)
    accelerations.col(i) = a0.col(i) + w[i] * data.constraint_forces.col(i);
}

SolveReport forward(const Model& model, Data& data, const StepSettings& settings, double time,
                    Points& positions, Points& velocities, Points& accelerations)
{
  imposeEliminated(model, data, time, &positions, &velocities);
  rowStage(model, data, time, positions, velocities, data.rows);
  appliedForceStage(model, data, positions, velocities);
  const Eigen::VectorXd* bias = nullptr;
  if (settings.stabilization == Stabilization::Baumgarte && model.numRows() > 0)
  {
    rowVelocityStage(model, data, velocities);
    baumgarteBias(settings, data.rows);
    bias = &data.rows.bias;
  }
  const SolveReport report = constraintForceStage(model, data, time, bias);
  accelerationStage(model, data, accelerations);
  return report;
}

void imposeEliminated(const Model& model, Data& data, double time, Points* positions,
                      Points* velocities)
{
  const Scene& scene = model.scene();
  for (int k : model.eliminated())
  {
    const Constraint& constraint = scene.constraints[k];
    const ImposedMotion motion = imposedMotion(constraint, time);
    const int i = eliminatedParticle(constraint);
    if (positions)
      positions->col(i) = motion.position;
    if (velocities)
      velocities->col(i) = motion.velocity;
    ++data.counters.constraints[constraint.index()];
  }
}

void multiplyJacobian(const Model& model, const RowData& rows, const Points& x, Eigen::VectorXd& y)
{
  const auto& start = model.rowStart();
  const auto& particle = model.blockParticle();
  const int m = model.numRows();
  y.resize(m);  // a no-op when it has its size already
  for (int r = 0; r < m; ++r)
  {
    double sum = 0.0;
    for (int b = start[r]; b < start[r + 1]; ++b)
      sum += rows.jacobian[b].dot(x.col(particle[b]));
    y[r] = sum;
  }
}

void multiplyJacobianInverseMass(const Model& model, const RowData& rows, const Points& x,
                                 Eigen::VectorXd& y)
{
  const auto& start = model.rowStart();
  const auto& particle = model.blockParticle();
  const auto& w = model.inverseMasses();
  const int m = model.numRows();
  y.resize(m);
  for (int r = 0; r < m; ++r)
  {
    double sum = 0.0;
    for (int b = start[r]; b < start[r + 1]; ++b)
      sum += w[particle[b]] * rows.jacobian[b].dot(x.col(particle[b]));
    y[r] = sum;
  }
}

void addJacobianTranspose(const Model& model, const RowData& rows, const Eigen::VectorXd& lambda,
                          double scale, Points& out)
{
  const auto& start = model.rowStart();
  const auto& particle = model.blockParticle();
  const int m = model.numRows();
  for (int r = 0; r < m; ++r)
  {
    const double s = scale * lambda[r];
    for (int b = start[r]; b < start[r + 1]; ++b)
      out.col(particle[b]) += s * rows.jacobian[b];
  }
}

void addInverseMassJacobianTranspose(const Model& model, const RowData& rows,
                                     const Eigen::VectorXd& lambda, double scale, Points& out)
{
  const auto& start = model.rowStart();
  const auto& particle = model.blockParticle();
  const auto& w = model.inverseMasses();
  const int m = model.numRows();
  for (int r = 0; r < m; ++r)
  {
    const double s = scale * lambda[r];
    for (int b = start[r]; b < start[r + 1]; ++b)
      out.col(particle[b]) += (w[particle[b]] * s) * rows.jacobian[b];
  }
}

void multiplyJWJt(const Model& model, const RowData& rows, const Eigen::VectorXd& x,
                  Eigen::VectorXd& y)
{
  // y = J (W (J^T x))
  Points force = Points::Zero(3, model.numParticles());
  addInverseMassJacobianTranspose(model, rows, x, 1.0, force);
  y.resize(model.numRows());
  multiplyJacobian(model, rows, force, y);
}

}  // namespace constrained_particles
