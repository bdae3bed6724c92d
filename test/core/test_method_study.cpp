// The method study behind ~compare_methods: its errors against closed forms, its recommendation
// against the offline benchmark's, its validation, and cancellation.
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/method_study.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <thread>

using namespace constrained_particles;

namespace
{
BuiltScene shippedScene(const std::string& name)
{
  return buildScene(loadSceneFile(std::string(SCENES_DIR) + "/" + name + ".yaml"));
}

/// The bead_orbit scene's closed form: a circle of r = 0.4 m at omega = sqrt(g k), k = 1.5 1/m.
Vec3 orbitAt(double t)
{
  const double k = 1.5, r = 0.4, omega = std::sqrt(9.81 * k);
  return Vec3(r * std::cos(omega * t), r * std::sin(omega * t), 0.5 * k * r * r);
}

void expectRefused(StudyRequest request, const std::string& field)
{
  try
  {
    validateStudyRequest(request);
    ADD_FAILURE() << "accepted; expected a refusal naming " << field;
  }
  catch (const InvalidInput& e)
  {
    EXPECT_EQ(e.field(), field) << e.what();
  }
}
}  // namespace

// On the circular orbit every run's error against the reference agrees with its error against
// the closed form to within the reference's own reported error.
TEST(MethodStudy, BeadOrbitErrorsAgreeWithClosedForm)
{
  const BuiltScene bead = shippedScene("bead_orbit");
  // the scene is on its orbit: the initial state is the closed form at t = 0
  ASSERT_LE((Vec3(bead.initial_state.positions.col(0)) - orbitAt(0)).norm(), 1e-12);
  StudyRequest request;
  request.horizon = 1.0;
  request.base.energy_budget = 0.0;  // every run to the horizon: errors compared, not budgets
  const StudyResult result = runMethodStudy(bead.scene, bead.initial_state, request);
  ASSERT_FALSE(result.cancelled);
  ASSERT_EQ(result.runs.size(), studyDefaultMethods(request.base.dt).size());
  EXPECT_GT(result.reference_error, 0.0);
  EXPECT_LT(result.reference_error, 1e-12);
  EXPECT_LE((Vec3(result.reference_positions.col(0)) - orbitAt(1.0)).norm(),
            result.reference_error);
  int compared = 0;
  for (const StudyRun& run : result.runs)
  {
    SCOPED_TRACE(studyMethodLabel(run.method));
    ASSERT_TRUE(run.finite) << run.failure;
    EXPECT_NEAR(run.end_time, 1.0, 1e-9);
    const double exact_error = (Vec3(run.final_positions.col(0)) - orbitAt(run.end_time)).norm();
    EXPECT_NEAR(run.position_error, exact_error, result.reference_error);
    ++compared;
  }
  EXPECT_GE(compared, 50);
  // rk4 (4th order) at dt 0.01 s beats explicit Euler (1st order) at dt 1e-5 s
  auto errorOf = [&](const std::string& integrator, Stabilization stabilization,
                     double dt) -> double
  {
    for (const StudyRun& run : result.runs)
      if (run.method.integrator == integrator && run.method.stabilization == stabilization &&
          std::abs(run.method.dt - dt) < 1e-12)
        return run.position_error;
    return NAN;
  };
  EXPECT_LT(errorOf("rk4", Stabilization::None, 1e-2),
            errorOf("explicit_euler", Stabilization::None, 1e-5));
}

// The offline benchmark's cheapest run for 1e-6 m on surface_chain (docs/bench/work_precision.csv,
// written by scripts/bench.sh) is the study's recommendation: same integrator, same dt decade.
TEST(MethodStudy, SurfaceChainRecommendationMatchesTheBenchmark)
{
  std::ifstream csv(std::string(DOCS_BENCH_DIR) + "/work_precision.csv");
  ASSERT_TRUE(csv.good());
  std::string line, bench_integrator;
  double bench_dt = 0, bench_cost = INFINITY;
  std::getline(csv, line);  // header
  while (std::getline(csv, line))
  {
    std::vector<std::string> f;
    std::stringstream fields(line);
    for (std::string item; std::getline(fields, item, ',');)
      f.push_back(item);
    // scenario,integrator,stabilization,dt,tolerance,error_m,...,cpu_s_per_sim_s(9),..,finite(12)
    ASSERT_GE(f.size(), 13u) << line;
    if (f[0] != "surface_chain" || f[12] != "1" || !(std::stod(f[5]) <= 1e-6))
      continue;
    if (std::stod(f[9]) < bench_cost)
    {
      bench_cost = std::stod(f[9]);
      bench_integrator = f[1];
      bench_dt = std::stod(f[3]);
    }
  }
  ASSERT_FALSE(bench_integrator.empty());

  const BuiltScene scene = shippedScene("surface_chain");
  StudyRequest request;
  request.horizon = 1.0;  // the benchmark's span
  request.error_target = 1e-6;
  const StudyResult result = runMethodStudy(scene.scene, scene.initial_state, request);
  ASSERT_GE(result.recommended, 0);
  const StudyRun& chosen = result.runs[result.recommended];
  EXPECT_EQ(chosen.method.integrator, bench_integrator) << studyMethodLabel(chosen.method);
  EXPECT_EQ(std::floor(std::log10(chosen.method.dt) + 1e-9),
            std::floor(std::log10(bench_dt) + 1e-9))
      << studyMethodLabel(chosen.method) << " against the benchmark's dt " << bench_dt;
  EXPECT_LE(chosen.position_error, 1e-6);
  // nothing that met the target was cheaper
  for (const StudyRun& run : result.runs)
    if (run.finite && run.position_error <= 1e-6)
    {
      EXPECT_GE(run.cpu_time_per_sim_second, chosen.cpu_time_per_sim_second);
    }
}

TEST(MethodStudy, NoRecommendationBelowTheReferenceError)
{
  const BuiltScene bead = shippedScene("bead_orbit");
  StudyRequest request;
  request.horizon = 0.1;
  request.error_target = 1e-300;  // below any reference's error: nothing can be certified
  request.methods = { StudyMethod{ "rk4", Stabilization::None, 1e-3, 0.0 } };
  const StudyResult result = runMethodStudy(bead.scene, bead.initial_state, request);
  ASSERT_EQ(result.runs.size(), 1u);
  EXPECT_EQ(result.recommended, -1);
}

TEST(MethodStudy, BadRequestsNameTheField)
{
  StudyRequest good;
  good.methods = { StudyMethod{ "rk4", Stabilization::None, 1e-3, 0.0 },
                   StudyMethod{ "dopri5", Stabilization::Projection, 1e-2, 1e-8 } };
  EXPECT_NO_THROW(validateStudyRequest(good));
  StudyRequest r = good;
  r.horizon = -1;
  expectRefused(r, "horizon");
  r.horizon = NAN;
  expectRefused(r, "horizon");
  r.horizon = 3601;
  expectRefused(r, "horizon");
  r = good;
  r.error_target = -1e-6;
  expectRefused(r, "error_target");
  r = good;
  r.methods[1].integrator = "leapfrog9";
  expectRefused(r, "methods[1].integrator");
  r = good;
  r.methods[0].dt = 0.0;
  expectRefused(r, "methods[0].dt");
  r.methods[0].dt = 2.0;
  expectRefused(r, "methods[0].dt");
  r = good;
  r.methods[0].tolerance = 1e-6;  // rk4 takes none
  expectRefused(r, "methods[0].tolerance");
  r = good;
  r.methods[1].tolerance = 10.0;
  expectRefused(r, "methods[1].tolerance");
  r = good;
  r.methods.assign(257, good.methods[0]);
  expectRefused(r, "methods");
}

TEST(MethodStudy, DefaultMethodsSpanFourDecadesInsideTheRange)
{
  for (const double dt : { 1e-3, 1e-6, 1.0, 0.05 })
  {
    SCOPED_TRACE(dt);
    const std::vector<StudyMethod> methods = studyDefaultMethods(dt);
    std::vector<double> dts;
    int adaptive = 0;
    for (const StudyMethod& m : methods)
    {
      EXPECT_TRUE(limits::DT.contains(m.dt)) << m.dt;
      if (findIntegrator(m.integrator).adaptive)
        ++adaptive;
      else if (std::find(dts.begin(), dts.end(), m.dt) == dts.end())
        dts.push_back(m.dt);
    }
    EXPECT_EQ(dts.size(), 4u);
    EXPECT_EQ(adaptive, 4);
    // the current dt is one of them
    EXPECT_NE(std::find_if(dts.begin(), dts.end(),
                           [dt](double d) { return std::abs(d - dt) < 1e-12 * dt; }),
              dts.end());
  }
}

// A cancel is seen inside a run: a run that would take hours stops within a wall-clock deadline.
TEST(MethodStudy, CancelStopsWithinARun)
{
  const BuiltScene chain = shippedScene("chain");
  StudyRequest request;
  request.horizon = 3600.0;
  request.methods = { StudyMethod{ "explicit_euler", Stabilization::None, 1e-6, 0.0 } };
  std::atomic<bool> cancel{ false };
  std::atomic<int> progress_calls{ 0 };
  std::thread canceller(
      [&]
      {
        // cancel once the study is in its runs (or its reference), polled on wall time
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
        while (progress_calls.load() < 1 && std::chrono::steady_clock::now() < deadline)
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        cancel = true;
      });
  const auto start = std::chrono::steady_clock::now();
  const StudyResult result = runMethodStudy(
      chain.scene, chain.initial_state, request,
      [&](int, int, const std::string&) { ++progress_calls; }, &cancel);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  canceller.join();
  EXPECT_TRUE(result.cancelled);
  EXPECT_TRUE(result.runs.empty());
  // the reference alone would take minutes and the run hours; generous for a busy machine
  EXPECT_LT(seconds, 20.0);
}

// From a state part-way through a driven scene, runs end at the state's time plus the horizon.
TEST(MethodStudy, RunsFromAStateKeepItsTime)
{
  const BuiltScene shaken = shippedScene("shaken_chain");
  State start = shaken.initial_state;
  start.time = 0.25;
  StudyRequest request;
  request.horizon = 0.1;
  request.methods = { StudyMethod{ "rk4", Stabilization::Projection, 1e-3, 0.0 } };
  const StudyResult result = runMethodStudy(shaken.scene, start, request);
  ASSERT_EQ(result.runs.size(), 1u);
  EXPECT_NEAR(result.runs[0].end_time, 0.35, 1e-9);
  EXPECT_TRUE(result.runs[0].finite) << result.runs[0].failure;
  EXPECT_LT(result.runs[0].position_error, 1e-6);
}
