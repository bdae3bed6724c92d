#include "constrained_particles/ros/shadow_reference.hpp"

#include "constrained_particles/core/simulator.hpp"

#include <cmath>

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace constrained_particles
{
void lowerThreadPriority()
{
  // best effort: an unprivileged thread may always lower its own priority
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
}

ShadowReference::ShadowReference() : thread_(&ShadowReference::loop, this)
{
}

ShadowReference::~ShadowReference()
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  cancel_ = true;
  wake_.notify_all();
  thread_.join();
}

bool ShadowReference::busy() const
{
  std::lock_guard<std::mutex> lock(mutex_);
  return busy_;
}

bool ShadowReference::start(Job job)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (busy_)
      return false;
    busy_ = true;
    cancel_ = false;
    samples_.assign(job.sample_times.size(), Points());
    ready_ = 0;
    cpu_ = 0.0;
    failure_.clear();
    job_ = std::move(job);
  }
  wake_.notify_all();
  return true;
}

void ShadowReference::cancel()
{
  cancel_ = true;
}

int ShadowReference::ready() const
{
  std::lock_guard<std::mutex> lock(mutex_);
  return ready_;
}

Points ShadowReference::take(int k)
{
  std::lock_guard<std::mutex> lock(mutex_);
  return std::move(samples_.at(k));
}

double ShadowReference::cpuSeconds() const
{
  std::lock_guard<std::mutex> lock(mutex_);
  return cpu_;
}

std::string ShadowReference::failure() const
{
  std::lock_guard<std::mutex> lock(mutex_);
  return failure_;
}

void ShadowReference::loop()
{
  lowerThreadPriority();
  std::unique_lock<std::mutex> lock(mutex_);
  while (true)
  {
    wake_.wait(lock, [this] { return stopping_ || job_.has_value(); });
    if (stopping_)
      return;
    const Job job = std::move(*job_);
    job_.reset();
    lock.unlock();
    const double begin = threadCpuSeconds();
    std::string failure;
    try
    {
      StepSettings s = job.base;
      s.integrator = "dopri5";
      s.stabilization = Stabilization::Projection;
      s.adaptive_tolerance = TOLERANCE;
      s.projection_tolerance = std::min(s.projection_tolerance, 1e-12);
      const BuiltScene built = buildScene(*job.scene);
      Simulator simulator(built.scene, job.start, s);
      simulator.restoreState(job.start);
      double t = job.start.time;
      for (std::size_t k = 0; k < job.sample_times.size() && !cancel_; ++k)
      {
        // equal output steps that land on the sample time
        const double span = job.sample_times[k] - t;
        const long m = std::max(1L, static_cast<long>(std::ceil(span / MAX_OUTPUT_STEP - 1e-9)));
        s.dt = span / static_cast<double>(m);
        simulator.setStepSettings(s);
        for (long j = 0; j < m && !cancel_; ++j)
        {
          const StepStatistics statistics = simulator.step(1);
          if (statistics.failed_check != StepCheck::None || !isFinite(simulator.state()))
            throw std::runtime_error(std::string("the shadow reference failed step check ") +
                                     stepCheckName(statistics.failed_check) +
                                     " at t = " + formatValue(simulator.state().time) + " s");
          // a step the stiff fallback (first order) took is no reference's
          if (statistics.stiff_steps > 0)
            throw std::runtime_error("the shadow reference could not meet its tolerance at t = " +
                                     formatValue(simulator.state().time) +
                                     " s (a step taken by the stiff fallback)");
        }
        t = job.sample_times[k];
        std::lock_guard<std::mutex> guard(mutex_);
        if (cancel_)
          break;
        samples_[k] = simulator.state().positions;
        ready_ = static_cast<int>(k) + 1;
        cpu_ = threadCpuSeconds() - begin;
      }
    }
    catch (const std::exception& e)
    {
      failure = e.what();
    }
    lock.lock();
    cpu_ = threadCpuSeconds() - begin;
    failure_ = failure;
    busy_ = false;
  }
}

}  // namespace constrained_particles
