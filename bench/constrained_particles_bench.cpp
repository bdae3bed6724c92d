// What accuracy costs in time. Three modes, each writing CSV into an output folder:
//   work_precision  every scenario x integrator x stabilisation x dt: error against a reference,
//                   constraint error, energy drift, CPU time per simulated second; plus the
//                   observed convergence orders (orders.csv)
//   scaling         time per step against n for the chain, O(n) solve and sparse/dense solves
//   peers           this package's side of the peer comparison (bench_common.hpp's PeerChain)
//   scenes          per scene file: the effects evaluated per step and the step cost
//                   (scenes.csv); the solve per structure against n for trees (trees.csv)
// Usage: constrained_particles_bench MODE [--out DIR] [--quick]
#include "bench_common.hpp"
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <sstream>

#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <optional>

using namespace constrained_particles;

namespace
{
/// A run whose CPU time is estimated above this is skipped (noted on stderr) [s].
constexpr double MAX_RUN_CPU = 20.0;
/// Runs shorter than this are repeated and the median CPU time kept [s].
constexpr double REPEAT_BELOW_CPU = 0.5;
constexpr int REPEATS = 3;

struct Workload
{
  std::string name;
  Scene scene;
  State start;
  double duration = 1.0;                // simulated [s]
  std::function<Points(double)> exact;  // closed form, where one exists
};

State makeState(const Points& positions, const Points& velocities)
{
  State s;
  s.positions = positions;
  s.velocities = velocities;
  return s;
}

Workload beadBowl()
{
  // circular orbit in the bowl Z = k r^2 / 2: angular rate sqrt(g k)
  const double k = 1.5, r = 0.4, omega = std::sqrt(9.81 * k), z = 0.5 * k * r * r;
  Workload w;
  w.name = "bead_bowl";
  w.scene.masses = { 1.0 };
  w.scene.surfaces = { makeSurface("bowl", { k, k }) };
  w.scene.forces = { GravityForce{} };
  w.scene.constraints = { SurfaceConstraint{ 0, 0 } };
  w.start = makeState(Vec3(r, 0, z), Vec3(0, omega * r, 0));
  w.exact = [=](double t) -> Points
  { return Vec3(r * std::cos(omega * t), r * std::sin(omega * t), z); };
  return w;
}

// a shipped scene file (config/scenes), as its description
SceneDescription shipped(const std::string& name)
{
  return loadSceneFile(std::string(SCENES_DIR) + "/" + name + ".yaml");
}

Workload fromDescription(const std::string& label, const SceneDescription& description)
{
  const BuiltScene built = buildScene(description);
  Workload w;
  w.name = label;
  w.scene = built.scene;
  w.start = built.initial_state;
  return w;
}

// the shipped `chain` scene with n particles of `mass` on links of `link_length`, first pinned
SceneDescription chainScene(int n, double link_length, double mass)
{
  SceneDescription d = shipped("chain");
  ChainChange change;
  change.num_particles = n;
  change.link_length = link_length;
  change.particle_mass = mass;
  change.pin_first = true;
  setChains(d, change);
  return d;
}

Workload beadWaves()
{
  SceneDescription d = shipped("bead");
  setFirstSurface(d, makeSurface("waves", { 0.2, 2.0, 1.0 }));
  return fromDescription("bead_waves", d);
}

Workload pendulum()
{
  Workload w;
  w.name = "pendulum_2";
  w.scene.masses = { 1.0, 1.0 };
  w.scene.forces = { GravityForce{} };
  w.scene.constraints = { LinkConstraint{ 0, 1, 1.0 }, PinConstraint{ 0, Vec3::Zero() } };
  Points p(3, 2);
  p << 0, std::sin(M_PI / 3), 0, 0, 0, -std::cos(M_PI / 3);
  w.start = makeState(p, Points::Zero(3, 2));
  return w;
}

// pinned chain of total length 1 m released horizontally
Workload chain(int n)
{
  return fromDescription("chain_" + std::to_string(n), chainScene(n, 1.0 / (n - 1), 0.1));
}

Workload surfaceChain()
{
  return fromDescription("surface_chain", shipped("surface_chain"));
}

struct RunResult
{
  double error = NAN;               // max |p_i(T) - p_ref_i(T)| [m]
  double max_constraint_error = 0;  // over the run [m]
  double energy_drift = 0;          // max |E(t) - E(0)| over the run [J]
  double cpu_per_sim_second = 0;    // [s/s]
  long steps = 0;
  bool finite = true;
  int runs = 0;
  int internal_steps = 0;  // dopri5: accepted internal steps in the run
  State final_state;
};

// Steps a workload to its duration; only stepping is timed, diagnostics are sampled around it.
RunResult runOnce(const Workload& w, const StepSettings& settings)
{
  RunResult result;
  Simulator simulator(w.scene, w.start, settings);
  const long steps = std::lround(w.duration / settings.dt);
  const long sample_every = std::max(1L, steps / 400);
  const double e0 = simulator.diagnostics().totalEnergy();
  double cpu = 0;
  for (long k = 0; k < steps; k += sample_every)
  {
    const int batch = static_cast<int>(std::min(sample_every, steps - k));
    const double start = bench::threadCpuSeconds();
    for (int b = 0; b < batch; ++b)
      result.internal_steps += simulator.step().internal_steps;
    cpu += bench::threadCpuSeconds() - start;
    result.steps += batch;
    const Diagnostics d = simulator.diagnostics();
    if (!d.finite() || !isFinite(simulator.state()))
    {
      result.finite = false;
      break;
    }
    result.max_constraint_error = std::max(result.max_constraint_error, d.max_position_error);
    result.energy_drift = std::max(result.energy_drift, std::abs(d.totalEnergy() - e0));
  }
  result.cpu_per_sim_second = cpu / (result.steps * settings.dt);
  result.final_state = simulator.state();
  result.runs = 1;
  return result;
}

RunResult run(const Workload& w, const StepSettings& settings)
{
  RunResult first = runOnce(w, settings);
  if (first.finite && first.cpu_per_sim_second * w.duration < REPEAT_BELOW_CPU)
  {
    std::vector<double> cpu{ first.cpu_per_sim_second };
    for (int r = 1; r < REPEATS; ++r)
      cpu.push_back(runOnce(w, settings).cpu_per_sim_second);
    first.cpu_per_sim_second = bench::median(cpu);
    first.runs = REPEATS;
  }
  return first;
}

double maxDistance(const Points& a, const Points& b)
{
  return (a - b).colwise().norm().maxCoeff();
}

// the most accurate method at a tight tolerance; its convergence is checked against a looser one
Points reference(const Workload& w, double& uncertainty)
{
  if (w.exact)
  {
    uncertainty = 0.0;
    return w.exact(w.duration);  // runs end within round-off of w.duration
  }
  // the check takes a different step sequence (half the output step): identical sequences
  // would agree whatever their error
  auto converged = [&](double dt, double tolerance)
  {
    StepSettings s;
    s.max_substeps = 1;  // the integrator itself (stability measures sub-steps)
    s.dt = dt;
    s.integrator = "dopri5";
    s.stabilization = Stabilization::Projection;
    s.projection_tolerance = 1e-13;
    s.adaptive_tolerance = tolerance;
    return runOnce(w, s).final_state.positions;
  };
  const Points tight = converged(1e-3, 1e-13);
  uncertainty = maxDistance(tight, converged(5e-4, 1e-12));
  return tight;
}

// the fixed-step integrators of the table, and the adaptive ones (swept by tolerance)
std::vector<std::string> integratorsWhere(bool adaptive)
{
  std::vector<std::string> names;
  for (const IntegratorInfo* integrator : integratorTable())
    if (integrator->adaptive == adaptive)
      names.push_back(integrator->name);
  return names;
}
const std::vector<Stabilization> STABILIZATIONS = { Stabilization::None, Stabilization::Baumgarte,
                                                    Stabilization::Projection };

// slope of log(error) against log(dt), over the points between round-off and saturation
std::optional<double> observedOrder(const std::vector<std::pair<double, double>>& dt_error,
                                    double low, double high)
{
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int count = 0;
  for (const auto& [dt, error] : dt_error)
    if (std::isfinite(error) && error > low && error < high)
    {
      const double x = std::log(dt), y = std::log(error);
      sx += x, sy += y, sxx += x * x, sxy += x * y;
      ++count;
    }
  if (count < 2)
    return std::nullopt;
  return (count * sxy - sx * sy) / (count * sxx - sx * sx);
}

int workPrecision(const std::string& out, bool quick)
{
  // every dt divides the 1 s span exactly, so every run ends at the reference's time
  std::vector<double> dts = { 1e-1, 2e-2, 1e-2, 2e-3, 1e-3, 2e-4, 1e-4, 2e-5, 1e-5, 2e-6, 1e-6 };
  std::vector<double> tolerances = {
    1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12
  };
  std::vector<Workload> workloads = { beadBowl(), beadWaves(), pendulum(),
                                      chain(10),  chain(100),  surfaceChain() };
  if (quick)
  {
    dts = { 1e-2, 1e-3, 1e-4 };
    tolerances = { 1e-4, 1e-8 };
    workloads.resize(3);
  }
  std::ofstream csv(out + "/work_precision.csv");
  csv << "scenario,integrator,stabilization,dt,tolerance,error_m,reference_uncertainty_m,"
         "max_constraint_error_m,energy_drift_J,cpu_s_per_sim_s,steps,internal_steps,finite,runs\n";
  std::ofstream orders(out + "/orders.csv");
  orders << "scenario,integrator,stabilization,theoretical_order,observed_order\n";

  for (const Workload& w : workloads)
  {
    double uncertainty = 0;
    std::cerr << "[" << w.name << "] reference..." << std::flush;
    const Points ref = reference(w, uncertainty);
    std::cerr << " converged to " << uncertainty << " m\n";
    auto record = [&](const std::string& integrator, Stabilization stabilization, double dt,
                      double tolerance, const RunResult& r)
    {
      const double error = r.finite ? maxDistance(r.final_state.positions, ref) : NAN;
      char line[512];
      std::snprintf(line, sizeof(line), "%s,%s,%s,%g,%g,%.6e,%.3e,%.6e,%.6e,%.6e,%ld,%d,%d,%d\n",
                    w.name.c_str(), integrator.c_str(), stabilizationName(stabilization), dt,
                    tolerance, error, uncertainty, r.max_constraint_error, r.energy_drift,
                    r.cpu_per_sim_second, r.steps, r.internal_steps, r.finite ? 1 : 0, r.runs);
      csv << line;
      csv.flush();
      return error;
    };

    for (const std::string& integrator : integratorsWhere(false))
      for (Stabilization stabilization : STABILIZATIONS)
      {
        // an integrator that projects by itself: one sweep stands for all stabilisations
        if (findIntegrator(integrator).holds_constraints && stabilization != Stabilization::None)
          continue;
        std::cerr << "[" << w.name << "] " << integrator << " + "
                  << stabilizationName(stabilization) << ":";
        std::vector<std::pair<double, double>> dt_error;
        double last_cpu = 0, last_dt = 0;
        for (double dt : dts)
        {
          if (last_cpu > 0 && last_cpu * last_dt / dt > MAX_RUN_CPU)
          {
            std::cerr << " (dt " << dt << " skipped: > " << MAX_RUN_CPU << " s)";
            break;
          }
          StepSettings s;
          s.max_substeps = 1;  // the integrator itself (stability measures sub-steps)
          s.dt = dt;
          s.integrator = integrator;
          s.stabilization = stabilization;
          const RunResult r = run(w, s);
          dt_error.emplace_back(dt, record(integrator, stabilization, dt, 0, r));
          last_cpu = r.cpu_per_sim_second * w.duration;
          last_dt = dt;
          std::cerr << " " << dt << std::flush;
        }
        std::cerr << "\n";
        // round-off floor: well above the reference's own uncertainty and 1e-12 m
        // between the pre-asymptotic range and round-off: 100x above the smallest error of the
        // sweep (where round-off takes over), the reference's own error, and 1e-11 m
        double floor = INFINITY;
        for (const auto& point : dt_error)
          if (std::isfinite(point.second))
            floor = std::min(floor, point.second);
        const auto order =
            observedOrder(dt_error, std::max({ 1e-11, 100 * uncertainty, 100 * floor }), 1e-3);
        orders << w.name << "," << integrator << ","
               << (findIntegrator(integrator).holds_constraints ? "rattle"
                                                                : stabilizationName(stabilization))
               << "," << findIntegrator(integrator).order << ","
               << (order ? std::to_string(*order) : std::string("nan")) << "\n";
      }

    for (const std::string& integrator : integratorsWhere(true))
      for (Stabilization stabilization : STABILIZATIONS)
      {
        std::cerr << "[" << w.name << "] " << integrator << " + "
                  << stabilizationName(stabilization) << ":";
        for (double tolerance : tolerances)
        {
          StepSettings s;
          s.max_substeps = 1;  // the integrator itself (stability measures sub-steps)
          s.dt = 1e-2;
          s.integrator = integrator;
          s.stabilization = stabilization;
          s.adaptive_tolerance = tolerance;
          record(integrator, stabilization, s.dt, tolerance, run(w, s));
          std::cerr << " " << tolerance << std::flush;
        }
        std::cerr << "\n";
      }
  }
  return 0;
}

// CPU seconds per call of `fn` over one run lasting at least `budget`
template <typename Fn>
double secondsPerCall(Fn& fn, double budget)
{
  long calls = 0;
  const double start = bench::threadCpuSeconds();
  double elapsed = 0;
  do
  {
    fn();
    ++calls;
    elapsed = bench::threadCpuSeconds() - start;
  } while (elapsed < budget);
  return elapsed / calls;
}

// median CPU seconds per call of `fn`, each of REPEATS runs lasting at least budget / REPEATS
template <typename Fn>
double medianSecondsPerCall(Fn fn, double budget)
{
  fn();  // warm caches and workspaces
  std::vector<double> per_call;
  for (int r = 0; r < REPEATS; ++r)
    per_call.push_back(secondsPerCall(fn, budget / REPEATS));
  return bench::median(per_call);
}

// `a` against `b` on a shared machine: 2 REPEATS + 1 rounds of one run of each, interleaved so
// that both see the same load; the medians of a's and b's CPU seconds per call and of the
// rounds' ratios a / b
struct Paired
{
  double a, b, ratio;
};
template <typename A, typename B>
Paired pairedSecondsPerCall(A a, B b, double budget)
{
  a();  // warm caches and workspaces
  b();
  const int rounds = 2 * REPEATS + 1;
  std::vector<double> as, bs, ratios;
  for (int r = 0; r < rounds; ++r)
  {
    as.push_back(secondsPerCall(a, budget / (2 * rounds)));
    bs.push_back(secondsPerCall(b, budget / (2 * rounds)));
    ratios.push_back(as.back() / bs.back());
  }
  return { bench::median(as), bench::median(bs), bench::median(ratios) };
}

/// Links of the scaling chain [m]: fixed, so that every n sees the same motion per link.
constexpr double SCALING_LINK_LENGTH = 0.01;

// CPU time of one step of a horizontally released pinned chain, from its first steps;
// `newton_iterations` gets the position projection's iterations in the last step
double secondsPerStep(int n, SolveMethod method, const std::string& integrator, double budget,
                      int& newton_iterations)
{
  const BuiltScene scenario = buildScene(chainScene(n, SCALING_LINK_LENGTH, 0.1));
  StepSettings s;
  s.max_substeps = 1;  // the integrator itself (stability measures sub-steps)
  s.dt = 1e-4;
  s.integrator = integrator;
  s.stabilization = Stabilization::Projection;
  Simulator simulator(scenario.scene, scenario.initial_state, s, method);
  simulator.step();  // with medianSecondsPerCall's own call: two warm-up steps
  StepStatistics last;
  const double seconds = medianSecondsPerCall([&] { last = simulator.step(); }, budget);
  newton_iterations = last.projection.max_iterations;
  return seconds;
}

int scaling(const std::string& out, bool quick)
{
  std::vector<int> sizes = { 10, 30, 100, 300, 1000, 3000, 10000, 30000, 100000 };
  if (quick)
    sizes = { 10, 100, 1000, 10000 };
  std::ofstream csv(out + "/scaling.csv");
  csv << "n,solve,integrator,seconds_per_step,particle_steps_per_second,newton_iterations\n";
  const std::vector<std::pair<SolveMethod, int>> methods = { { SolveMethod::Tridiagonal, 1000000 },
                                                             { SolveMethod::Sparse, 1000000 },
                                                             { SolveMethod::Dense, 1000 } };
  for (const std::string integrator : { "semi_implicit_euler", "rk4" })
    for (const auto& [method, max_n] : methods)
    {
      if (integrator == "rk4" && method != SolveMethod::Tridiagonal)
        continue;
      for (int n : sizes)
      {
        if (n > max_n)
          continue;
        int iterations = 0;
        const double seconds = secondsPerStep(n, method, integrator, quick ? 0.3 : 1.5, iterations);
        csv << n << "," << solveMethodName(method) << "," << integrator << "," << seconds << ","
            << n / seconds << "," << iterations << "\n";
        csv.flush();
        std::cerr << "[scaling] " << integrator << " " << solveMethodName(method) << " n = " << n
                  << ": " << seconds * 1e6 << " us/step, " << n / seconds / 1e6
                  << " M particle-steps/s\n";
      }
    }
  return 0;
}

// our side of the peer comparison: exact constraints, O(n) solve
int peers(const std::string& out, bool quick)
{
  std::ofstream csv(out + "/peers_constrained_particles.csv");
  csv << bench::peerCsvHeader() << "\n";
  // the last variant holds links to round-off, for comparison with reduced coordinates
  const std::vector<std::pair<std::string, double>> variants = {
    { "semi_implicit_euler", 1e-10 },
    { "velocity_verlet", 1e-10 },
    { "rk4", 1e-10 },
    { "rk4", 1e-13 },
  };
  for (int n : bench::peerChainSizes())
    for (const auto& [integrator, tolerance] : variants)
    {
      bench::PeerChain chain;
      chain.n = n;
      if (quick)
        chain.duration = 1.0;
      SceneDescription d = chainScene(n, chain.link_length, chain.particle_mass);
      setGravityAndDamping(d, Vec3(0, 0, chain.gravity), 0.0);
      const BuiltScene scenario = buildScene(d);
      StepSettings s;
      s.max_substeps = 1;  // the integrator itself (stability measures sub-steps)
      s.dt = chain.dt;
      s.integrator = integrator;
      s.stabilization = Stabilization::Projection;
      s.projection_tolerance = tolerance;
      Simulator simulator(scenario.scene, scenario.initial_state, s);
      bench::PeerResult r;
      r.engine = "constrained_particles";
      r.method = integrator + (findIntegrator(integrator).holds_constraints ? "" : "+projection") +
                 (tolerance < 1e-10 ? "_tol_1e-13" : "");
      bench::runPeerChain(
          chain, r, [&] { simulator.step(); },
          [&]
          {
            const Diagnostics d = simulator.diagnostics();
            return d.finite() ? d.max_position_error : NAN;
          },
          [&] { return simulator.diagnostics().totalEnergy(); });
      csv << r.csv() << "\n";
      csv.flush();
      bench::reportPeer(r);
    }
  return 0;
}

// "kind:count kind:count" of the counters that moved, per step
template <typename Variant, std::size_t N>
std::string perStep(const std::array<std::uint64_t, N>& counts, double steps)
{
  std::ostringstream text;
  for (std::size_t k = 0; k < N; ++k)
    if (counts[k] > 0)
      text << (text.tellp() > 0 ? " " : "") << KindNames<Variant>::value[k] << ":"
           << counts[k] / steps;
  return text.str().empty() ? "-" : text.str();
}

// A binary tree of n particles (particle k hangs from (k - 1) / 2), the root pinned; or a free
// star (every particle linked to particle 0).
BuiltScene treeScene(int n, bool star)
{
  BuiltScene s;
  s.scene.masses.assign(n, 0.1);
  s.initial_state.positions.resize(3, n);
  s.initial_state.velocities.setZero(3, n);
  s.initial_state.positions.col(0).setZero();
  for (int k = 1; k < n; ++k)
  {
    const int parent = star ? 0 : (k - 1) / 2;
    const double angle = 2.0 * M_PI * k / n;
    const Vec3 offset(0.1 * std::cos(angle), 0.1 * std::sin(angle), -0.1);
    s.initial_state.positions.col(k) =
        s.initial_state.positions.col(parent) + 0.01 * offset.normalized();
    s.scene.constraints.push_back(LinkConstraint{ parent, k, 0.01 });
  }
  // a pinned hub would make every link of a star independent: leave the star free
  if (!star)
    s.scene.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
  s.scene.forces = { GravityForce{} };
  return s;
}

int scenes(const std::string& out, bool quick)
{
  const double budget = quick ? 0.15 : 1.5;
  std::ofstream csv(out + "/scenes.csv");
  csv << "scene,particles,rows,solve,integrator,stabilization,seconds_per_step,"
         "forces_per_step,constraints_per_step,factorizations_per_step,stages,"
         "generic_seconds_per_step,generic_ratio_median\n";
  for (const std::string& name : listScenes(SCENES_DIR))
  {
    const SceneDescription d = loadSceneFile(std::string(SCENES_DIR) + "/" + name + ".yaml");
    const BuiltScene built = buildScene(d);
    StepSettings settings = d.solver.applyTo(StepSettings{});
    settings.max_substeps = 1;  // a step as the scene asks (stability measures sub-steps)
    Simulator simulator(built.scene, built.initial_state, settings, d.solver.solve_method);
    // against the same scene on the generic stages, interleaved: what the fused chain stages save
    Simulator generic(built.scene, built.initial_state, settings, d.solver.solve_method,
                      StagePaths::Generic);
    const Paired paired =
        pairedSecondsPerCall([&] { simulator.step(); }, [&] { generic.step(); }, 2.0 * budget);
    const double seconds = paired.a, generic_seconds = paired.b;
    // fused where its steps evaluate stages that take them: not under Baumgarte's bias, nor with
    // an integrator that holds the constraints itself (velocity Verlet, fast projection)
    const bool evaluated = settings.stabilization != Stabilization::Baumgarte &&
                           !findIntegrator(settings.integrator).holds_constraints;
    const Model& model = simulator.model();
    // a tree of links takes the fused tree stages (Model::fusedTree()); another tree solved by
    // rows (Model::solvesTreeByRows()) the generic stages with its own solve
    const char* stages = evaluated && model.fusedChain() ? "fused"
                         : evaluated && model.fusedTree()
                             ? "fused tree"
                             : (model.solvesTreeByRows() ? "tree rows" : "generic");
    // counts of exactly 100 further steps
    Simulator counted(built.scene, built.initial_state, settings, d.solver.solve_method);
    const EffectCounters before = counted.effectCounters();
    counted.step(100);
    EffectCounters c = counted.effectCounters();
    for (int k = 0; k < NUM_FORCE_KINDS; ++k)
      c.forces[k] -= before.forces[k];
    for (int k = 0; k < NUM_CONSTRAINT_KINDS; ++k)
      c.constraints[k] -= before.constraints[k];
    std::ostringstream factorizations;
    for (int k = 0; k < NUM_SOLVE_METHODS; ++k)
      if (c.factorizations[k] - before.factorizations[k] > 0)
        factorizations << solveMethodName(static_cast<SolveMethod>(k)) << ":"
                       << (c.factorizations[k] - before.factorizations[k]) / 100.0;
    const std::string forces = perStep<Force>(c.forces, 100.0);
    const std::string constraints = perStep<Constraint>(c.constraints, 100.0);
    csv << name << "," << simulator.model().numParticles() << "," << simulator.model().numRows()
        << "," << solveMethodName(simulator.model().solveMethod()) << "," << settings.integrator
        << "," << stabilizationName(settings.stabilization) << "," << seconds << "," << forces
        << "," << constraints << "," << (factorizations.str().empty() ? "-" : factorizations.str())
        << "," << stages << "," << generic_seconds << "," << paired.ratio << "\n";
    std::cerr << "[scenes] " << name << ": " << seconds * 1e6 << " us/step (" << stages
              << " stages; generic " << generic_seconds * 1e6 << ", ratio " << paired.ratio << "), "
              << solveMethodName(simulator.model().solveMethod()) << "; forces " << forces
              << "; constraints " << constraints << "\n";
  }

  // one evaluation of the constraint forces (assemble, factorise, solve) per structure and n
  std::ofstream trees(out + "/trees.csv");
  trees << "shape,n,solve,seconds_per_solve\n";
  std::vector<int> sizes = { 100, 1000, 10000, 100000 };
  if (quick)
    sizes = { 100, 1000, 10000 };
  // the tree solve as it runs (a binary tree of links: the fused tree stages, Model::fusedTree();
  // the star: the block elimination), and the block elimination (tree.cpp), which the generic
  // paths keep
  struct Solve
  {
    SolveMethod method;
    StagePaths paths;
    const char* name;
  };
  const Solve solves[] = { { SolveMethod::Tree, StagePaths::Specialized, "tree" },
                           { SolveMethod::Tree, StagePaths::Generic, "tree_blocks" },
                           { SolveMethod::Sparse, StagePaths::Specialized, "sparse" },
                           { SolveMethod::Dense, StagePaths::Specialized, "dense" } };
  for (const bool star : { false, true })
    for (const Solve& solve : solves)
      for (const int n : sizes)
      {
        const SolveMethod method = solve.method;
        // dense is O(n^3); sparse on a star fills an n x n matrix
        if ((method == SolveMethod::Dense && n > 1000) ||
            (method == SolveMethod::Sparse && star && n > 1000))
          continue;
        const BuiltScene s = treeScene(n, star);
        StepSettings settings;
        settings.max_substeps = 1;  // the integrator itself (stability measures sub-steps)
        settings.stabilization = Stabilization::None;
        Simulator simulator(s.scene, s.initial_state, settings, method, solve.paths);
        Points forces;
        Eigen::VectorXd multipliers;
        // one evaluation of every stage at the state: rows, forces, assembly, factorisation, solve
        const double seconds = medianSecondsPerCall(
            [&] { simulator.constraintForces(forces, multipliers); }, quick ? 0.15 : 1.0);
        const char* shape = star ? "star" : "binary_tree";
        trees << shape << "," << n << "," << solve.name << "," << seconds << "\n";
        trees.flush();
        std::cerr << "[trees] " << shape << " n = " << n << " " << solve.name << ": "
                  << seconds * 1e6 << " us\n";
      }
  return 0;
}

}  // namespace

// What stability costs on the fine-link chains of issue 14 (pinned, links of 1 cm, 10 g,
// released horizontally, 10 s): rk4 unsplit (max_substeps = 1, until a step check stops it), rk4
// and velocity Verlet with the default sub-steps, fast projection at 1 ms and 10 ms. Thread CPU
// seconds per simulated second, median of `repeats`, and ratios to unsplit rk4's cost per step
// measured in the same run.
int stability(const std::string& out, bool quick)
{
  const int repeats = quick ? 1 : 3;
  const double seconds = quick ? 2.0 : 10.0;
  struct Method
  {
    const char* label;
    const char* integrator;
    double dt;
    int max_substeps;
  };
  const Method methods[] = { { "rk4 unsplit", "rk4", 1e-3, 1 },
                             { "rk4 + sub-steps", "rk4", 1e-3, 1024 },
                             { "velocity_verlet + sub-steps", "velocity_verlet", 1e-3, 1024 },
                             { "fast_projection dt 1 ms", "fast_projection", 1e-3, 1024 },
                             { "fast_projection dt 10 ms", "fast_projection", 1e-2, 1024 } };
  std::ofstream csv(out + "/stability.csv");
  csv << "n,method,dt_s,max_substeps,sim_seconds_reached,failed_check,cpu_s_per_sim_s,"
         "cost_ratio_to_unsplit_rk4,substeps_per_step,stiff_steps,rejected_steps,"
         "max_constraint_error_m,energy_change_J\n";
  std::printf("%6s  %-28s %9s %10s %10s %8s %9s %12s %12s\n", "n", "method", "reached_s",
              "cpu/sim_s", "x_rk4", "sub/step", "retaken", "max_err_m", "dE_J");
  for (const int n : { 200, 1000 })
  {
    double unsplit_per_step = NAN;
    for (const Method& method : methods)
    {
      std::vector<double> costs;
      StepStatistics all;
      double reached = 0, max_error = 0, energy_change = 0;
      StepCheck failed = StepCheck::None;
      for (int r = 0; r < repeats; ++r)
      {
        Scene scene;
        scene.masses.assign(n, 0.01);
        for (int i = 0; i + 1 < n; ++i)
          scene.constraints.push_back(LinkConstraint{ i, i + 1, 0.01 });
        scene.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
        scene.forces = { GravityForce{} };
        State start;
        start.positions = Points::Zero(3, n);
        start.velocities = Points::Zero(3, n);
        for (int i = 0; i < n; ++i)
          start.positions(0, i) = 0.01 * i;
        StepSettings settings;
        settings.integrator = method.integrator;
        settings.dt = method.dt;
        settings.max_substeps = method.max_substeps;
        Simulator simulator(scene, start, settings);
        const double e0 = simulator.diagnostics().totalEnergy();
        all = StepStatistics{};
        max_error = 0;
        failed = StepCheck::None;
        const long steps = std::lround(seconds / method.dt);
        const double begin = bench::threadCpuSeconds();
        for (long k = 0; k < steps && failed == StepCheck::None; k += 10)
        {
          const StepStatistics s = simulator.step(static_cast<int>(std::min(10L, steps - k)));
          all.merge(s);
          failed = s.failed_check;
          max_error = std::max(max_error, simulator.diagnostics().max_position_error);
        }
        const double cpu = bench::threadCpuSeconds() - begin;
        reached = simulator.state().time;
        energy_change = simulator.diagnostics().totalEnergy() - e0;
        costs.push_back(cpu / std::max(reached, 1e-9));
      }
      const double cost = bench::median(costs);
      if (std::string(method.label) == "rk4 unsplit")
        unsplit_per_step = cost * 1e-3;  // CPU seconds per 1 ms step
      const double ratio = cost * method.dt / unsplit_per_step / (method.dt / 1e-3);
      const double per_step = static_cast<double>(all.substeps) / std::max(all.steps, 1L);
      std::printf("%6d  %-28s %9.3f %10.4f %10.2f %8.2f %9ld %12.2e %12.3g%s\n", n, method.label,
                  reached, cost, ratio, per_step, all.rejected_steps, max_error, energy_change,
                  failed == StepCheck::None
                      ? ""
                      : (std::string("  stopped: ") + stepCheckName(failed)).c_str());
      csv << n << "," << method.label << "," << method.dt << "," << method.max_substeps << ","
          << reached << "," << stepCheckName(failed) << "," << cost << "," << ratio << ","
          << per_step << "," << all.stiff_steps << "," << all.rejected_steps << "," << max_error
          << "," << energy_change << "\n";
    }
  }
  return 0;
}

int main(int argc, char** argv)
{
  if (argc < 2)
  {
    std::cerr << "usage: " << argv[0]
              << " work_precision|scaling|peers|scenes|stability [--out DIR] [--quick]\n";
    return 2;
  }
  const std::string mode = argv[1];
  std::string out = ".";
  bool quick = false;
  for (int i = 2; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if (arg == "--out" && i + 1 < argc)
      out = argv[++i];
    else if (arg == "--quick")
      quick = true;
    else
    {
      std::cerr << "unknown argument " << arg << "\n";
      return 2;
    }
  }
  if (mode == "work_precision")
    return workPrecision(out, quick);
  if (mode == "scaling")
    return scaling(out, quick);
  if (mode == "peers")
    return peers(out, quick);
  if (mode == "scenes")
    return scenes(out, quick);
  if (mode == "stability")
    return stability(out, quick);
  std::cerr << "unknown mode " << mode << "\n";
  return 2;
}
