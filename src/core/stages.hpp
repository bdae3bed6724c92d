/// @file stages.hpp
/// @brief The named stages of one evaluation, in MuJoCo's shape (engine_forward.c):
///   rowStage -> appliedForceStage -> rowVelocityStage -> constraintForceStage -> accelerationStage
/// and forward(), which calls them in order. Witkin's formulation: with W = M^-1, applied forces
/// f and a0 = W f (an eliminated particle: its imposed acceleration, which data.free_accelerations
/// leaves at 0, W = 0 there, and which enters J a0 through the particle's blocks),
///   (J W J^T) lambda = -(Jdot v + J a0) - bias,   f_c = J^T lambda,   a = a0 + W f_c,
/// bias = 2 zeta omega Cdot + omega^2 C under Baumgarte (stabilization.hpp), else 0.
/// Also the Jacobian products the stages and the stabilisation share. Private to the core.
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/forward_path.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"

#include <tuple>
#include <type_traits>

namespace constrained_particles
{
/// The obstacles where they are at `time` [s]: the scene's surfaces and the carried shapes on
/// their tracks (Data::carriers), for the contact rows evaluated outside the stages.
inline EffectContext contextAt(const Model& model, const Data& data, double time)
{
  return EffectContext{ model.scene().surfaces, time, nullptr, &data.carriers };
}

/// Evaluates every row record at (p, v) and time t into `rows`: C, J, Jdot v, the metric
/// violations and their max, and (if `diagonals`) each row's diagonal entry of J W J^T. Counts
/// each record in `counters` if given. `frame_positions`, `carriers`: see EffectContext.
/// Stateless otherwise.
void evaluateRowRecords(const Model& model, double time, const Points& positions,
                        const Points& velocities, RowData& rows, EffectCounters* counters,
                        bool diagonals = true, const Points* frame_positions = nullptr,
                        const std::vector<AnchorTrack>* carriers = nullptr);

/// A switched-off unilateral row as every path writes it (contact.hpp): an identity row, its C,
/// Jdot v, violation and dC/dt 0, its `blocks` Jacobian blocks from `first_block` 0 and (if
/// `diagonals`) its diagonal 1, which the dense and sparse solves put on J W J^T themselves.
inline void writeIdentityRow(RowData& rows, int row, int first_block, int blocks, bool diagonals)
{
  rows.value[row] = rows.jdot_v[row] = rows.violation[row] = rows.time_rate[row] = 0.0;
  for (int k = 0; k < blocks; ++k)
    rows.jacobian[first_block + k].setZero();
  if (diagonals)
    rows.diagonal[row] = 1.0;
}

/// Stage 1, rows at positions: evaluateRowRecords into `rows`, counted in data.counters.
void rowStage(const Model& model, Data& data, double time, const Points& positions,
              const Points& velocities, RowData& rows);

/// Stage 2, applied forces: data.applied_forces = f(p, v) [N], only the forces the scene lists,
/// and data.free_accelerations = a0 = W f [m/s^2] (g itself under gravity alone).
void appliedForceStage(const Model& model, Data& data, const Points& positions,
                       const Points& velocities);

/// Stage 3, row velocities: data.rows.velocity = Cdot = J v. Only Baumgarte reads it.
void rowVelocityStage(const Model& model, Data& data, const Points& velocities);

/// Stage 4, constraint forces: factorises J W J^T (data.rows), solves for lambda with the
/// optional bias (m) and fills data.multipliers and data.constraint_forces, eliminated reactions
/// included. The eliminated particles' accelerations are data.imposed (imposeEliminated).
SolveReport constraintForceStage(const Model& model, Data& data, const Eigen::VectorXd* bias);

/// After the multipliers: each eliminated particle's reaction m a - f - J^T lambda, added to
/// data.constraint_forces and written after the m multipliers in data.multipliers.
void addEliminatedReactions(const Model& model, Data& data);

/// Stages 1, 2, 4 and 5 for a fused chain (Model::fusedChain(), no Baumgarte bias), in two
/// sweeps over the rows (the down sweep also sets each particle's acceleration)
/// (chain_stages.cpp): the same data (of the links' rows only the Jacobian, each row's first
/// block in data.fused.chain_jacobian: C, Jdot v, the diagonals and violations are read by the
/// projections and Baumgarte only, after evaluating rows of their own; a surface row's C, Jdot v,
/// diagonal and violation in data.rows), counters and report as the generic stages; a singular
/// pivot hands the stage to them. At data.state.positions and the time its last fused projection
/// factorised at (FusedWorkspace::factorization) it solves with that factorisation, counted as
/// reused; every call uses or discards it (used once). Eliminated motion already imposed.
SolveReport chainForward(const Model& model, Data& data, double time, const Points& positions,
                         const Points& velocities, Points& accelerations);

/// Stages 1, 2, 4 and 5 for a fused tree (Model::fusedTree(), no Baumgarte bias), in two sweeps
/// over the links in elimination order (tree_stages.cpp): the same data as chainForward's but
/// none of the rows (each link's d is in data.fused.tree_jacobian), the same counters and report as
/// the generic stages, and the same motion to rounding; a singular pivot hands the stage to them.
/// At the state its last fused projection factorised, it solves with that factorisation, as
/// chainForward does. Eliminated motion already imposed.
SolveReport treeForward(const Model& model, Data& data, double time, const Points& positions,
                        const Points& velocities, Points& accelerations);

/// Stages 1, 2, 4 and 5 for a contact tree (Model::fusedContactTree(), no Baumgarte bias), in
/// the fused tree's two sweeps (tree_stages.cpp), each contact's row one more row of one block:
/// data as the generic stages write it but for the links' rows (d in data.fused.tree_jacobian;
/// the contacts' and surface rows are in data.rows), the contacts' forces (recordNormalForces), the
/// same counters and report, the same motion to rounding. Not of the stage afterwards: the links'
/// rows in data.rows, rows.max_violation, data.rhs (by place), the friction iteration's buffers and
/// the solver's factorisation (every reader evaluates and factorises its own). A stage whose
/// friction must be solved for (frictionAtRounding) or whose pivot is singular is taken by the
/// generic stages (contactForceStage). Eliminated motion already imposed.
SolveReport contactTreeForward(const Model& model, Data& data, double time, const Points& positions,
                               const Points& velocities, Points& accelerations);

/// Counts a fused sweep's factorisation (model.solveMethod()'s) and merges its report (the
/// smallest pivot / diagonal entry `min_ratio`), as factorizeRows() does the solver's.
SolveReport countFusedFactorization(const Model& model, Data& data, double min_ratio);

/// Where a fused down sweep reads a free particle's a0 [m/s^2]: under gravity alone
/// (Data::applied_forces_are_gravity) the one vector g, which every free particle's entry of
/// data.free_accelerations holds exactly (appliedForceStage), so at 10^5 particles the sweep
/// does not stream 2.4 MB of copies of it; else each particle's entry. A held particle's reads
/// g, not its entry's 0: right only where its acceleration is set afterwards (heldAccelerations),
/// so not for right-hand sides, which read data.free_accelerations.
struct FreeAccelerations
{
  FreeAccelerations(const Model& model, const Data& data)
    : base(data.applied_forces_are_gravity
               ? std::get<GravityForce>(model.scene().forces.front()).acceleration.data()
               : data.free_accelerations.data())
    , stride(data.applied_forces_are_gravity ? 0 : 3)
  {
  }
  const double* of(int i) const
  {
    return base + stride * i;
  }
  const double* base;
  int stride;
};

/// A fused down sweep's J^T lambda share `force` [N] of one row on particle i (3 x n `forces`),
/// and its acceleration a0 + w f_c once no row is left (`closes`): accelerationStage's
/// expression, a particle at a time while its forces are in cache. `opens`: the first share
/// (written, not added: the generic stages' 0 + force, the same but -0 where they give +0).
inline void settleParticle(int i, bool opens, bool closes, double w, const Vec3& force,
                           const FreeAccelerations& a0, double* forces, double* accelerations)
{
  Eigen::Map<Vec3> fc(forces + 3 * i);
  if (opens)
    fc = force;
  else
    fc += force;
  if (closes)
    Eigen::Map<Vec3>(accelerations + 3 * i) = Eigen::Map<const Vec3>(a0.of(i)) + w * fc;
}

/// Stage 5, accelerations: a = a0 + W f_c into `accelerations` [m/s^2] (3 x n); an
/// eliminated particle's is its imposed acceleration.
void accelerationStage(const Model& model, Data& data, Points& accelerations);

/// accelerationStage's last part: each eliminated particle's acceleration is its imposed one.
void heldAccelerations(const Model& model, const Data& data, Points& accelerations);

/// For a fused forward stage at (time, positions): whether the last fused projection's
/// factorisation is of them (FactorizationCache: then its L and D serve the stage's solve, as
/// J W J^T depends on the positions only); used once either way (the stage uses or overwrites it).
inline bool takeFactorizationAtState(Data& data, double time, const Points& positions)
{
  FactorizationCache& cache = data.fused.factorization;
  const bool at_state = cache.state_version == data.stateVersion() &&
                        positions.data() == data.state.positions.data() && time == cache.time;
  cache.state_version = 0;
  return at_state;
}

/// A fused forward stage's frame (chain_stages.cpp, tree_stages.cpp), the stages' rows, solve and
/// accelerations in sweeps: the applied forces, the rows counted once (`count_rows()`, as rowStage
/// counts them, whichever path finishes the stage), `sweep_up(reused, min_ratio)` (false at a
/// singular pivot; `reused`: the last fused projection's factorisation is of these positions, so
/// only the right-hand side is new, counted as a reused factorisation), `sweep_down()` (the
/// multipliers, constraint forces and accelerations), then the eliminated reactions and
/// accelerations. A singular pivot hands the stage to the generic stages, which regularise it.
template <typename CountRows, typename SweepUp, typename SweepDown>
inline SolveReport fusedForward(const Model& model, Data& data, double time,
                                const Points& positions, const Points& velocities,
                                Points& accelerations, CountRows&& count_rows, SweepUp&& sweep_up,
                                SweepDown&& sweep_down)
{
  appliedForceStage(model, data, positions, velocities);
  count_rows();
  double min_ratio = 1.0;
  SolveReport report;
  if (takeFactorizationAtState(data, time, positions))
  {
    sweep_up(std::true_type{}, min_ratio);
    report.method = model.solveMethod();
    report.min_pivot_ratio = data.fused.factorization.min_pivot_ratio;
    data.statistics.solve.mergeReused(report);
  }
  else if (sweep_up(std::false_type{}, min_ratio))
    report = countFusedFactorization(model, data, min_ratio);
  else
  {
    evaluateRowRecords(model, time, positions, velocities, data.rows, nullptr, true, nullptr,
                       &data.carriers);
    report = constraintForceStage(model, data, nullptr);
    accelerationStage(model, data, accelerations);
    return report;
  }
  sweep_down();
  addEliminatedReactions(model, data);
  heldAccelerations(model, data, accelerations);
  return report;
}

/// Every stage at (t, p, v): positions and velocities of eliminated particles are first set to
/// their imposed motion at t (the stage buffers are the integrator's), then rows, forces, row
/// velocities and bias (Baumgarte only), constraint forces and accelerations.
/// Merges the solve report into data.statistics.
SolveReport forward(const Model& model, Data& data, const StepSettings& settings, double time,
                    Points& positions, Points& velocities, Points& accelerations);

/// Evaluates every eliminated record's motion at `time` into data.imposed and sets its particle's
/// position and velocity (each if given) to it. Counts each application.
void imposeEliminated(const Model& model, Data& data, double time, Points* positions,
                      Points* velocities);

/// Assembles and factorises J W J^T from data.rows (data.solver()), merging the report into
/// data.statistics.
SolveReport factorizeRows(const Model& model, Data& data);

/// Calls fn(table) with every row kind's table of KindRecords (eliminated kinds make no rows), in
/// registry order: a loop per kind with no dispatch per record.
template <typename Fn>
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
inline void
forEachRowTable(const Model& model, Fn&& fn)
{
  std::apply(
      [&](const auto&... tables)
      {
        (
            [&](const auto& table)
            {
              using Kind = typename std::decay_t<decltype(table)>::value_type::KindType;
              if constexpr (!Kind::ELIMINATED)
                fn(table);
            }(tables),
            ...);
      },
      model.kindTables());
}

/// Calls fn(row, first_block, width) for every row, kind by kind, with `width` (its blocks) a
/// std::integral_constant: loops over a row's blocks have a fixed trip count the compiler
/// unrolls, where one generic loop per row costs more than the arithmetic in it.
template <typename Fn>
#if defined(__GNUC__)
__attribute__((always_inline))  // one loop per kind, inlined into each product: see above
#endif
inline void
forEachRow(const Model& model, Fn&& fn)
{
  forEachRowTable(model,
                  [&](const auto& table)
                  {
                    using Kind = typename std::decay_t<decltype(table)>::value_type::KindType;
                    for (const auto& entry : table)
                      for (int r = 0; r < Kind::ROWS; ++r)
                        fn(entry.first_row + r, entry.first_block + r * Kind::PARTICLES,
                           std::integral_constant<int, Kind::PARTICLES>{});
                  });
}

// --- Jacobian products over the rows' blocks (J is m x 3n, blocks per model.rowStart()) ---

/// y = J x (m), x one 3-vector per particle.
void multiplyJacobian(const Model& model, const RowData& rows, const Points& x, Eigen::VectorXd& y);
/// y = J W x (m): eliminated particles contribute nothing.
void multiplyJacobianInverseMass(const Model& model, const RowData& rows, const Points& x,
                                 Eigen::VectorXd& y);
/// out += scale J^T lambda, on every particle a row touches.
void addJacobianTranspose(const Model& model, const RowData& rows, const Eigen::VectorXd& lambda,
                          double scale, Points& out);
/// out += scale W J^T lambda (zero on eliminated particles).
void addInverseMassJacobianTranspose(const Model& model, const RowData& rows,
                                     const Eigen::VectorXd& lambda, double scale, Points& out);
/// y = (J W J^T) x (m), straight from the blocks (residuals in tests).
void multiplyJWJt(const Model& model, const RowData& rows, const Eigen::VectorXd& x,
                  Eigen::VectorXd& y);

}  // namespace constrained_particles
