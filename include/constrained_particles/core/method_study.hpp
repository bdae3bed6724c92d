/// @file method_study.hpp
/// @brief What accuracy costs on one scene: runs a list of methods (integrator, stabilisation,
/// dt, tolerance) over a horizon from a start state and measures each against a reference
/// (dopri5 at a tight tolerance with projection, cross-checked by a second reference with a
/// different step sequence, whose difference is the reference's own error). The node's
/// ~compare_methods action and the offline benchmark ask the same question; this answers it on
/// the user's own scene. Eigen and the standard library only; synchronous (the caller chooses
/// the thread), cancellable within a run.
#pragma once

#include "constrained_particles/core/anchor_track.hpp"
#include "constrained_particles/core/limits.hpp"
#include "constrained_particles/core/scene.hpp"
#include "constrained_particles/core/settings.hpp"
#include "constrained_particles/core/types.hpp"

#include <atomic>
#include <functional>
#include <string>
#include <vector>

namespace constrained_particles
{
constexpr double DEFAULT_STUDY_HORIZON = 1.0;        ///< [s]
constexpr double DEFAULT_STUDY_ERROR_TARGET = 1e-6;  ///< [m]
/// The reference: dopri5 + projection at these tolerances and output step (the check takes half
/// the output step and ten times the tolerance: the same sequence would agree whatever its error).
constexpr double STUDY_REFERENCE_TOLERANCE = 1e-13;   ///< dopri5 adaptive_tolerance [1]
constexpr double STUDY_REFERENCE_PROJECTION = 1e-13;  ///< projection_tolerance [m]
constexpr double STUDY_REFERENCE_DT = 1e-3;           ///< output step [s]
/// The reference's output step in a scene with contacts [s]: an impact or a contact's change is
/// found at a step's end or start (contact.hpp), so the reference's own error is of order its
/// step there, whatever its tolerance; 10 us finds them 100 times closer than at STUDY_REFERENCE_DT
/// (at 100 times its cost).
constexpr double STUDY_CONTACT_REFERENCE_DT = 1e-5;
/// A run whose timed part took less CPU than this is repeated (3 runs, median) [s].
constexpr double STUDY_REPEAT_BELOW_CPU = 0.05;

/// One method a study runs.
struct StudyMethod
{
  std::string integrator = "rk4";  ///< a name of integratorTable()
  Stabilization stabilization = Stabilization::Projection;
  double dt = 1e-3;        ///< step [s], in limits::DT
  double tolerance = 0.0;  ///< adaptive integrators only: adaptive_tolerance [1]; 0 = the base's
};

/// "rk4 + projection, dt 0.001" (with "tol 1e-08" for adaptive integrators).
std::string studyMethodLabel(const StudyMethod& method);

/// Every fixed-step integrator x stabilisation (one entry for those that project by themselves)
/// at four dt decades around `dt` (10 dt, dt, dt/10, dt/100, shifted to stay in limits::DT),
/// then every adaptive integrator + projection at tolerances 1e-4, 1e-6, 1e-8, 1e-10 with the
/// largest of those dt as its output step.
std::vector<StudyMethod> studyDefaultMethods(double dt);

/// What to study.
struct StudyRequest
{
  double horizon = 0.0;              ///< [s]; 0 = DEFAULT_STUDY_HORIZON
  std::vector<StudyMethod> methods;  ///< empty = studyDefaultMethods(base.dt)
  double error_target = 0.0;         ///< [m]; 0 = DEFAULT_STUDY_ERROR_TARGET
  /// Everything else a run takes from here (sub-steps, projection and Baumgarte settings): the
  /// settings the user runs with.
  StepSettings base;
  /// The carried obstacles' tracks (Simulator::carriers()): each run's obstacles rest where
  /// these have them at the start (their holders' later motion is not known to a study).
  std::vector<AnchorTrack> carriers;
};

/// @throws InvalidInput naming the field ("horizon", "error_target", "methods",
/// "methods[2].integrator", "methods[2].dt", "methods[2].tolerance") and its valid values
void validateStudyRequest(const StudyRequest& request);

/// One method's run.
struct StudyRun
{
  StudyMethod method;
  double position_error = 0.0;           ///< max_i |p_i - p_ref_i| at the run's end [m]
  double max_constraint_error = 0.0;     ///< largest |C| seen over the run (sampled) [m]
  double energy_drift = 0.0;             ///< largest |E(t) - E(0)| over the run (sampled) [J]
  double cpu_time_per_sim_second = 0.0;  ///< thread CPU of stepping alone (median of 3 if short)
  long steps = 0;                        ///< steps of dt taken
  long substeps = 0;                     ///< accepted sub-steps (stability splits and retakes)
  bool finite = true;      ///< false: the run blew up or a check failed; error unknown
  std::string failure;     ///< why it stopped early, if it did
  double end_time = 0.0;   ///< nominal end: start + steps dt (not the summed clock) [s]
  Points final_positions;  ///< at end_time (3 x n) [m]
};

/// A study's outcome.
struct StudyResult
{
  std::vector<StudyRun> runs;  ///< in request order (fewer if cancelled)
  /// Max over the runs' end times of |reference - check reference| [m]: errors below it are not
  /// resolved.
  double reference_error = 0.0;
  double reference_cpu_time_per_sim_second = 0.0;
  /// The reference at start + horizon (3 x n) [m]: where the ghosts of a diagram or a test go.
  Points reference_positions;
  /// Index of the cheapest finite run whose position_error meets the target (and is resolved:
  /// the target is above reference_error); -1 if none.
  int recommended = -1;
  double horizon = 0.0;       ///< as run [s]
  double error_target = 0.0;  ///< as run [m]
  bool cancelled = false;
};

/// Progress: called before each run (done of total finished, `current` about to run) and once at
/// the end (current empty).
using StudyProgress = std::function<void(int done, int total, const std::string& current)>;

/// Runs `request` on `scene` from `start` (its time kept: driven motion continues from it).
/// `cancel` (may be null) is polled between runs and inside them, every few milliseconds: a
/// cancelled study returns at once with the runs it finished.
/// Source: the work-precision method of Hairer, Norsett & Wanner, Solving ODEs I, II.1.
/// @throws InvalidInput from validateStudyRequest or the scene; std::runtime_error if the
/// reference itself fails (its message says how)
StudyResult runMethodStudy(const Scene& scene, const State& start, const StudyRequest& request,
                           const StudyProgress& progress = nullptr,
                           const std::atomic<bool>* cancel = nullptr);

/// The study as CSV: a header line, then one line per run (error, costs, recommendation flag).
std::string studyCsv(const StudyResult& result);

}  // namespace constrained_particles
