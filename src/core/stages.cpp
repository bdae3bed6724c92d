#include "stages.hpp"

#include "constrained_particles/core/diagnostics.hpp"

#include "contact.hpp"
#include "solvers/solver.hpp"
#include "stabilization.hpp"

namespace constrained_particles
{
namespace
{
// One kind's records, with its rows' evaluation inlined: no dispatch per record.
template <typename Kind>
void evaluateKind(const std::vector<KindRecord<Kind>>& table, const Model& model,
                  const EffectContext& context, const Points& positions, const Points& velocities,
                  RowData& rows, bool diagonals, double& max_violation, EffectCounters* counters)
{
  if constexpr (!Kind::ELIMINATED)
  {
    const auto& w = model.inverseMasses();
    const auto& particle = model.blockParticle();
    for (const KindRecord<Kind>& entry : table)
    {
      if constexpr (IsUnilateral<Kind>::value)
      {
        static_assert(Kind::ROWS == 1, "a unilateral kind's row switches on and off whole");
        // switched off: an identity row (contact.hpp), not evaluated (most of a folded rope's
        // near link pairs, a chain's contacts in flight)
        if (rows.inactive[entry.first_row])
        {
          writeIdentityRow(rows, entry.first_row, entry.first_block, Kind::PARTICLES, diagonals);
          continue;
        }
      }
      evaluateRows(
          entry.record, context, positions, velocities,
          RowBlock{ rows.value.data() + entry.first_row, rows.jdot_v.data() + entry.first_row,
                    rows.violation.data() + entry.first_row,
                    rows.jacobian.data() + entry.first_block,
                    rows.time_rate.data() + entry.first_row });
      for (int r = 0; r < Kind::ROWS; ++r)
      {
        const int row = entry.first_row + r, first = entry.first_block + r * Kind::PARTICLES;
        max_violation = worseError(max_violation, rows.violation[row]);
        if (!diagonals)
          continue;
        // the row's diagonal entry of J W J^T, while its blocks are in cache
        double diagonal = 0.0;
        for (int k = 0; k < Kind::PARTICLES; ++k)
          diagonal += w[particle[first + k]] * rows.jacobian[first + k].squaredNorm();
        rows.diagonal[row] = diagonal;
      }
    }
    if (counters)
      counters->constraints[constraintKindIndex<Kind>()] += table.size();
  }
}

// One eliminated kind's records: their motion at `time`, onto the particles they hold.
template <typename Kind>
void imposeKind(const std::vector<KindRecord<Kind>>& table, double time,
                const std::vector<AnchorTrack>& tracks, std::vector<ImposedMotion>& imposed,
                Points* positions, Points* velocities, EffectCounters& counters)
{
  if constexpr (Kind::ELIMINATED)
  {
    for (const KindRecord<Kind>& entry : table)
    {
      // eliminated kinds keep their index in first_row and their particle in first_block
      const ImposedMotion& motion = imposed[entry.first_row] =
          imposedMotionOf(entry.record, time, tracks);
      if (positions)
        positions->col(entry.first_block) = motion.position;
      if (velocities)
        velocities->col(entry.first_block) = motion.velocity;
    }
    counters.constraints[constraintKindIndex<Kind>()] += table.size();
  }
}

}  // namespace

void evaluateRowRecords(const Model& model, double time, const Points& positions,
                        const Points& velocities, RowData& rows, EffectCounters* counters,
                        bool diagonals, const Points* frame_positions,
                        const std::vector<AnchorTrack>* carriers)
{
  const EffectContext context{ model.scene().surfaces, time, frame_positions, carriers };
  double max_violation = 0.0;
  std::apply(
      [&](const auto&... tables)
      {
        (evaluateKind(tables, model, context, positions, velocities, rows, diagonals, max_violation,
                      counters),
         ...);
      },
      model.kindTables());
  rows.max_violation = max_violation;
}

void rowStage(const Model& model, Data& data, double time, const Points& positions,
              const Points& velocities, RowData& rows)
{
  data.noteStateChange();  // its callers may move the positions past any kept factorisation
  evaluateRowRecords(model, time, positions, velocities, rows, &data.counters, true, nullptr,
                     &data.carriers);
}

void appliedForceStage(const Model& model, Data& data, const Points& positions,
                       const Points& velocities)
{
  const Scene& scene = model.scene();
  auto accumulate = [&](auto first, auto end)
  {
    for (; first != end; ++first)
    {
      accumulateForce(*first, scene.masses, positions, velocities, data.applied_forces);
      ++data.counters.forces[first->index()];
    }
  };
  auto first = scene.forces.begin();
  // gravity alone gives m g at every stage: assigned once and kept while nothing else acts (at
  // 10^5 particles each assignment wrote 2.4 MB); still counted per stage, as the stage applies it
  const bool gravity_only = scene.forces.size() == 1 &&
                            std::holds_alternative<GravityForce>(*first) &&
                            data.perturbations.empty();
  if (gravity_only && data.applied_forces_are_gravity)
  {
    ++data.counters.forces[first->index()];
    return;
  }
  data.applied_forces_are_gravity = gravity_only;
  const auto& w = model.inverseMasses();
  Points& a0 = data.free_accelerations;
  if (gravity_only)
  {
    // a0 = g on every free particle, not W (m g): the same vector, so a row between two free
    // particles has J a0 = 0 exactly (Data::applied_forces_are_gravity)
    const GravityForce& gravity = std::get<GravityForce>(*first);
    assignForce(gravity, scene.masses, data.applied_forces);
    ++data.counters.forces[first->index()];
    for (int i = 0; i < model.numParticles(); ++i)
      a0.col(i) = w[i] > 0.0 ? gravity.acceleration : Vec3::Zero();
    data.gravity_force_sum = forceNormSum(data.applied_forces);
    return;
  }
  if (first != scene.forces.end() && std::holds_alternative<GravityForce>(*first))
  {
    // the usual first force sets the accumulator rather than adding to zeros: one pass fewer
    assignForce(std::get<GravityForce>(*first), scene.masses, data.applied_forces);
    ++data.counters.forces[first->index()];
    ++first;
  }
  else
    data.applied_forces.setZero();
  accumulate(first, scene.forces.end());
  accumulate(data.perturbations.begin(), data.perturbations.end());  // from outside, while set
  for (int i = 0; i < model.numParticles(); ++i)
    a0.col(i) = w[i] * data.applied_forces.col(i);
}

void rowVelocityStage(const Model& model, Data& data, const Points& velocities)
{
  multiplyJacobian(model, data.rows, velocities, data.rows.velocity);
  if (model.hasCarriers())
    data.rows.velocity += data.rows.time_rate;  // rows on a moving shape: Cdot = J v + dC/dt
}

SolveReport factorizeRows(const Model& model, Data& data)
{
  const SolveReport report = data.solver().factorize(model, data.rows, data.counters);
  data.statistics.solve.merge(report);
  return report;
}

SolveReport constraintForceStage(const Model& model, Data& data, const Eigen::VectorXd* bias)
{
  const int m = model.numRows();
  // (J W J^T) lambda = -(Jdot v + J a0) - bias, J a0 = J data.free_accelerations (W f, 0 on held
  // particles) + the eliminated particles' imposed accelerations through their blocks
  // (data.imposed, set by imposeEliminated at this time)
  SolveReport report;
  report.method = model.solveMethod();
  data.constraint_forces.setZero();
  if (m > 0)
  {
    report = factorizeRows(model, data);
    // one sweep: rhs_r = -((Jdot v + bias)_r + (J a0)_r), J a0 summed on its own first (the
    // fused chain stages take a link's between free particles under gravity alone as 0)
    const auto& particle = model.blockParticle();
    const RowData& rows = data.rows;
    const Points& a0 = data.free_accelerations;
    Eigen::VectorXd& rhs = data.rhs;
    forEachRow(model,
               [&](int r, int b, auto width)
               {
                 double j_a0 = 0.0;
                 for (int k = 0; k < width; ++k)
                   j_a0 += rows.jacobian[b + k].dot(a0.col(particle[b + k]));
                 double sum = rows.jdot_v[r] + (bias ? (*bias)[r] : 0.0);
                 sum += j_a0;
                 rhs[r] = -sum;
               });
    // the eliminated particles' imposed accelerations, through their blocks
    const auto& block_row = model.blockRow();
    for (const EliminatedBlock& held : model.eliminatedBlocks())
      rhs[block_row[held.block]] -=
          rows.jacobian[held.block].dot(data.imposed[held.eliminated].acceleration);
    data.solver().solveInPlace(data.rhs);
    data.multipliers.head(m) = data.rhs;
    addJacobianTranspose(model, data.rows, data.rhs, 1.0, data.constraint_forces);
  }

  addEliminatedReactions(model, data);
  return report;
}

void addEliminatedReactions(const Model& model, Data& data)
{
  // an eliminated particle's reaction makes it follow its imposed motion: m a - f - J^T lambda
  const Scene& scene = model.scene();
  const int m = model.numRows();
  const auto& held = model.eliminatedParticles();
  for (std::size_t k = 0; k < held.size(); ++k)
  {
    const int i = held[k];
    const Vec3 reaction = scene.masses[i] * data.imposed[k].acceleration -
                          data.applied_forces.col(i) - data.constraint_forces.col(i);
    data.constraint_forces.col(i) += reaction;
    data.multipliers.segment<3>(m + 3 * static_cast<int>(k)) = reaction;
  }
}

void accelerationStage(const Model& model, Data& data, Points& accelerations)
{
  // a = a0 + W f_c; W = 0 on held particles, which take their imposed acceleration
  const auto& w = model.inverseMasses();
  for (int i = 0; i < model.numParticles(); ++i)
    accelerations.col(i) = data.free_accelerations.col(i) + w[i] * data.constraint_forces.col(i);
  heldAccelerations(model, data, accelerations);
}

SolveReport countFusedFactorization(const Model& model, Data& data, double min_ratio)
{
  ++data.counters.factorizations[static_cast<int>(model.solveMethod())];
  SolveReport report;
  report.method = model.solveMethod();
  report.min_pivot_ratio = min_ratio;
  data.statistics.solve.merge(report);
  return report;
}

void heldAccelerations(const Model& model, const Data& data, Points& accelerations)
{
  const auto& held = model.eliminatedParticles();
  for (std::size_t k = 0; k < held.size(); ++k)
    accelerations.col(held[k]) = data.imposed[k].acceleration;
}

SolveReport forward(const Model& model, Data& data, const StepSettings& settings, double time,
                    Points& positions, Points& velocities, Points& accelerations)
{
  imposeEliminated(model, data, time, &positions, &velocities);
  const ForwardPath path = forwardPath(model, settings);
  switch (path)
  {
    case ForwardPath::FusedChain:  // rows, solve and forces in two sweeps (chain_stages.cpp)
      return chainForward(model, data, time, positions, velocities, accelerations);
    case ForwardPath::FusedTree:  // the same in two sweeps, leaves first (tree_stages.cpp)
      return treeForward(model, data, time, positions, velocities, accelerations);
    case ForwardPath::FusedContactTree:  // after the check below: its contact stage's reuse
    case ForwardPath::Generic:
      break;
  }
  // a step's first stage at the state the contact stage has just solved (chooseContactModes)
  StepControl& control = data.control;
  const bool at_state = control.forward_version == data.stateVersion() &&
                        positions.data() == data.state.positions.data() &&
                        velocities.data() == data.state.velocities.data() &&
                        time == control.forward_time;
  control.forward_version = 0;
  if (at_state)
  {
    accelerations = data.accelerations;
    data.statistics.solve.mergeReused(control.forward_report);
    return control.forward_report;
  }
  if (path == ForwardPath::FusedContactTree)  // rows, solve and forces in two sweeps
    return contactTreeForward(model, data, time, positions, velocities, accelerations);
  rowStage(model, data, time, positions, velocities, data.rows);
  appliedForceStage(model, data, positions, velocities);
  const Eigen::VectorXd* bias = nullptr;
  if (settings.stabilization == Stabilization::Baumgarte && model.numRows() > 0)
  {
    rowVelocityStage(model, data, velocities);
    baumgarteBias(settings, data.rows);
    bias = &data.rows.bias;
  }
  // a scene with contacts adds their friction, solved with the rows (contact.hpp)
  const SolveReport report = model.numContacts() > 0
                                 ? contactForceStage(model, data, time, positions, velocities, bias)
                                 : constraintForceStage(model, data, bias);
  accelerationStage(model, data, accelerations);
  return report;
}

void imposeEliminated(const Model& model, Data& data, double time, Points* positions,
                      Points* velocities)
{
  if (model.eliminated().empty())
    return;
  std::apply(
      [&](const auto&... tables)
      {
        (imposeKind(tables, time, data.tracks, data.imposed, positions, velocities, data.counters),
         ...);
      },
      model.kindTables());
}

void multiplyJacobian(const Model& model, const RowData& rows, const Points& x, Eigen::VectorXd& y)
{
  const auto& particle = model.blockParticle();
  y.resize(model.numRows());  // a no-op when it has its size already
  forEachRow(model,
             [&](int r, int b, auto width)
             {
               double sum = 0.0;
               for (int k = 0; k < width; ++k)
                 sum += rows.jacobian[b + k].dot(x.col(particle[b + k]));
               y[r] = sum;
             });
}

void multiplyJacobianInverseMass(const Model& model, const RowData& rows, const Points& x,
                                 Eigen::VectorXd& y)
{
  const auto& particle = model.blockParticle();
  const auto& w = model.inverseMasses();
  y.resize(model.numRows());
  forEachRow(model,
             [&](int r, int b, auto width)
             {
               double sum = 0.0;
               for (int k = 0; k < width; ++k)
                 sum += w[particle[b + k]] * rows.jacobian[b + k].dot(x.col(particle[b + k]));
               y[r] = sum;
             });
}

void addJacobianTranspose(const Model& model, const RowData& rows, const Eigen::VectorXd& lambda,
                          double scale, Points& out)
{
  const auto& particle = model.blockParticle();
  forEachRow(model,
             [&](int r, int b, auto width)
             {
               const double s = scale * lambda[r];
               for (int k = 0; k < width; ++k)
                 out.col(particle[b + k]) += s * rows.jacobian[b + k];
             });
}

void addInverseMassJacobianTranspose(const Model& model, const RowData& rows,
                                     const Eigen::VectorXd& lambda, double scale, Points& out)
{
  const auto& particle = model.blockParticle();
  const auto& w = model.inverseMasses();
  forEachRow(model,
             [&](int r, int b, auto width)
             {
               const double s = scale * lambda[r];
               for (int k = 0; k < width; ++k)
                 out.col(particle[b + k]) += (w[particle[b + k]] * s) * rows.jacobian[b + k];
             });
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
