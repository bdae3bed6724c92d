// Shared by the benchmark programs: CPU clocks, medians, CSV output, the peer chain workload.
#pragma once

#include <algorithm>
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

}  // namespace bench
