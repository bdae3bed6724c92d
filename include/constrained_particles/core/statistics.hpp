/// @file statistics.hpp
/// @brief What the stepper reports: per factorisation, per projection, per effect, and merged
/// over a batch of steps (MuJoCo keeps its warnings and solver statistics in mjData likewise).
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/model.hpp"

#include <array>
#include <cstdint>

namespace constrained_particles
{
/// Pivots below this fraction of their diagonal entry mark J W J^T as singular.
constexpr double SINGULAR_PIVOT_RATIO = 1e-12;
/// Regularization added when singular, relative to the largest diagonal entry.
constexpr double SINGULAR_REGULARIZATION = 1e-9;

/// Outcome of one factorisation of J W J^T.
struct SolveReport
{
  SolveMethod method = SolveMethod::None;
  bool singular = false;         ///< (near) singular: solved with regularization added
  double min_pivot_ratio = 1.0;  ///< smallest pivot relative to its diagonal entry
  double regularization = 0.0;   ///< delta added to the diagonal (0 unless singular)
  /// The tree elimination lost its precision (a particle's own rows all but lock it along a row
  /// to its parent) and the sparse LDL^T of J W J^T gave this solve instead.
  bool fallback = false;
};

/// Outcome of a projection of a state onto the constraints.
struct ProjectionReport
{
  int iterations = 0;              ///< Newton (or SHAKE) iterations taken
  bool converged = true;           ///< max position error <= tolerance
  double max_position_error = 0;   ///< after projection [m]
  double max_displacement = 0;     ///< largest distance a particle moved [m]
  double max_velocity_change = 0;  ///< largest velocity change of a particle [m/s]
  bool singular = false;           ///< J W J^T was singular during the projection
  /// Simulator::setObstacles: the steps a shape took to its new place (1: at once)
  int change_steps = 1;
};

/// How often each effect and each solve was evaluated: proof that a scene pays only for what it
/// lists. Counted where the work is dispatched, not derived from the scene.
struct EffectCounters
{
  std::array<std::uint64_t, NUM_FORCE_KINDS> forces{};  ///< force records accumulated, by kind
  /// constraint records evaluated, by kind: records for row kinds, applications of the imposed
  /// motion for eliminated kinds
  std::array<std::uint64_t, NUM_CONSTRAINT_KINDS> constraints{};
  std::array<std::uint64_t, NUM_SOLVE_METHODS> factorizations{};  ///< by SolveMethod

  /// Evaluations of the force kind `Kind` (e.g. QuadraticDragForce).
  template <typename Kind>
  std::uint64_t forceCount() const
  {
    return forces[Force(Kind{}).index()];
  }
  /// Evaluations of the constraint kind `Kind` (e.g. SurfaceConstraint).
  template <typename Kind>
  std::uint64_t constraintCount() const
  {
    return constraints[Constraint(Kind{}).index()];
  }
  /// Factorizations by `method`.
  std::uint64_t factorizationCount(SolveMethod method) const
  {
    return factorizations[static_cast<int>(method)];
  }
  /// Counts since `earlier` (a copy taken before).
  EffectCounters since(const EffectCounters& earlier) const;
  /// Adds `other`'s counts (two batches counted as one).
  void add(const EffectCounters& other);
};

/// Calls visit(kind, count) for each force kind, then each constraint kind, counted at least
/// once (kind as scene files name it: "gravity", "link", ...).
template <typename Visit>
void forEachEffectCount(const EffectCounters& counters, Visit&& visit)
{
  for (std::size_t k = 0; k < counters.forces.size(); ++k)
    if (counters.forces[k] > 0)
      visit(KindNames<Force>::value[k], counters.forces[k]);
  for (std::size_t k = 0; k < counters.constraints.size(); ++k)
    if (counters.constraints[k] > 0)
      visit(KindNames<Constraint>::value[k], counters.constraints[k]);
}

/// The worst and the totals over factorisations.
struct SolveStatistics
{
  SolveMethod method = SolveMethod::None;  ///< the model's method
  long factorizations = 0;       ///< how many were taken (reused ones: reused_factorizations)
  long singular_count = 0;       ///< how many were singular
  bool singular = false;         ///< any was
  double min_pivot_ratio = 1.0;  ///< the smallest pivot ratio of any
  double regularization = 0.0;   ///< the largest delta added
  long fallbacks = 0;            ///< how many the tree solve handed to the sparse one
  /// Constraint-force solves that took the last projection's factorisation at the same
  /// positions instead of a new one (a fused chain's or tree's first stage, chain_stages.cpp,
  /// tree_stages.cpp); not in
  /// `factorizations`
  long reused_factorizations = 0;

  /// One factorisation's report.
  void merge(const SolveReport& report)
  {
    ++factorizations;
    mergeWorst(report);
  }
  /// A solve with a factorisation already taken (`report` is its): counted as reused, its worst
  /// values kept as if it were new, so a batch reports the pivots its solves used.
  void mergeReused(const SolveReport& report)
  {
    ++reused_factorizations;
    mergeWorst(report);
  }
  /// The method, fallback, singularity and worst values of one report (both merges).
  void mergeWorst(const SolveReport& report)
  {
    method = report.method;
    fallbacks += report.fallback ? 1 : 0;
    singular_count += report.singular ? 1 : 0;
    singular = singular || report.singular;
    min_pivot_ratio =
        report.min_pivot_ratio < min_pivot_ratio ? report.min_pivot_ratio : min_pivot_ratio;
    regularization =
        report.regularization > regularization ? report.regularization : regularization;
  }
  /// Takes in another batch's statistics: totals add, worst values stay worst.
  void merge(const SolveStatistics& other);
};

/// The worst and the totals over projections (and velocity Verlet's SHAKE/RATTLE).
struct ProjectionStatistics
{
  long projections = 0;            ///< position projections taken
  long iterations = 0;             ///< Newton or SHAKE iterations, in all
  int max_iterations = 0;          ///< the most any one projection took
  bool converged = true;           ///< every projection reached its tolerance
  double max_position_error = 0;   ///< largest error any projection left [m]
  double max_velocity_change = 0;  ///< largest velocity change of a particle [m/s]
  bool singular = false;           ///< any was singular

  void merge(const ProjectionReport& report);
  /// Takes in another batch's statistics: totals add, worst values stay worst.
  void merge(const ProjectionStatistics& other);
};

/// The checks a step (or sub-step) must pass to be accepted (Simulator::step).
enum class StepCheck
{
  None,           ///< passed every check
  NonFinite,      ///< a position or velocity is not finite
  Projection,     ///< a projection (or SHAKE) did not reach projection_tolerance
  EnergyRise,     ///< a conservative scene's energy rose by more than ENERGY_RISE_TOLERANCE
  SingularSolve,  ///< J W J^T became singular where the previous step's was not
  AdaptiveGuard,  ///< dopri5 hit its internal step guard
  EnergyBudget,   ///< the energy ledger's residual passed energy_budget of its scale
  /// a hold (a tracked record with max_force) would carry more than its max_force, or holds
  /// made the step impossible (its projection or solve failed at every split and the fallback):
  /// the step is put back and StepStatistics::hold names the hold, for the caller to let go
  HoldForce,
};
constexpr int NUM_STEP_CHECKS = 8;
/// "none", "non_finite", "projection", "energy_rise", "singular_solve", "adaptive_guard",
/// "energy_budget", "hold_force".
const char* stepCheckName(StepCheck check);

/// Statistics of a batch of steps (Simulator::step(count)): the worst and the totals over all of
/// them, not only the last.
struct StepStatistics
{
  long steps = 0;                   ///< steps taken
  SolveStatistics solve;            ///< every constraint-force and projection factorisation
  ProjectionStatistics projection;  ///< every projection
  long internal_steps = 0;          ///< dopri5: accepted internal steps (fixed-step: 1 per step)
  /// dopri5: internal steps rejected and retaken smaller; and every internal step of a step
  /// that failed a check and was retaken (Simulator::step)
  long rejected_internal_steps = 0;
  /// dopri5: dt ends taken unchecked because a guard was hit (over 100,000 internal steps in one
  /// dt, or an internal step under 1e-12 dt): the tolerance cannot be met at this dt
  long forced_internal_steps = 0;
  long substeps = 0;        ///< accepted sub-steps (1 per step when none was split)
  int max_substeps = 0;     ///< the most sub-steps any one step was split into
  long rejected_steps = 0;  ///< steps (or splits of them) rejected and retaken finer
  /// steps the chosen integrator could not take stably within max_substeps, taken by the
  /// stiff-safe fast_projection instead (Simulator::step)
  long stiff_steps = 0;
  /// contact scenes: constraint-force stages (every attempt's, and the active set's rounds)
  /// whose friction iteration stopped short (stalled: no fixed point, or at
  /// MAX_FRICTION_ITERATIONS) still changing by more than FRICTION_REPORT_TOLERANCE (the last
  /// iterate was taken); docs/physics.md, "Contact"
  long unconverged_friction = 0;
  /// rejections by the check that failed (index: StepCheck), each retaken with twice the
  /// sub-steps; the stability estimate's splits are not rejections
  std::array<long, NUM_STEP_CHECKS> rejections{};
  /// the check the finest allowed split (and the stiff fallback) still failed (StepCheck::None:
  /// every step accepted); that step was put back and the batch ended (with max_substeps = 1
  /// the step stands and the batch goes on: the checks only report). The node faults on it
  StepCheck failed_check = StepCheck::None;
  /// failed_check HoldForce: the hold (its Model::tracked() index) that carried too much, the
  /// force it would have carried [N] (infinite: the holds made the step impossible) and the
  /// check the step failed then (StepCheck::None: it passed, over the limit)
  int hold = -1;
  double hold_force = 0.0;
  StepCheck hold_failure = StepCheck::None;
  double max_frequency = 0;  ///< largest estimated omega_max [rad/s] (stability.hpp)
  EffectCounters effects;    ///< evaluations during the batch
  /// The largest constraint violation at the batch's final state, as the last accepted step's
  /// projection measured it [m] (what diagnostics() would find, without evaluating the rows
  /// again); -1 where no projection measured it (another stabilisation, an integrator that
  /// holds the constraints itself, no step accepted)
  double end_position_error = -1.0;

  /// Takes in the statistics of a later batch, as if both had been one.
  void merge(const StepStatistics& later);
};

/// CPU time of the calling thread [s] (POSIX clock_gettime(CLOCK_THREAD_CPUTIME_ID)): what a
/// study, a shadow reference or a live window cost, not the time of the threads beside it.
double threadCpuSeconds();

}  // namespace constrained_particles
