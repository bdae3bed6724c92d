// Step cost of this core against an earlier one, in one process, interleaved: the same scenes,
// the same settings, CPU time of the stepping thread, medians of repeated batches.
// scripts/compare_cores.sh builds it with the earlier core's sources (renamed to namespace
// cp_old, headers under cp_old/core) beside this one's, both with the same flags.
// Usage: compare_cores [--quick] [--csv FILE]
#include "bench_common.hpp"

#include "constrained_particles/core/simulator.hpp"
#include "cp_old/core/simulator.hpp"

#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace cp = constrained_particles;

namespace
{
// A scene both cores can build: particles, links, a pin, a bowl under the first particle.
struct Workload
{
  std::string name;
  std::vector<double> masses;
  std::vector<std::array<double, 3>> links;  // first, second, length
  bool pin_first = false;
  bool first_on_bowl = false;
  Eigen::Matrix3Xd positions, velocities;
  double dt = 1e-3;
};

// the peer chain (bench_common.hpp): n particles of 0.1 kg, links of 0.1 m, the first pinned,
// released horizontally
Workload pinnedChain(int n)
{
  Workload w;
  w.name = "pinned chain n=" + std::to_string(n);
  w.masses.assign(n, 0.1);
  w.positions.resize(3, n);
  w.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
    w.positions.col(i) = Eigen::Vector3d(0.1 * i, 0.0, 0.0);
  for (int i = 0; i + 1 < n; ++i)
    w.links.push_back({ double(i), double(i + 1), 0.1 });
  w.pin_first = true;
  return w;
}

// seed problem 3: the first particle slides on the bowl z = (x^2 + y^2)/2, the others hang from
// it at 30 degrees, all moving with it
Workload surfaceChain(int n)
{
  Workload w;
  w.name = "surface chain n=" + std::to_string(n);
  // links of 0.5 m for the seed's five particles, 1 cm for long chains (at dt = 0.1 ms)
  const double l = n <= 5 ? 0.5 : 0.01;
  w.dt = n <= 5 ? 1e-3 : 1e-4;
  w.masses.assign(n, 1.0);
  w.positions.resize(3, n);
  w.velocities.resize(3, n);
  const Eigen::Vector3d start(0.5, 0.0, 0.125), down(0.5, 0.0, -0.8660254037844386);
  for (int i = 0; i < n; ++i)
  {
    w.positions.col(i) = start + i * l * down;
    w.velocities.col(i) = Eigen::Vector3d(0.0, 0.8, 0.0);
  }
  for (int i = 0; i + 1 < n; ++i)
    w.links.push_back({ double(i), double(i + 1), l });
  w.first_on_bowl = true;
  return w;
}

// the same scene, simulator and settings in either core
template <typename Scene, typename State, typename Link, typename Pin, typename OnSurface,
          typename Gravity, typename MakeSurface>
std::pair<Scene, State> build(const Workload& w, MakeSurface makeSurface)
{
  Scene scene;
  scene.masses = w.masses;
  if (w.first_on_bowl)
  {
    scene.surfaces = { makeSurface("bowl", { 1.0, 1.0 }) };
    scene.constraints.push_back(OnSurface{ 0, 0 });
  }
  for (const auto& link : w.links)
    scene.constraints.push_back(Link{ int(link[0]), int(link[1]), link[2] });
  if (w.pin_first)
    scene.constraints.push_back(Pin{ 0, Eigen::Vector3d(w.positions.col(0)) });
  scene.forces.push_back(Gravity{ Eigen::Vector3d(0.0, 0.0, -9.81) });
  State state;
  state.positions = w.positions;
  state.velocities = w.velocities;
  return { scene, state };
}

std::unique_ptr<cp::Simulator> makeNew(const Workload& w, const std::string& integrator)
{
  auto [scene, state] = build<cp::Scene, cp::State, cp::LinkConstraint, cp::PinConstraint,
                              cp::SurfaceConstraint, cp::GravityForce>(
      w, [](const char* type, std::vector<double> c) { return cp::makeSurface(type, c); });
  cp::StepSettings settings;
  settings.dt = w.dt;
  settings.integrator = integrator;
  return std::make_unique<cp::Simulator>(scene, state, settings);
}

std::unique_ptr<cp_old::Simulator> makeOld(const Workload& w, const std::string& integrator)
{
  auto [scene, state] =
      build<cp_old::Scene, cp_old::State, cp_old::LinkConstraint, cp_old::PinConstraint,
            cp_old::SurfaceConstraint, cp_old::GravityForce>(
          w, [](const char* type, std::vector<double> c) { return cp_old::makeSurface(type, c); });
  cp_old::StepSettings settings;
  settings.dt = w.dt;
#ifdef CP_OLD_PARSE_INTEGRATOR  // set by compare_cores.sh for cores that named them by an enum
  settings.integrator = cp_old::parseIntegrator(integrator);
#else
  settings.integrator = integrator;
#endif
  return std::make_unique<cp_old::Simulator>(scene, state, settings);
}

struct Result
{
  std::string workload, integrator;
  double old_seconds = 0, new_seconds = 0;  // per step, medians
  double ratio = 0;                         // median of the paired ratios new / old
  double difference = 0;                    // largest position difference after 100 steps [m]
  long steps = 0;
};

Result compare(const Workload& w, const std::string& integrator, bool quick)
{
  auto older = makeOld(w, integrator);
  auto newer = makeNew(w, integrator);
  // batches of about 20 ms, from a first timed step of each
  double first = bench::threadCpuSeconds();
  older->step(1);
  newer->step(1);
  first = (bench::threadCpuSeconds() - first) / 2;
  const int batch = std::max(1, static_cast<int>(0.02 / std::max(first, 1e-9)));
  const int repeats = quick ? 5 : 31;
  std::vector<double> old_times, new_times;
  for (int r = 0; r < repeats; ++r)
  {
    // alternate which core goes first, so neither always meets a warmer cache
    for (int turn = 0; turn < 2; ++turn)
    {
      const bool old_turn = (turn == 0) == (r % 2 == 0);
      const double start = bench::threadCpuSeconds();
      if (old_turn)
        older->step(batch);
      else
        newer->step(batch);
      (old_turn ? old_times : new_times).push_back((bench::threadCpuSeconds() - start) / batch);
    }
  }
  Result result;
  result.workload = w.name;
  result.integrator = integrator;
  result.old_seconds = bench::median(old_times);
  result.new_seconds = bench::median(new_times);
  // each pair ran back to back: the median of their ratios drifts least with the machine
  std::vector<double> ratios;
  for (std::size_t k = 0; k < old_times.size(); ++k)
    ratios.push_back(new_times[k] / old_times[k]);
  result.ratio = bench::median(ratios);
  result.steps = static_cast<long>(newer->state().steps);
  // the same motion: 100 steps from the start (long runs of a whipping chain are chaotic, and
  // round-off grows)
  auto old_check = makeOld(w, integrator);
  auto new_check = makeNew(w, integrator);
  old_check->step(100);
  new_check->step(100);
  result.difference =
      (old_check->state().positions - new_check->state().positions).colwise().norm().maxCoeff();
  return result;
}

}  // namespace

int main(int argc, char** argv)
{
  bool quick = false;
  std::string csv_path;
  for (int i = 1; i < argc; ++i)
  {
    if (std::strcmp(argv[i], "--quick") == 0)
      quick = true;
    else if (std::strcmp(argv[i], "--csv") == 0 && i + 1 < argc)
      csv_path = argv[++i];
  }
  std::vector<Result> results;
  for (const int n : { 10, 1000, 100000 })
    for (const char* integrator : { "rk4", "velocity_verlet" })
    {
      results.push_back(compare(pinnedChain(n), integrator, quick));
      const Result& r = results.back();
      std::fprintf(stderr, "[cores] %s %s: old %.3g us, new %.3g us per step\n", r.workload.c_str(),
                   integrator, 1e6 * r.old_seconds, 1e6 * r.new_seconds);
    }
  for (const int n : { 5, 1000 })
  {
    results.push_back(compare(surfaceChain(n), "rk4", quick));
    const Result& r = results.back();
    std::fprintf(stderr, "[cores] %s rk4: old %.3g us, new %.3g us per step\n", r.workload.c_str(),
                 1e6 * r.old_seconds, 1e6 * r.new_seconds);
  }
  std::printf(
      "| workload | integrator + stabilization | old [us/step] | new [us/step] | new / old "
      "(median of paired runs) "
      "| steps timed | position difference after 100 steps [m] |\n|---|---|---|---|---|---|---|\n");
  for (const Result& r : results)
    std::printf("| %s | %s + projection | %.3g | %.3g | %.2f | %ld | %.1e |\n", r.workload.c_str(),
                r.integrator.c_str(), 1e6 * r.old_seconds, 1e6 * r.new_seconds, r.ratio, r.steps,
                r.difference);
  if (!csv_path.empty())
  {
    std::FILE* csv = std::fopen(csv_path.c_str(), "w");
    std::fprintf(csv,
                 "workload,integrator,old_seconds_per_step,new_seconds_per_step,ratio,steps,"
                 "max_position_difference_m\n");
    for (const Result& r : results)
      std::fprintf(csv, "%s,%s,%.6e,%.6e,%.4f,%ld,%.3e\n", r.workload.c_str(), r.integrator.c_str(),
                   r.old_seconds, r.new_seconds, r.ratio, r.steps, r.difference);
    std::fclose(csv);
  }
  return 0;
}
