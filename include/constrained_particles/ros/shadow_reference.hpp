/// @file shadow_reference.hpp
/// @brief The live accuracy estimate's reference: a thread of its own that runs dopri5 +
/// projection at a tight tolerance from a start state to a list of sample times, so the runner
/// can compare its live states with it. The runner never waits for it: it asks whether samples
/// are ready. Needs no ROS.
#pragma once

#include "constrained_particles/core/settings.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace constrained_particles
{
/// Lowers the calling thread's scheduling priority (nice 10, Linux: per thread), so work beside
/// the live simulation (a shadow reference, a method study) yields the cores to its stepping.
void lowerThreadPriority();

class ShadowReference
{
public:
  /// dopri5's adaptive_tolerance for the shadow [1] (the study's reference takes 1e-13 and a
  /// check; live, a window must cost less than it lasts).
  static constexpr double TOLERANCE = 1e-12;
  /// Output steps are at most this long, so dopri5's guards see a short span [s].
  static constexpr double MAX_OUTPUT_STEP = 1e-2;

  struct Job
  {
    std::shared_ptr<const SceneDescription> scene;
    StepSettings base;  ///< the live settings: what the reference does not set itself
    State start;
    std::vector<double> sample_times;  ///< ascending, after start.time [s]
  };

  ShadowReference();
  ~ShadowReference();
  ShadowReference(const ShadowReference&) = delete;
  ShadowReference& operator=(const ShadowReference&) = delete;

  /// True while a job runs (a new one must wait).
  bool busy() const;
  /// Starts `job`. @return false (nothing started) if busy
  bool start(Job job);
  /// Abandons the running job (the thread drops it at its next check, within milliseconds).
  void cancel();
  /// Samples computed so far of the current or last job.
  int ready() const;
  /// The reference positions (3 x n) [m] at sample `k` < ready(); moved out (empty after).
  Points take(int k);
  /// Thread CPU time the current or last job took [s].
  double cpuSeconds() const;
  /// Why the last job stopped early ('' if it did not).
  std::string failure() const;

private:
  void loop();

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<Job> job_;  // waiting to start
  bool busy_ = false, stopping_ = false;
  std::atomic<bool> cancel_{ false };
  std::vector<Points> samples_;
  int ready_ = 0;
  double cpu_ = 0.0;
  std::string failure_;
  std::thread thread_;  // last: starts once the members above exist
};

}  // namespace constrained_particles
