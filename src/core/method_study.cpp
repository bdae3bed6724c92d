#include "constrained_particles/core/method_study.hpp"

#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace constrained_particles
{
namespace
{

double median(std::vector<double> values)
{
  std::sort(values.begin(), values.end());
  const std::size_t mid = values.size() / 2;
  return values.size() % 2 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
}

double maxDistance(const Points& a, const Points& b)
{
  return (a - b).colwise().norm().maxCoeff();
}

bool cancelled(const std::atomic<bool>* cancel)
{
  return cancel != nullptr && cancel->load();
}

/// Steps of `dt` a run of `horizon` takes: at least one.
long stepsFor(double horizon, double dt)
{
  return std::max(1L, std::lround(horizon / dt));
}

/// Wall-clock-free chunking: chunks of steps that each take about CHUNK_CPU, so a cancel is seen
/// within milliseconds whatever the scene's size.
constexpr double CHUNK_CPU = 5e-3;  // [s]
/// Diagnostics (constraint error, energy) are sampled this many times per run, outside timing.
constexpr long SAMPLES_PER_RUN = 100;

/// Grows or shrinks a chunk towards CHUNK_CPU from the last chunk's time.
long nextChunk(long chunk, double seconds)
{
  if (seconds < 0.5 * CHUNK_CPU)
    return chunk * 2;
  if (seconds > 2.0 * CHUNK_CPU)
    return std::max(1L, chunk / 2);
  return chunk;
}

struct RunOutcome
{
  StudyRun run;
  double cpu = 0.0;  // timed stepping [s]
  bool cancelled = false;
};

// The live run's carried obstacles, each at rest where it is at `time`, onto `simulator`
void restCarriers(Simulator& simulator, const std::vector<AnchorTrack>& carriers, double time)
{
  for (std::size_t k = 0; k < carriers.size() && k < simulator.carriers().size(); ++k)
    simulator.carriers()[k].restAt(carriers[k], time);
}

RunOutcome runOnce(const Scene& scene, const State& start, const StepSettings& settings,
                   double horizon, const std::vector<AnchorTrack>& carriers,
                   const std::atomic<bool>* cancel)
{
  RunOutcome out;
  Simulator simulator(scene, start, settings);
  restCarriers(simulator, carriers, start.time);
  simulator.restoreState(start);  // the start as it is, at its time: no projection at t = 0
  const long steps = stepsFor(horizon, settings.dt);
  const long sample_every = std::max(1L, steps / SAMPLES_PER_RUN);
  const double e0 = simulator.diagnostics().totalEnergy();
  StudyRun& run = out.run;
  long chunk = 1;
  long taken = 0;
  while (taken < steps)
  {
    if (cancelled(cancel))
    {
      out.cancelled = true;
      return out;
    }
    const long to_sample = sample_every - taken % sample_every;
    const long count = std::min({ chunk, steps - taken, to_sample });
    const double begin = threadCpuSeconds();
    const StepStatistics statistics = simulator.step(static_cast<int>(count));
    const double spent = threadCpuSeconds() - begin;
    out.cpu += spent;
    chunk = std::min(nextChunk(chunk, spent), 1L << 20);
    taken += statistics.steps;
    run.substeps += statistics.substeps;
    if (!isFinite(simulator.state()))
    {
      run.finite = false;
      run.failure = "non-finite state at t = " + formatValue(simulator.state().time) + " s";
      break;
    }
    if (statistics.failed_check != StepCheck::None && run.failure.empty())
      run.failure = std::string("step check ") + stepCheckName(statistics.failed_check) +
                    " failed at t = " + formatValue(simulator.state().time) +
                    " s (the node would fault here)";
    if (statistics.steps < count)
    {
      // the check was final: the step was put back and cannot be taken with these settings
      run.finite = false;
      break;
    }
    if (const StepControl& control = simulator.data().control; control.budget_fallback)
    {
      // from here the stiff-safe method takes the steps: what follows is not this method's
      if (run.failure.empty())
        run.failure =
            "energy budget overdrawn at t = " + formatValue(control.budget_fallback_time) +
            " s (the node would hand the run to " + Simulator::STIFF_FALLBACK + ")";
      run.finite = false;
      break;
    }
    if (taken % sample_every == 0 || taken == steps)
    {
      const Diagnostics d = simulator.diagnostics();
      run.max_constraint_error = std::max(run.max_constraint_error, d.max_position_error);
      run.energy_drift = std::max(run.energy_drift, std::abs(d.totalEnergy() - e0));
    }
  }
  run.steps = taken;
  // nominal: the simulator's clock sums dt per step and drifts by round-off (1e-11 s in 1e5 steps)
  run.end_time = start.time + static_cast<double>(taken) * settings.dt;
  run.final_positions = simulator.state().positions;
  return out;
}

/// Reference positions at each of `end_times` (ascending), by dopri5 + projection at
/// `tolerance` with output steps of at most `output_dt`; false if cancelled.
/// @throws std::runtime_error if the reference fails a check or leaves the finite
bool referenceAt(const Scene& scene, const State& start, const StepSettings& base,
                 const std::vector<AnchorTrack>& carriers, const std::vector<double>& end_times,
                 double output_dt, double tolerance, std::vector<Points>& positions, double& cpu,
                 const std::atomic<bool>* cancel)
{
  StepSettings s = base;
  s.integrator = "dopri5";
  s.stabilization = Stabilization::Projection;
  s.adaptive_tolerance = tolerance;
  s.projection_tolerance = STUDY_REFERENCE_PROJECTION;
  s.projection_max_iterations = std::max(s.projection_max_iterations, 50);
  s.dt = std::min(output_dt, std::max(limits::DT.low, end_times.back() - start.time));
  Simulator simulator(scene, start, s);
  restCarriers(simulator, carriers, start.time);
  simulator.restoreState(start);
  positions.clear();
  cpu = 0.0;
  for (const double end : end_times)
  {
    const double span = end - simulator.state().time;
    if (span >= limits::DT.low)
    {
      // equal steps that land on `end`: no sliver of a step at the end of a segment
      const long m = static_cast<long>(std::ceil(span / output_dt - 1e-9));
      s.dt = span / static_cast<double>(m);
      simulator.setStepSettings(s);
      long chunk = 1;
      for (long k = 0; k < m;)
      {
        if (cancelled(cancel))
          return false;
        const long count = std::min(chunk, m - k);
        const double begin = threadCpuSeconds();
        const StepStatistics statistics = simulator.step(static_cast<int>(count));
        const double spent = threadCpuSeconds() - begin;
        cpu += spent;
        chunk = std::min(nextChunk(chunk, spent), 1L << 20);
        k += statistics.steps;
        // a step the stiff fallback (first order) took is no reference's either
        if (statistics.failed_check != StepCheck::None || statistics.stiff_steps > 0 ||
            !isFinite(simulator.state()))
          throw std::runtime_error(
              std::string("the reference (dopri5 + projection, tolerance ") +
              formatValue(tolerance) + ") " +
              (statistics.failed_check != StepCheck::None
                   ? std::string("failed step check ") + stepCheckName(statistics.failed_check)
                   : std::string("needed the stiff fallback")) +
              " at t = " + formatValue(simulator.state().time) +
              " s: this scene cannot be resolved to the reference's tolerance");
      }
    }
    positions.push_back(simulator.state().positions);
  }
  return true;
}

}  // namespace

std::string studyMethodLabel(const StudyMethod& method)
{
  const IntegratorInfo& info = findIntegrator(method.integrator);
  std::string label = method.integrator;
  label += info.holds_constraints ? " (projects itself)"
                                  : std::string(" + ") + stabilizationName(method.stabilization);
  label += ", dt " + formatValue(method.dt);
  if (info.adaptive)
    label += ", tol " + formatValue(method.tolerance);
  return label;
}

std::vector<StudyMethod> studyDefaultMethods(double dt)
{
  // four decades 10 dt .. dt / 100, shifted as a block to stay inside limits::DT
  int shift = 0;
  while (shift < 8 && dt * std::pow(10.0, 1 + shift) > limits::DT.high * (1 + 1e-12))
    --shift;
  while (shift > -8 && dt * std::pow(10.0, -2 + shift) < limits::DT.low * (1 - 1e-12))
    ++shift;
  std::vector<double> dts;
  for (int k = 1; k >= -2; --k)
  {
    const double candidate = dt * std::pow(10.0, k + shift);
    if (limits::DT.contains(candidate))
      dts.push_back(candidate);
  }
  std::vector<StudyMethod> methods;
  for (const IntegratorInfo* info : integratorTable())
  {
    if (info->adaptive)
      continue;
    for (const Stabilization stabilization :
         { Stabilization::None, Stabilization::Baumgarte, Stabilization::Projection })
    {
      // a method that projects by itself ignores the stabilisation: one entry stands for all
      if (info->holds_constraints && stabilization != Stabilization::None)
        continue;
      for (const double d : dts)
        methods.push_back(StudyMethod{ info->name, stabilization, d, 0.0 });
    }
  }
  for (const IntegratorInfo* info : integratorTable())
    if (info->adaptive)
      for (const double tolerance : { 1e-4, 1e-6, 1e-8, 1e-10 })
        methods.push_back(StudyMethod{ info->name, Stabilization::Projection,
                                       dts.empty() ? dt : dts.front(), tolerance });
  return methods;
}

void validateStudyRequest(const StudyRequest& request)
{
  requireInRange("horizon", request.horizon, limits::STUDY_HORIZON);
  requireInRange("error_target", request.error_target, limits::STUDY_ERROR_TARGET);
  requireInRange("methods", static_cast<double>(request.methods.size()), limits::STUDY_METHODS);
  validateStepSettings(request.base);
  for (std::size_t k = 0; k < request.methods.size(); ++k)
  {
    const StudyMethod& m = request.methods[k];
    const std::string field = "methods[" + std::to_string(k) + "]";
    const IntegratorInfo& info = findIntegrator(m.integrator, field + ".integrator");
    requireInRange(field + ".dt", m.dt, limits::DT);
    if (info.adaptive)
    {
      if (m.tolerance != 0.0)
        requireInRange(field + ".tolerance", m.tolerance, limits::ADAPTIVE_TOLERANCE);
    }
    else if (m.tolerance != 0.0)
      throw InvalidInput(field + ".tolerance", "= " + formatValue(m.tolerance) +
                                                   ", must be 0: only adaptive " +
                                                   "integrators (dopri5) take a tolerance, '" +
                                                   m.integrator + "' steps with dt");
  }
}

StudyResult runMethodStudy(const Scene& scene, const State& given_start,
                           const StudyRequest& request, const StudyProgress& progress,
                           const std::atomic<bool>* cancel)
{
  validateStudyRequest(request);
  // every run starts from the same state on the constraints, at the given state's time
  Simulator projector(scene, given_start, request.base);
  restCarriers(projector, request.carriers, given_start.time);
  projector.restoreState(given_start);
  projector.setState(given_start);
  const State start = projector.state();
  StudyResult result;
  result.horizon = request.horizon > 0.0 ? request.horizon : DEFAULT_STUDY_HORIZON;
  result.error_target =
      request.error_target > 0.0 ? request.error_target : DEFAULT_STUDY_ERROR_TARGET;
  std::vector<StudyMethod> methods =
      request.methods.empty() ? studyDefaultMethods(request.base.dt) : request.methods;
  for (StudyMethod& m : methods)
    if (findIntegrator(m.integrator).adaptive && m.tolerance == 0.0)
      m.tolerance = request.base.adaptive_tolerance;
  const int total = static_cast<int>(methods.size()) + 2;
  auto report = [&](int done, const std::string& current)
  {
    if (progress)
      progress(done, total, current);
  };

  // every run ends at start + round(horizon / dt) dt: the reference is taken at each such time
  std::vector<double> end_times;
  for (const StudyMethod& m : methods)
    end_times.push_back(start.time + static_cast<double>(stepsFor(result.horizon, m.dt)) * m.dt);
  std::sort(end_times.begin(), end_times.end());
  std::vector<double> distinct;
  for (const double t : end_times)
    if (distinct.empty() || t - distinct.back() >= limits::DT.low)
      distinct.push_back(t);
  auto endIndex = [&](double t)
  {
    std::size_t best = 0;
    for (std::size_t k = 1; k < distinct.size(); ++k)
      if (std::abs(distinct[k] - t) < std::abs(distinct[best] - t))
        best = k;
    return best;
  };

  // the reference, and a check with another step sequence: their difference is its own error
  std::vector<Points> reference, check;
  double reference_cpu = 0.0, check_cpu = 0.0;
  const double reference_dt =
      projector.model().numContacts() > 0 ? STUDY_CONTACT_REFERENCE_DT : STUDY_REFERENCE_DT;
  report(0, "reference: dopri5 + projection, tol " + formatValue(STUDY_REFERENCE_TOLERANCE));
  if (!referenceAt(scene, start, request.base, request.carriers, distinct, reference_dt,
                   STUDY_REFERENCE_TOLERANCE, reference, reference_cpu, cancel))
  {
    result.cancelled = true;
    return result;
  }
  report(1, "reference check: dopri5 + projection, tol " +
                formatValue(10 * STUDY_REFERENCE_TOLERANCE));
  if (!referenceAt(scene, start, request.base, request.carriers, distinct, 0.5 * reference_dt,
                   10 * STUDY_REFERENCE_TOLERANCE, check, check_cpu, cancel))
  {
    result.cancelled = true;
    return result;
  }
  for (std::size_t k = 0; k < distinct.size(); ++k)
    result.reference_error = std::max(result.reference_error, maxDistance(reference[k], check[k]));
  result.reference_cpu_time_per_sim_second = reference_cpu / (distinct.back() - start.time);
  result.reference_positions = reference[endIndex(start.time + result.horizon)];

  for (std::size_t k = 0; k < methods.size(); ++k)
  {
    const StudyMethod& m = methods[k];
    report(static_cast<int>(k) + 2, studyMethodLabel(m));
    StepSettings s = request.base;
    s.integrator = m.integrator;
    s.stabilization = m.stabilization;
    s.dt = m.dt;
    if (findIntegrator(m.integrator).adaptive)
      s.adaptive_tolerance = m.tolerance;
    RunOutcome first = runOnce(scene, start, s, result.horizon, request.carriers, cancel);
    if (first.cancelled)
    {
      result.cancelled = true;
      return result;
    }
    StudyRun run = first.run;
    run.method = m;
    const double sim = run.end_time - start.time;
    run.cpu_time_per_sim_second = sim > 0 ? first.cpu / sim : 0.0;
    if (run.finite && run.steps > 0)
    {
      run.position_error = maxDistance(run.final_positions, reference[endIndex(run.end_time)]);
      // a short run's CPU time is noise-dominated: the median of three
      if (first.cpu < STUDY_REPEAT_BELOW_CPU)
      {
        std::vector<double> cpu{ first.cpu };
        for (int r = 0; r < 2; ++r)
        {
          const RunOutcome again =
              runOnce(scene, start, s, result.horizon, request.carriers, cancel);
          if (again.cancelled)
          {
            result.cancelled = true;
            return result;
          }
          cpu.push_back(again.cpu);
        }
        run.cpu_time_per_sim_second = median(cpu) / sim;
      }
    }
    else
      run.position_error = std::numeric_limits<double>::quiet_NaN();
    result.runs.push_back(run);
  }
  // the cheapest run that meets the target, where the reference resolves the target at all
  if (result.error_target > result.reference_error)
    for (std::size_t k = 0; k < result.runs.size(); ++k)
    {
      const StudyRun& r = result.runs[k];
      if (r.finite && r.position_error <= result.error_target &&
          (result.recommended < 0 ||
           r.cpu_time_per_sim_second < result.runs[result.recommended].cpu_time_per_sim_second))
        result.recommended = static_cast<int>(k);
    }
  report(total, "");
  return result;
}

std::string studyCsv(const StudyResult& result)
{
  std::ostringstream csv;
  csv.precision(6);
  csv << "integrator,stabilization,dt_s,tolerance,position_error_m,reference_error_m,"
         "max_constraint_error_m,energy_drift_J,cpu_s_per_sim_s,steps,substeps,finite,"
         "recommended,error_target_m,horizon_s,failure\n";
  for (std::size_t k = 0; k < result.runs.size(); ++k)
  {
    const StudyRun& r = result.runs[k];
    std::string failure = r.failure;
    std::replace(failure.begin(), failure.end(), ',', ';');
    csv << r.method.integrator << ',' << stabilizationName(r.method.stabilization) << ','
        << r.method.dt << ',' << r.method.tolerance << ',' << r.position_error << ','
        << result.reference_error << ',' << r.max_constraint_error << ',' << r.energy_drift << ','
        << r.cpu_time_per_sim_second << ',' << r.steps << ',' << r.substeps << ','
        << (r.finite ? 1 : 0) << ',' << (static_cast<int>(k) == result.recommended ? 1 : 0) << ','
        << result.error_target << ',' << result.horizon << ',' << failure << '\n';
  }
  return csv.str();
}

}  // namespace constrained_particles
