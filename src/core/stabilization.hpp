/// @file stabilization.hpp
/// @brief Constraint drift correction, all in one place: the Baumgarte bias that enters the
/// constraint-force stage, Newton projection of positions and velocities after a step, and the
/// SHAKE/RATTLE projections velocity Verlet makes inside its step. Private to the core.
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"

namespace constrained_particles
{
/// rows.bias = 2 zeta omega Cdot + omega^2 C, omega = 2 pi f (Baumgarte 1972): with it the rows
/// obey Cddot + 2 zeta omega Cdot + omega^2 C = 0 instead of Cddot = 0. Reads rows.value and
/// rows.velocity (rowVelocityStage).
void baumgarteBias(const StepSettings& settings, RowData& rows);

/// Moves positions onto C = 0 by Newton steps dp = -W J^T (J W J^T)^-1 C until the largest
/// metric error is below `tolerance` [m] or after `max_iterations`; eliminated particles are put
/// where their kinds hold them at `time`. On return data.rows are evaluated at the result.
ProjectionReport projectPositions(const Model& model, Data& data, double time, Points& positions,
                                  double tolerance, int max_iterations);

/// Removes the constraint-violating velocity, dv = -W J^T (J W J^T)^-1 J v; eliminated particles
/// get their imposed velocity at `time`.
/// @param rows_current data.rows were last evaluated at these positions (as projectPositions
/// leaves them): skip evaluating them again
/// @param measure_change compute the largest velocity change [m/s] (else return 0)
double projectVelocities(const Model& model, Data& data, double time, const Points& positions,
                         Points& velocities, bool rows_current, bool measure_change,
                         bool* singular = nullptr);

/// One projection solve at data.rows: factorises J W J^T, solves for data.rhs in place (the
/// residual on entry: C or J v; the multipliers mu on return) and subtracts W J^T mu from `out`
/// (positions [m] or velocities [m/s]). @return whether the factorisation was singular.
bool correctAlongRows(const Model& model, Data& data, Points& out);

/// A step's projection on `path` (forwardPath(), forward_path.hpp): projectPositions(), then
/// finishProjection() at the final rows without measuring the velocity change; a fused chain
/// takes chainProjectStep(), a fused tree treeProjectStep(), a contact tree
/// contactTreeProjectStep().
ProjectionReport projectStep(const Model& model, Data& data, ForwardPath path, double time,
                             Points& positions, Points& velocities, double tolerance,
                             int max_iterations);

/// projectStep() for a fused chain (chain_stages.cpp): each check's sweep also factorises and
/// forward-substitutes C and J v, so the last check's factorisation projects the velocities;
/// the same motion, counters and statistics as the generic projection, which takes over the
/// solves at a singular pivot.
ProjectionReport chainProjectStep(const Model& model, Data& data, double time, Points& positions,
                                  Points& velocities, double tolerance, int max_iterations);

/// What a fused projection's Newton loop (fusedProjectStep) calls: `sweep` evaluates the rows at
/// the positions, sets data.rows.max_violation, factorises J W J^T and forward-substitutes C
/// into data.rhs and J v into data.fused.velocity_rhs, false at a singular pivot; `count_rows`
/// counts one evaluation of every row as rowStage would; `correct` back-substitutes x in place
/// and subtracts W J^T x from `out`.
struct FusedProjection
{
  bool (*sweep)(const Model& model, Data& data, double time, const Points& positions,
                const Points& velocities, double& min_ratio);
  void (*count_rows)(const Model& model, Data& data);
  void (*correct)(const Model& model, Data& data, Eigen::VectorXd& x, Points& out);
};

/// projectStep()'s loop with `fused`'s sweeps (projectPositions then projectVelocities at the
/// final rows, each check's sweep also factorising, the last check's factorisation projecting the
/// velocities); a singular pivot hands the solves to the generic ones. Merges the report into
/// data.statistics. The last factorisation, if usable and at data.state.positions, is kept for
/// the next stage there (FusedWorkspace::factorization, takeFactorizationAtState).
ProjectionReport fusedProjectStep(const Model& model, Data& data, double time, Points& positions,
                                  Points& velocities, double tolerance, int max_iterations,
                                  const FusedProjection& fused);

/// projectStep() for a fused tree (tree_stages.cpp), as chainProjectStep() for a chain: the same
/// motion to rounding, the same counters and statistics as the generic projection.
ProjectionReport treeProjectStep(const Model& model, Data& data, double time, Points& positions,
                                 Points& velocities, double tolerance, int max_iterations);

/// projectStep() for a contact tree (tree_stages.cpp): treeProjectStep() with each contact's row
/// (at zero velocities, an identity row while it is off, as projectPositions evaluates it; into
/// data.rows) one more row on its particle.
ProjectionReport contactTreeProjectStep(const Model& model, Data& data, double time,
                                        Points& positions, Points& velocities, double tolerance,
                                        int max_iterations);

/// Ends a projection: projectVelocities() (arguments as there), its largest change and any
/// singular solve written into `report`, which is then merged into data.statistics.projection
/// and returned.
ProjectionReport finishProjection(const Model& model, Data& data, double time,
                                  const Points& positions, Points& velocities, bool rows_current,
                                  bool measure_change, ProjectionReport report);

/// SHAKE (Ryckaert, Ciccotti, Berendsen 1977): moves positions onto C = 0 along the fixed
/// directions W J(reference)^T, the directions of the constraint forces of a step that started
/// at `reference`; falls back to projectPositions() if that does not converge in max_iterations.
/// @param corrections if given, the displacement applied is added to it, summed from the small
/// corrections themselves (no cancellation against the positions)
ProjectionReport shakePositions(const Model& model, Data& data, double time,
                                const Points& reference, Points& positions, double tolerance,
                                int max_iterations, Points* corrections);

}  // namespace constrained_particles
