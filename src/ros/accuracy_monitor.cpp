#include "constrained_particles/ros/accuracy_monitor.hpp"

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
int AccuracyMonitor::stepsToNextSample(std::uint64_t steps, int chunk) const
{
  if (!window_ || window_->recorded >= static_cast<int>(window_->sample_steps.size()))
    return chunk;
  return static_cast<int>(std::min<std::uint64_t>(
      static_cast<std::uint64_t>(chunk), window_->sample_steps[window_->recorded] - steps));
}

void AccuracyMonitor::addLiveCpu(double seconds)
{
  if (window_)
    window_->live_cpu += seconds;
}

bool AccuracyMonitor::record(const State& state)
{
  if (!window_ || window_->recorded >= static_cast<int>(window_->sample_steps.size()) ||
      state.steps != window_->sample_steps[window_->recorded])
    return false;
  window_->live[window_->recorded++] = state.positions;
  return true;
}

void AccuracyMonitor::abandon()
{
  reference_now_.reset();
  waiting_since_ = -1.0;
  if (!window_)
    return;
  window_.reset();
  ++abandoned_windows_;
  if (shadow_)
    shadow_->cancel();
}

std::uint64_t AccuracyMonitor::skippedWindows(double now, double window) const
{
  if (!(window > 0.0))
    return skipped_windows_;
  double behind_since = waiting_since_;  // no window open: the shadow still busy
  if (window_ && window_->recorded == static_cast<int>(window_->sample_steps.size()))
    behind_since = window_->sample_times.back();  // live done, the shadow not yet
  if (behind_since < 0.0 || now <= behind_since)
    return skipped_windows_;
  return skipped_windows_ + static_cast<std::uint64_t>(std::floor((now - behind_since) / window));
}

bool AccuracyMonitor::update(const State& now, bool stepping, const StepSettings& settings,
                             double window, double publish_rate, int num_particles,
                             const std::shared_ptr<const SceneDescription>& scene,
                             double clock_base)
{
  bool reported = false;
  if (window_ && shadow_)
  {
    Window& w = *window_;
    // compare what both sides have; the shadow never holds up stepping
    const int both = std::min(w.recorded, shadow_->ready());
    for (; w.compared < both; ++w.compared)
    {
      const int k = w.compared;
      auto reference = std::make_shared<const Points>(shadow_->take(k));
      w.errors[k] = (w.live[k] - *reference).colwise().norm().maxCoeff();
      w.live[k] = Points();
      if (w.sample_steps[k] == now.steps)
        reference_now_ = reference;
    }
    const int samples = static_cast<int>(w.sample_steps.size());
    if (w.compared == samples)
    {
      auto report = std::make_shared<AccuracyReport>();
      report->serial = report_ ? report_->serial + 1 : 1;
      report->window_start = w.start_time;
      report->window = w.sample_times.back() - w.start_time;
      report->stamp = clock_base + w.sample_times.back();
      report->integrator = w.settings.integrator;
      report->stabilization = w.settings.stabilization;
      report->dt = w.settings.dt;
      report->sample_times = w.sample_times;
      report->position_errors = w.errors;
      report->position_error = w.errors.back();
      report->error_growth_rate = report->position_error / report->window;
      report->live_cpu_per_sim_second = w.live_cpu / report->window;
      report->reference_cpu_per_sim_second = shadow_->cpuSeconds() / report->window;
      report->windows = ++windows_;
      skipped_windows_ = skippedWindows(now.time, window);
      report->skipped = skipped_windows_;
      report->abandoned = abandoned_windows_;
      report_ = report;
      window_.reset();
      reported = true;
    }
    else if (!shadow_->busy() && shadow_->ready() < samples)
    {
      // the shadow gave up (its failure says why): this window cannot be measured
      abandon();
    }
  }
  // the next window starts from the state now, when there is stepping to measure
  if (window_ || !(window > 0.0) || !stepping)
    return reported;
  if (!shadow_)
    shadow_ = std::make_unique<ShadowReference>();
  if (shadow_->busy())
  {
    if (waiting_since_ < 0.0)
      waiting_since_ = now.time;
    return reported;
  }
  if (waiting_since_ >= 0.0)
  {
    // the windows that would have run while the shadow was busy
    skipped_windows_ = skippedWindows(now.time, window);
    waiting_since_ = -1.0;
  }
  open(now, settings, window, publish_rate, num_particles, scene);
  return reported;
}

void AccuracyMonitor::open(const State& now, const StepSettings& settings, double window,
                           double publish_rate, int num_particles,
                           const std::shared_ptr<const SceneDescription>& scene)
{
  Window w;
  w.settings = settings;
  const double dt = w.settings.dt;
  const int wanted_samples = num_particles > MANY_PARTICLES
                                 ? MIN_WINDOW_SAMPLES
                                 : static_cast<int>(std::lround(window * publish_rate));
  const auto steps = static_cast<std::uint64_t>(std::max(1L, std::lround(window / dt)));
  const auto samples = static_cast<int>(
      std::min<std::uint64_t>(steps, static_cast<std::uint64_t>(std::clamp(
                                         wanted_samples, MIN_WINDOW_SAMPLES, MAX_WINDOW_SAMPLES))));
  w.start_time = now.time;
  w.start_steps = now.steps;
  for (int k = 1; k <= samples; ++k)
  {
    const std::uint64_t offset =
        (steps * static_cast<std::uint64_t>(k)) / static_cast<std::uint64_t>(samples);
    w.sample_steps.push_back(now.steps + offset);
    w.sample_times.push_back(now.time + static_cast<double>(offset) * dt);
  }
  w.live.assign(samples, Points());
  w.errors.assign(samples, 0.0);
  ShadowReference::Job job;
  job.scene = scene;
  job.base = w.settings;
  job.start = now;
  job.sample_times = w.sample_times;
  if (shadow_->start(std::move(job)))
    window_ = std::move(w);
}

}  // namespace constrained_particles
