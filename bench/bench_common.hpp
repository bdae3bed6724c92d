// Shared by the benchmark programs: CPU clocks, medians, CSV output, the peer chain workload.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <string>
#include <vector>

namespace bench
{
/// CPU time of the calling thread [s]: unaffected by other processes on a shared machine.
inline double threadCpuSeconds()
{
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// The options every benchmark program reads: --quick (a small sweep) and --out DIR (where its
/// CSV goes; "." by default). Others are ignored.
struct Options
{
  bool quick = false;
  std::string out = ".";
};

inline Options parseOptions(int argc, char** argv)
{
  Options options;
  for (int k = 1; k < argc; ++k)
  {
    const std::string arg = argv[k];
    if (arg == "--quick")
      options.quick = true;
    else if (arg == "--out" && k + 1 < argc)
      options.out = argv[++k];
  }
  return options;
}

inline double median(std::vector<double> values)
{
  if (values.empty())
    return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t mid = values.size() / 2;
  return values.size() % 2 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
}

/// The peer comparison's workload, identical in every engine: a chain of `n` point masses
/// joined by links, particle 0 pinned at the origin, laid out along +x at rest, under gravity
/// (0, 0, -9.81), stepped at dt for `duration`.
struct PeerChain
{
  int n = 10;
  double link_length = 0.1;    // [m]
  double particle_mass = 0.1;  // [kg]
  double dt = 1e-3;            // [s]
  double duration = 10.0;      // [s]
  double gravity = -9.81;      // z [m/s^2]
};

/// The chain sizes and the columns of peers.csv, shared with the peer programs.
inline std::vector<int> peerChainSizes()
{
  return { 10, 100, 1000 };
}

inline const char* peerCsvHeader()
{
  return "engine,method,n,dt,steps_run,time_per_step_s,link_error_max_m,link_error_mean_m,"
         "energy_drift_J,finite,note";
}

/// One row of peers.csv.
struct PeerResult
{
  std::string engine, method;
  int n = 0;
  double dt = 0;
  long steps_run = 0;
  double time_per_step = 0, link_error_max = 0, link_error_mean = 0, energy_drift = 0;
  bool finite = true;
  std::string note;

  std::string csv() const
  {
    char line[512];
    std::snprintf(line, sizeof(line), "%s,%s,%d,%g,%ld,%.6e,%.6e,%.6e,%.6e,%d,%s", engine.c_str(),
                  method.c_str(), n, dt, steps_run, time_per_step, link_error_max, link_error_mean,
                  energy_drift, finite ? 1 : 0, note.c_str());
    return line;
  }
};

/// A run projected to take more CPU than this is cut short and says so in its note [s].
constexpr double MAX_PEER_RUN_CPU = 120.0;

/// Steps a peer chain for its duration, timing only `step()`; every 10 steps (and when cut
/// short) samples `link_error()` (max over links and pin [m], NaN if the state is not finite)
/// and `energy()` [J].
template <typename StepFn, typename LinkErrorFn, typename EnergyFn>
void runPeerChain(const PeerChain& chain, PeerResult& r, StepFn step, LinkErrorFn link_error,
                  EnergyFn energy)
{
  r.n = chain.n;
  r.dt = chain.dt;
  const long steps = std::lround(chain.duration / chain.dt);
  const double e0 = energy();
  double cpu = 0, error_sum = 0;
  long samples = 0;
  for (long k = 1; k <= steps; ++k)
  {
    const double start = threadCpuSeconds();
    step();
    cpu += threadCpuSeconds() - start;
    r.steps_run = k;
    const bool cut = k >= 3 && k < steps && cpu / k * steps > MAX_PEER_RUN_CPU;
    if (k % 10 != 0 && k != steps && !cut)
      continue;
    const double error = link_error();
    if (!std::isfinite(error))
    {
      r.finite = false;
      break;
    }
    r.link_error_max = std::max(r.link_error_max, error);
    error_sum += error;
    ++samples;
    r.energy_drift = std::max(r.energy_drift, std::abs(energy() - e0));
    if (cut)
    {
      r.note = "cut short after " + std::to_string(k) + " of " + std::to_string(steps) +
               " steps (projected over " + std::to_string(static_cast<int>(MAX_PEER_RUN_CPU)) +
               " s CPU)";
      break;
    }
  }
  r.time_per_step = cpu / std::max(1L, r.steps_run);
  r.link_error_mean = samples ? error_sum / samples : NAN;
  if (r.note.empty())
    r.note = "errors sampled every 10 steps";
}

/// A peer program's command line: `[--out DIR] [--quick]`.
struct PeerArguments
{
  std::string out = ".";
  bool quick = false;  ///< 1 s runs instead of the full duration

  PeerArguments(int argc, char** argv)
  {
    for (int i = 1; i < argc; ++i)
    {
      const std::string arg = argv[i];
      if (arg == "--out" && i + 1 < argc)
        out = argv[++i];
      else if (arg == "--quick")
        quick = true;
    }
  }

  /// The chain for size n, shortened in quick mode.
  PeerChain chain(int n) const
  {
    PeerChain c;
    c.n = n;
    if (quick)
      c.duration = 1.0;
    return c;
  }

  /// Opens `<out>/<file>` with the CSV header written.
  std::ofstream openCsv(const std::string& file) const
  {
    std::ofstream csv(out + "/" + file);
    csv << peerCsvHeader() << "\n";
    return csv;
  }
};

/// Prints one result line to stderr (progress).
inline void reportPeer(const PeerResult& r)
{
  std::fprintf(stderr, "[peers] %s %s n = %d: %.1f us/step, link error max %.3g m%s\n",
               r.engine.c_str(), r.method.c_str(), r.n, r.time_per_step * 1e6, r.link_error_max,
               r.finite ? "" : " (non-finite)");
}

}  // namespace bench
