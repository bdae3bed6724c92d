/// @file accuracy_monitor.hpp
/// @brief The live accuracy monitor (~accuracy_window; docs/accuracy.md): the live run's
/// positions at sample steps of each window against a shadow reference run from the window's
/// start on its own thread.
#pragma once

#include "constrained_particles/core/settings.hpp"
#include "constrained_particles/core/types.hpp"
#include "constrained_particles/ros/shadow_reference.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace constrained_particles
{
/// The live method's error over one window against the shadow reference (~accuracy).
struct AccuracyReport
{
  std::uint64_t serial = 0;  ///< one more per report, from 1
  double stamp = 0;          ///< Snapshot::stamp at the window's end [s]
  double window_start = 0;   ///< sim time [s]
  double window = 0;         ///< length: whole live steps [s]
  std::string integrator;    ///< the live method over the window
  Stabilization stabilization = Stabilization::Projection;
  double dt = 0;                            ///< [s]
  std::vector<double> sample_times;         ///< [s]
  std::vector<double> position_errors;      ///< max_i |p_live - p_ref| at each sample time [m]
  double position_error = 0;                ///< at the window's end [m]
  double error_growth_rate = 0;             ///< position_error / window [m/s]
  double live_cpu_per_sim_second = 0;       ///< live stepping's thread CPU [s/s]
  double reference_cpu_per_sim_second = 0;  ///< the shadow's [s/s]
  std::uint64_t windows = 0;                ///< measured since start
  std::uint64_t skipped = 0;                ///< not measured: the shadow was still busy
  std::uint64_t abandoned =
      0;  ///< cut short by a reset, scene change, teleport, fault, reconfigure
};

/// Windows of ~accuracy_window [s] sim time, each with samples the live run records as it steps
/// and the shadow reference computes alongside; never holds up stepping (a window the shadow is
/// still busy for is skipped and counted). Used on the runner's thread only.
class AccuracyMonitor
{
public:
  /// Samples per window: ~publish_rate per second of window, within these (the fewest above
  /// MANY_PARTICLES particles, where each sample copies every position).
  static constexpr int MIN_WINDOW_SAMPLES = 4, MAX_WINDOW_SAMPLES = 64;
  static constexpr int MANY_PARTICLES = 10000;

  /// What the runner's step loop asks between chunks.
  bool open() const
  {
    return window_.has_value();
  }
  /// The steps the live run may take from `steps` before the next sample, at most `chunk`.
  int stepsToNextSample(std::uint64_t steps, int chunk) const;
  /// Adds live stepping's thread CPU [s] to the open window.
  void addLiveCpu(double seconds);
  /// After a chunk: records `state` if it is the open window's next sample; true if it was.
  bool record(const State& state);
  /// The shadow's positions at the current state, when compared at it (ghosts in rviz).
  const std::shared_ptr<const Points>& referenceNow() const
  {
    return reference_now_;
  }
  /// The state moved on from the last comparison (each chunk).
  void clearReferenceNow()
  {
    reference_now_.reset();
  }

  /// Compares the samples both sides have, reports a finished window and, while `stepping`
  /// (running, not pushed or dragged: the shadow feels neither), opens the next one at `now`.
  /// `clock_base` turns sim time into Snapshot::stamp. True if a report finished.
  bool update(const State& now, bool stepping, const StepSettings& settings, double window,
              double publish_rate, int num_particles,
              const std::shared_ptr<const SceneDescription>& scene, double clock_base);
  /// Ends the open window unmeasured (the state or settings changed under it).
  void abandon();
  /// Windows of `window` [s] skipped so far, with those passing up to sim time `now` [s] while
  /// the shadow is behind.
  std::uint64_t skippedWindows(double now, double window) const;
  /// The last report (null before the first).
  const std::shared_ptr<const AccuracyReport>& report() const
  {
    return report_;
  }

private:
  /// One window: its sample steps and what was measured at them so far.
  struct Window
  {
    double start_time = 0;
    std::uint64_t start_steps = 0;
    std::vector<std::uint64_t> sample_steps;  // absolute step counts
    std::vector<double> sample_times;         // nominal: start + steps dt [s]
    std::vector<Points> live;                 // live positions at each sample, until compared
    std::vector<double> errors;
    int recorded = 0, compared = 0;
    double live_cpu = 0;  // [s]
    StepSettings settings;
  };
  void open(const State& now, const StepSettings& settings, double window, double publish_rate,
            int num_particles, const std::shared_ptr<const SceneDescription>& scene);

  std::optional<Window> window_;
  std::unique_ptr<ShadowReference> shadow_;  // made when a window first opens
  std::shared_ptr<const AccuracyReport> report_;
  std::shared_ptr<const Points> reference_now_;
  std::uint64_t windows_ = 0, skipped_windows_ = 0, abandoned_windows_ = 0;
  double waiting_since_ = -1.0;  // sim time a window was due while the shadow was busy [s]
};

}  // namespace constrained_particles
