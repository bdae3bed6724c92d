// The runner without ROS: requests applied between batches, ~step in batches that a pause stops,
// faults that keep every good batch, snapshots with a clock that never repeats, and the core's
// statistics handed to each reader once. Deadlines are wall-clock and generous: they bound a
// wait for something that must happen, they do not time anything.
#include "constrained_particles/ros/simulation_runner.hpp"
#include "scene_fixtures.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <thread>

namespace constrained_particles
{
namespace
{
using namespace std::chrono_literals;

using fixtures::parametersFor;
using fixtures::scene;

SceneDescription chainOf(int n)
{
  SceneDescription d = scene("chain");
  ChainChange change;
  change.num_particles = n;
  change.link_length = 0.05;
  change.particle_mass = 0.1;
  setChains(d, change);
  return d;
}

/// Polls `predicate` until it holds or `timeout` of wall time passed.
template <typename Predicate>
bool waitFor(Predicate predicate, std::chrono::seconds timeout = 60s)
{
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!predicate())
  {
    if (std::chrono::steady_clock::now() > deadline)
      return false;
    std::this_thread::sleep_for(2ms);
  }
  return true;
}

TEST(SimulationRunner, SceneRequestsCountScenesByOneAndARefusalChangesNothing)
{
  SimulationRunner runner(parametersFor("chain"), scene("chain"));
  ASSERT_EQ(runner.snapshot()->scene_serial, 1u);
  runner.start(true);
  ChainChange chain;
  chain.num_particles = 8;
  chain.link_length = 0.2;
  chain.particle_mass = 0.1;
  const RunnerReply changed = runner.setChain(chain);
  ASSERT_TRUE(changed.success) << changed.message;
  EXPECT_EQ(runner.snapshot()->scene_serial, 2u);
  EXPECT_EQ(runner.snapshot()->model->numParticles(), 8);
  chain.num_particles = 0;
  const RunnerReply refused = runner.setChain(chain);
  EXPECT_FALSE(refused.success);
  EXPECT_EQ(refused.field, "num_particles") << refused.message;
  // the chain scene has no surface to replace: the scene's own refusal
  const RunnerReply no_surface = runner.setSurface("plane", { 0.0, 0.0, 0.0 }, "");
  EXPECT_FALSE(no_surface.success);
  EXPECT_NE(no_surface.message.find("has no surface"), std::string::npos) << no_surface.message;
  EXPECT_EQ(runner.snapshot()->scene_serial, 2u);
  EXPECT_EQ(runner.snapshot()->model->numParticles(), 8);
  EXPECT_TRUE(runner.reset("").success);
  EXPECT_EQ(runner.snapshot()->scene_serial, 3u);
}

TEST(SimulationRunner, StepTakesExactlyTheStepsAskedAndReportsThem)
{
  SimulationRunner runner(parametersFor("chain"), scene("chain"));
  runner.start(true);
  StepStatistics s;
  const std::shared_ptr<const Snapshot> start = runner.snapshot(SimulationRunner::Reader::State, s);
  const RunnerReply reply = runner.step(250);
  ASSERT_TRUE(reply.success) << reply.message;
  EXPECT_EQ(reply.steps_taken, 250u);
  const auto snap = runner.snapshot();
  EXPECT_EQ(snap->state.steps, 250u);
  EXPECT_NEAR(snap->state.time, 250 * snap->parameters.step.dt, 1e-12);
  EXPECT_NEAR(reply.sim_time, snap->state.time, 1e-12);
  EXPECT_TRUE(snap->paused);
  EXPECT_FALSE(snap->stepping);
  // the state reader gets every step once; the diagnostics reader has its own copy
  EXPECT_EQ(runner.snapshot(SimulationRunner::Reader::State, s)->state.steps, 250u);
  EXPECT_EQ(s.steps, 250);
  EXPECT_GT(s.solve.factorizations, 0);
  EXPECT_TRUE(s.projection.converged);
  std::uint64_t links = 0;
  forEachEffectCount(s.effects,
                     [&](const char* kind, std::uint64_t count)
                     {
                       if (std::string(kind) == "link")
                         links = count;
                     });
  EXPECT_GT(links, 0u);
  runner.snapshot(SimulationRunner::Reader::State, s);
  EXPECT_EQ(s.steps, 0);
  runner.snapshot(SimulationRunner::Reader::Diagnostics, s);
  EXPECT_EQ(s.steps, 250);
  // the constraint forces handed out are the last step's, not the start's
  EXPECT_TRUE(snap->constraint_forces.allFinite());
  EXPECT_GT((snap->constraint_forces - start->constraint_forces).norm(), 1e-6);
}

TEST(SimulationRunner, RefusesStepWhileRunningOrOutOfRange)
{
  SimulationRunner runner(parametersFor("chain"), scene("chain"));
  runner.start(false);
  RunnerReply reply = runner.step(10);
  EXPECT_FALSE(reply.success);
  EXPECT_NE(reply.message.find("~pause"), std::string::npos) << reply.message;
  ASSERT_TRUE(runner.pause().success);
  reply = runner.step(0);
  EXPECT_FALSE(reply.success);
  EXPECT_EQ(reply.field, "steps");
  EXPECT_NE(reply.message.find("[1, 1e+06]"), std::string::npos) << reply.message;
}

TEST(SimulationRunner, LongStepRunsInBatchesAndAPauseStopsItAtTheNextBatch)
{
  SimulationRunner runner(parametersFor("chain"), chainOf(300));
  runner.start(true);
  auto step = std::async(std::launch::async, [&] { return runner.step(1000000); });
  // snapshots keep coming while it runs: publishers are never held up by it
  ASSERT_TRUE(
      waitFor([&] { return runner.snapshot()->stepping && runner.snapshot()->state.steps > 0; }));
  const std::uint64_t first = runner.snapshot()->state.steps;
  ASSERT_TRUE(waitFor([&] { return runner.snapshot()->state.steps > first; }));
  const RunnerReply paused = runner.pause();
  ASSERT_TRUE(paused.success);
  // applied at the first batch boundary: at most the batch under way finished meanwhile
  EXPECT_LE(paused.batches_waited, 1u);
  ASSERT_EQ(step.wait_for(60s), std::future_status::ready);
  const RunnerReply reply = step.get();
  EXPECT_FALSE(reply.success);
  EXPECT_NE(reply.message.find("~pause"), std::string::npos) << reply.message;
  EXPECT_GT(reply.steps_taken, first);
  EXPECT_LT(reply.steps_taken, 1000000u);
  EXPECT_EQ(runner.snapshot()->state.steps, reply.steps_taken);
  EXPECT_FALSE(runner.snapshot()->stepping);
}

TEST(SimulationRunner, StepStoppedByAResetAnswersWhereItGot)
{
  SimulationRunner runner(parametersFor("chain"), chainOf(300));
  runner.start(true);
  auto step = std::async(std::launch::async, [&] { return runner.step(1000000); });
  ASSERT_TRUE(waitFor([&] { return runner.snapshot()->state.steps > 0; }));
  ASSERT_TRUE(runner.reset("").success);
  ASSERT_EQ(step.wait_for(60s), std::future_status::ready);
  const RunnerReply reply = step.get();
  EXPECT_FALSE(reply.success);
  EXPECT_NE(reply.message.find("reset"), std::string::npos) << reply.message;
  // the time its steps reached, not the new scene's 0
  EXPECT_GT(reply.steps_taken, 0u);
  EXPECT_NEAR(reply.sim_time, reply.steps_taken * runner.snapshot()->parameters.step.dt, 1e-9);
  EXPECT_EQ(runner.snapshot()->state.steps, 0u);
}

TEST(SimulationRunner, ReconfiguredForcesStayWithTheirScene)
{
  SimulationRunner runner(parametersFor("chain"), scene("chain"));
  runner.start(true);
  ASSERT_TRUE(runner
                  .reconfigure([](NodeParameters& p, const SceneDescription&)
                               { p.overrides.gravity = Vec3(0, 0, -1.0); })
                  .success);
  EXPECT_EQ(sceneGravity(*runner.snapshot()->scene), Vec3(0, 0, -1.0));
  // kept by a reset of the same scene, gone with a named one, and not brought back later
  ASSERT_TRUE(runner.reset("").success);
  EXPECT_EQ(sceneGravity(*runner.snapshot()->scene), Vec3(0, 0, -1.0));
  ASSERT_TRUE(runner.reset("chain").success);
  EXPECT_EQ(sceneGravity(*runner.snapshot()->scene), Vec3(0, 0, -9.81));
  ASSERT_TRUE(
      runner.reconfigure([](NodeParameters& p, const SceneDescription&) { p.step.dt = 0.002; })
          .success);
  EXPECT_EQ(sceneGravity(*runner.snapshot()->scene), Vec3(0, 0, -9.81));
  EXPECT_EQ(runner.snapshot()->parameters.step.dt, 0.002);
}

// A change of gravity or damping recompiles the scene's forces: the bends a chain's
// bend_stiffness makes stay (sceneForces), beside the file's own and the new gravity.
TEST(SimulationRunner, ReconfiguredGravityKeepsAChainsBends)
{
  SimulationRunner runner(parametersFor("cable"), scene("cable"));
  runner.start(true);
  auto bends = [&]
  {
    int count = 0;
    for (const Force& force : runner.snapshot()->model->scene().forces)
      count += std::holds_alternative<BendingForce>(force) ? 1 : 0;
    return count;
  };
  ASSERT_EQ(bends(), 9);  // the clamp's (the file's) and one at each of the chain's 8 inner ones
  ASSERT_TRUE(runner
                  .reconfigure([](NodeParameters& p, const SceneDescription&)
                               { p.overrides.gravity = Vec3(0, 0, -1.0); })
                  .success);
  EXPECT_EQ(sceneGravity(*runner.snapshot()->scene), Vec3(0, 0, -1.0));
  EXPECT_EQ(bends(), 9);
}

TEST(SimulationRunner, FaultKeepsEveryGoodBatch)
{
  // no stabilisation: the links drift until the error passes ~max_constraint_error
  NodeParameters p = parametersFor("chain");
  p.max_constraint_error = 0.5;
  p.step.stabilization = Stabilization::None;
  p.step.integrator = "semi_implicit_euler";
  p.step.dt = 0.001;
  p.step_given = { "stabilization", "integrator", "dt" };
  const SceneDescription chain = chainOf(300);
  // the step at which it faults, one step at a time
  const BuiltScene built = buildScene(chain);
  StepSettings settings = chain.solver.applyTo(StepSettings{});
  settings.stabilization = p.step.stabilization;
  settings.integrator = p.step.integrator;
  settings.dt = p.step.dt;
  Simulator reference(built.scene, built.initial_state, settings);
  std::uint64_t fault_step = 0;
  while (fault_step < 1000000 &&
         reference.diagnostics().max_position_error <= p.max_constraint_error)
  {
    reference.step();
    ++fault_step;
  }
  ASSERT_GT(fault_step, 2000u);
  ASSERT_LT(fault_step, 1000000u);
  std::cerr << "faults at step " << fault_step << "\n";

  SimulationRunner runner(p, chain);
  runner.start(true);
  const RunnerReply reply = runner.step(1000000);
  EXPECT_FALSE(reply.success);
  EXPECT_NE(reply.message.find("constraint error"), std::string::npos) << reply.message;
  const auto snap = runner.snapshot();
  EXPECT_TRUE(snap->faulted);
  // the good steps before the fault are kept: all but the last chunk's (a few ms of wall time)
  EXPECT_LT(reply.steps_taken, fault_step);
  EXPECT_GT(reply.steps_taken, fault_step / 2);
  EXPECT_EQ(snap->state.steps, reply.steps_taken);
  EXPECT_LE(snap->diagnostics.max_position_error, p.max_constraint_error);
  EXPECT_EQ(snap->fault_reason.find("forces from outside"), std::string::npos)
      << snap->fault_reason;
  EXPECT_FALSE(runner.step(1).success);
  ASSERT_TRUE(runner.reset("").success);
  EXPECT_FALSE(runner.snapshot()->faulted);
}

TEST(SimulationRunner, AFaultUnderAPushSaysThePushActed)
{
  // 1e9 N (inside limits::FORCE) on a 1 kg particle of the chain: no step can follow it
  SimulationRunner runner(parametersFor("chain"), scene("chain"));
  runner.start(true);
  ASSERT_TRUE(runner.applyForce(4, Vec3(0.0, 0.0, 1e9), 0.0).success);
  EXPECT_FALSE(runner.step(1000).success);
  const auto snap = runner.snapshot();
  ASSERT_TRUE(snap->faulted);
  EXPECT_NE(snap->fault_reason.find("forces from outside acted (1 ~apply_force, 0 drags, 0 "
                                    "~wrench_command)"),
            std::string::npos)
      << snap->fault_reason;
}

TEST(SimulationRunner, Dopri5AtItsGuardsFaultsNamingTheTolerance)
{
  // a 1 mm, 1 mg chain at dt = 1 s and the tightest tolerance: the step cannot be met in
  // bounded work, so dopri5 ends it unchecked at a guard; with max_substeps 1 there is no stiff
  // fallback to take it, and the runner faults, keeping t = 0
  NodeParameters p = parametersFor("chain");
  p.step.integrator = "dopri5";
  p.step.adaptive_tolerance = limits::ADAPTIVE_TOLERANCE.low;
  p.step.dt = 1.0;
  p.step.max_substeps = 1;
  p.step_given = { "integrator", "adaptive_tolerance", "dt", "max_substeps" };
  SceneDescription chain = scene("chain");
  ChainChange change;
  change.num_particles = 50;
  change.link_length = 1e-3;
  change.particle_mass = 1e-6;
  setChains(chain, change);
  SimulationRunner runner(p, chain);
  runner.start(true);
  const RunnerReply reply = runner.step(1);
  EXPECT_FALSE(reply.success);
  EXPECT_NE(reply.message.find("adaptive_tolerance"), std::string::npos) << reply.message;
  EXPECT_NE(reply.message.find("raise ~max_substeps above 1"), std::string::npos) << reply.message;
  EXPECT_EQ(reply.steps_taken, 0u);
  EXPECT_TRUE(runner.snapshot()->faulted);
  EXPECT_EQ(runner.snapshot()->state.steps, 0u);
}

TEST(SimulationRunner, StampsNeverRepeatOrGoBackAcrossResetsAndTeleports)
{
  SimulationRunner runner(parametersFor("chain"), scene("chain"));
  runner.start(true);
  double last = runner.snapshot()->stamp;
  const std::uint64_t scene_serial = runner.snapshot()->scene_serial;
  ASSERT_TRUE(runner.step(100).success);
  EXPECT_NEAR(runner.snapshot()->stamp - last, 100 * runner.snapshot()->parameters.step.dt, 1e-9);
  last = runner.snapshot()->stamp;
  ASSERT_TRUE(runner.reset("").success);
  EXPECT_EQ(runner.snapshot()->state.time, 0.0);
  EXPECT_NEAR(runner.snapshot()->stamp, last + SimulationRunner::TIME_JUMP, 1e-9);
  EXPECT_GT(runner.snapshot()->scene_serial, scene_serial);
  last = runner.snapshot()->stamp;
  const Points positions = runner.snapshot()->state.positions;
  ASSERT_TRUE(runner.setState(positions, Points(3, 0)).success);
  EXPECT_NEAR(runner.snapshot()->stamp, last + SimulationRunner::TIME_JUMP, 1e-9);
  last = runner.snapshot()->stamp;
  // a refused change changes nothing, not even the clock
  EXPECT_FALSE(runner.reset("no_such_scene").success);
  EXPECT_EQ(runner.snapshot()->stamp, last);
}

TEST(SimulationRunner, RefusedReconfigureNamesTheFieldAndKeepsEverything)
{
  SimulationRunner runner(parametersFor("chain"), scene("chain"));
  runner.start(true);
  const double dt = runner.snapshot()->parameters.step.dt;
  const RunnerReply reply =
      runner.reconfigure([](NodeParameters& p, const SceneDescription&) { p.step.dt = -1.0; });
  EXPECT_FALSE(reply.success);
  EXPECT_EQ(reply.field, "~dt");
  EXPECT_EQ(runner.snapshot()->parameters.step.dt, dt);
  ASSERT_TRUE(runner.step(10).success);
  EXPECT_NEAR(runner.snapshot()->state.time, 10 * dt, 1e-12);
}

TEST(BehindMonitor, OnAfterTwoLaggingWindowsInARowOffAfterAFastOne)
{
  BehindMonitor monitor;
  // one slow window of a busy machine, then a middling one: not behind
  EXPECT_FALSE(monitor.update(0.5));
  EXPECT_FALSE(monitor.update(0.03));
  EXPECT_FALSE(monitor.update(0.06));
  EXPECT_FALSE(monitor.update(0.0));
  // two in a row: behind, and it stays while the lag is middling
  EXPECT_FALSE(monitor.update(0.06));
  EXPECT_TRUE(monitor.update(0.06));
  EXPECT_TRUE(monitor.update(0.03));
  EXPECT_TRUE(monitor.update(0.5));
  // off after one window under 1 %
  EXPECT_FALSE(monitor.update(0.005));
  EXPECT_FALSE(monitor.update(0.06));
}

TEST(SimulationRunner, BehindOnlyOnASustainedLagAndNotWhilePaused)
{
  NodeParameters p = parametersFor("chain");
  p.real_time_factor = limits::REAL_TIME_FACTOR.high;
  SimulationRunner runner(p, chainOf(2000));
  runner.start(false);
  // 2,000 particles cannot run at 100x real time: behind within a few rate windows
  EXPECT_TRUE(waitFor([&] { return runner.snapshot()->behind; }));
  EXPECT_GT(runner.snapshot()->real_time_factor, 0.0);
  ASSERT_TRUE(runner.pause().success);
  EXPECT_FALSE(runner.snapshot()->behind);
}

// A small scene at a tiny dt cannot reach a high real-time factor even though each batch takes
// the steps due at its start: behind says so (it did not when only dropped time counted).
TEST(SimulationRunner, BehindWhenTheWantedRateIsNotReachedAtATinyStep)
{
  NodeParameters p = parametersFor("chain");
  p.real_time_factor = limits::REAL_TIME_FACTOR.high;
  p.step.dt = 1e-6;
  p.step_given.push_back("dt");
  SimulationRunner runner(p, chainOf(10));
  runner.start(false);
  EXPECT_TRUE(waitFor([&] { return runner.snapshot()->behind; }));
  EXPECT_LT(runner.snapshot()->real_time_factor, 0.5 * limits::REAL_TIME_FACTOR.high);
}

// Following /clock, a clock that went back (a bag played again) is a new epoch even while paused:
// the scene stands for the new clock at once, not after the next unpause.
TEST(SimulationRunner, APausedRunnerNoticesTheClockGoingBack)
{
  constexpr std::int64_t C0 = 1733000000000000000;
  NodeParameters p = parametersFor("chain");
  p.follow_clock = true;
  SimulationRunner runner(p, scene("chain"));
  runner.start();
  std::int64_t clock = C0;
  ASSERT_TRUE(waitFor(  // a clock moving on by 1 ms each poll: the scene follows it
      [&]
      {
        runner.followClock(clock += 1000000);
        return runner.snapshot()->state.steps > 0;
      }));
  ASSERT_TRUE(runner.pause().success);
  EXPECT_EQ(runner.snapshot()->epoch, 0u);
  runner.followClock(C0 - 10000000000);  // ten seconds back
  EXPECT_TRUE(waitFor([&] { return runner.snapshot()->epoch == 1u; }));
  EXPECT_TRUE(runner.snapshot()->paused);
}

// An ~attach waiting for its frame's pose is refused by a reset that comes first, naming it:
// the particle it asked for belonged to the scene that was.
TEST(SimulationRunner, AWaitingAttachIsRefusedByAReset)
{
  SimulationRunner runner(parametersFor("chain"), scene("chain"));
  runner.start();
  std::atomic<bool> asked{ false }, resetting{ false };
  // tf never has the frame; the first look holds the physics thread until the reset is queued
  auto never = [&](std::int64_t) -> std::optional<Eigen::Isometry3d>
  {
    if (!asked.exchange(true))
    {
      waitFor([&] { return resetting.load(); }, 10s);
      // the reset's request is in the queue by then (queued at once after `resetting`), well
      // inside the attach's 1 s deadline
      std::this_thread::sleep_for(300ms);
    }
    return std::nullopt;
  };
  auto attach = std::async(std::launch::async,
                           [&] { return runner.attach(4, "hand", Vec3::Zero(), true, never); });
  ASSERT_TRUE(waitFor([&] { return asked.load(); }));
  resetting = true;
  EXPECT_TRUE(runner.reset("").success);
  ASSERT_EQ(attach.wait_for(60s), std::future_status::ready);
  const RunnerReply reply = attach.get();
  EXPECT_FALSE(reply.success);
  EXPECT_EQ(reply.field, "particle");
  EXPECT_NE(reply.message.find("a reset or scene change came first"), std::string::npos)
      << reply.message;
  EXPECT_TRUE(runner.snapshot()->model->tracked().empty());  // nothing attached
}

TEST(SimulationRunner, StopRefusesWaitingRequestsAndEndsAStep)
{
  SimulationRunner runner(parametersFor("chain"), chainOf(300));
  runner.start(true);
  auto step = std::async(std::launch::async, [&] { return runner.step(1000000); });
  ASSERT_TRUE(waitFor([&] { return runner.snapshot()->state.steps > 0; }));
  EXPECT_TRUE(runner.stop(10s));
  ASSERT_EQ(step.wait_for(60s), std::future_status::ready);
  EXPECT_FALSE(step.get().success);
  EXPECT_FALSE(runner.pause().success);
}

}  // namespace

/// Runs `runner` until a new accuracy report (after `after`) arrives; null at the deadline.
std::shared_ptr<const AccuracyReport> nextReport(SimulationRunner& runner, std::uint64_t after)
{
  std::shared_ptr<const AccuracyReport> report;
  waitFor(
      [&]
      {
        report = runner.snapshot()->accuracy;
        return report && report->serial > after;
      });
  return report && report->serial > after ? report : nullptr;
}

// The live accuracy: explicit Euler's error against the shadow grows over a window and with a
// longer window, and switching to rk4 shrinks it by orders of magnitude.
TEST(SimulationRunner, AccuracyWindowMeasuresTheLiveMethod)
{
  NodeParameters p = parametersFor("chain");
  p.step.integrator = "explicit_euler";
  p.step_given = { "integrator" };
  p.real_time_factor = 5.0;  // windows come faster; the shadow still keeps up
  p.accuracy_window = 0.2;
  SimulationRunner runner(p, scene("chain"));
  runner.start();
  const auto euler = nextReport(runner, 0);
  ASSERT_TRUE(euler);
  EXPECT_EQ(euler->integrator, "explicit_euler");
  EXPECT_NEAR(euler->window, 0.2, 1e-9);
  ASSERT_GE(euler->position_errors.size(), 4u);
  EXPECT_GT(euler->position_error, 1e-5);
  // the error grows within the window: the last sample's is over the first's
  EXPECT_GT(euler->position_errors.back(), euler->position_errors.front());
  EXPECT_NEAR(euler->error_growth_rate, euler->position_error / euler->window, 1e-12);
  EXPECT_GT(euler->reference_cpu_per_sim_second, 0.0);
  EXPECT_GT(euler->live_cpu_per_sim_second, 0.0);

  // a longer window: a larger error at its end
  ASSERT_TRUE(
      runner
          .reconfigure([](NodeParameters& c, const SceneDescription&) { c.accuracy_window = 0.8; })
          .success);
  const auto longer = nextReport(runner, euler->serial);
  ASSERT_TRUE(longer);
  EXPECT_NEAR(longer->window, 0.8, 1e-9);
  EXPECT_GT(longer->position_error, euler->position_error);
  EXPECT_GE(longer->abandoned, 1u);  // the reconfigure cut the open window short

  ASSERT_TRUE(runner
                  .reconfigure([](NodeParameters& c, const SceneDescription&)
                               { c.step.integrator = "rk4"; })
                  .success);
  auto rk4 = nextReport(runner, longer->serial);
  ASSERT_TRUE(rk4);
  EXPECT_EQ(rk4->integrator, "rk4");
  EXPECT_LT(rk4->position_error, 1e-3 * longer->position_error);
}

// A shadow that cannot keep up never slows stepping: windows are skipped and counted instead.
TEST(SimulationRunner, AccuracyWindowsAreSkippedNotWaitedFor)
{
  NodeParameters p = parametersFor("chain");
  p.real_time_factor = 100.0;
  p.accuracy_window = 0.01;  // ten live steps per window against a reference run each time
  SimulationRunner runner(p, chainOf(500));
  runner.start();
  const double start = runner.snapshot()->state.time;
  // the shadow's first window (a stiff chain to 1e-12) takes longer than the live one
  ASSERT_TRUE(waitFor([&] { return runner.snapshot()->skipped_windows > 0; }));
  // and stepping went on meanwhile, windows past the first one's end
  EXPECT_GT(runner.snapshot()->state.time, start + 2 * p.accuracy_window);
}

// An applied force acts on exactly ceil(duration / dt) steps, however the steps are chunked,
// ends a ~step that reaches its last step reported gone, and bad requests change nothing.
TEST(SimulationRunner, AppliedForcesActOnTheirStepsExactly)
{
  SimulationRunner runner(parametersFor("bead"), scene("bead"));
  runner.start(true);
  StepStatistics s;
  runner.snapshot(SimulationRunner::Reader::State, s);
  // 10.5 ms at dt = 1 ms: 11 steps; one within 1e-9 dt of 11 ms counts as 11 too
  ASSERT_TRUE(runner.applyForce(0, Vec3(1.0, 0.0, 0.0), 0.0105).success);
  ASSERT_TRUE(runner.applyForce(0, Vec3(0.0, 1.0, 0.0), 0.011 + 1e-13).success);
  EXPECT_EQ(runner.snapshot()->applied_forces, 2u);
  ASSERT_TRUE(runner.step(10).success);
  EXPECT_EQ(runner.snapshot()->applied_forces, 2u);
  ASSERT_TRUE(runner.step(1).success);  // the 11th: both end with it, not a step later
  EXPECT_EQ(runner.snapshot()->applied_forces, 0u);
  ASSERT_TRUE(runner.step(30).success);
  runner.snapshot(SimulationRunner::Reader::State, s);
  std::uint64_t pushes = 0;
  forEachEffectCount(s.effects,
                     [&](const char* kind, std::uint64_t count)
                     {
                       if (std::string(kind) == "external")
                         pushes = count;
                     });
  // rk4: four evaluations per step, 11 steps each, and the stability estimate's evaluation at the
  // first step after the change
  EXPECT_EQ(pushes, 2u * (11u * 4u + 1u));
  // until cleared; the most at once; bad requests name the field and change nothing
  for (std::size_t k = 0; k < Perturbations::MAX_APPLIED_FORCES; ++k)
    ASSERT_TRUE(runner.applyForce(0, Vec3(0.0, 0.0, 1e-3), 0.0).success);
  EXPECT_FALSE(runner.applyForce(0, Vec3::Zero(), 0.0).success);
  EXPECT_EQ(runner.applyForce(1, Vec3::Zero(), 0.0).field, "particle");
  EXPECT_EQ(runner.applyForce(0, Vec3(0.0, NAN, 0.0), 0.0).field, "force.y");
  EXPECT_EQ(runner.applyForce(0, Vec3::Zero(), -1.0).field, "duration");
  EXPECT_EQ(runner.snapshot()->applied_forces, Perturbations::MAX_APPLIED_FORCES);
  const RunnerReply cleared = runner.clearForces();
  EXPECT_NE(cleared.message.find("cleared 1000"), std::string::npos) << cleared.message;
  EXPECT_EQ(runner.snapshot()->applied_forces, 0u);
}

// A drag pulls until released; one made for another scene (a marker held across a reset) is
// dropped; a very heavy particle is pulled (slower), not refused; a reset lets go.
TEST(SimulationRunner, DragsFollowTheirSceneAndEndOnRelease)
{
  SimulationRunner runner(parametersFor("chain"), scene("chain"));
  runner.start(true);
  const std::uint64_t serial = runner.snapshot()->scene_serial;
  runner.drag(serial + 1, 4, Vec3(1.0, 0.0, 1.0));  // another scene's: dropped
  ASSERT_TRUE(runner.step(1).success);
  EXPECT_EQ(runner.snapshot()->dragged_particles, 0u);
  runner.drag(serial, 4, Vec3(1.0, 0.0, 1.0));
  ASSERT_TRUE(waitFor([&] { return runner.snapshot()->dragged_particles == 1u; }));
  ASSERT_TRUE(runner.step(100).success);
  runner.release(serial, 4);
  ASSERT_TRUE(waitFor([&] { return runner.snapshot()->dragged_particles == 0u; }));
  // 1e6 kg: w = 0.5 rad/s keeps c = 2 m w inside limits::DAMPING
  SceneDescription heavy = scene("chain");
  ChainChange change;
  change.num_particles = 5;
  change.particle_mass = 1e6;
  setChains(heavy, change);
  SimulationRunner heavy_runner(parametersFor("chain"), heavy);
  heavy_runner.start(true);
  const std::uint64_t heavy_serial = heavy_runner.snapshot()->scene_serial;
  heavy_runner.drag(heavy_serial, 4, Vec3(1.0, 0.0, 1.0));
  ASSERT_TRUE(waitFor([&] { return heavy_runner.snapshot()->dragged_particles == 1u; }));
  const RunnerReply stepped = heavy_runner.step(100);
  EXPECT_TRUE(stepped.success) << stepped.message;
  EXPECT_TRUE(isFinite(heavy_runner.snapshot()->state));
  ASSERT_TRUE(heavy_runner.reset("").success);
  EXPECT_EQ(heavy_runner.snapshot()->dragged_particles, 0u);
}

TEST(SimulationRunner, AnOverdrawnEnergyBudgetHandsTheRunToTheFallbackAndSaysSo)
{
  // explicit Euler gains energy on the default chain until about t = 2 s; 3,000 steps through
  // ~step: the run goes on under fast_projection, not faulted, and the snapshot says why until
  // a reset hands it back to the integrator
  NodeParameters p = parametersFor("chain");
  p.step.integrator = "explicit_euler";
  p.step_given = { "integrator" };
  SimulationRunner runner(p, scene("chain"));
  runner.start(true);
  const RunnerReply reply = runner.step(3000);
  EXPECT_TRUE(reply.success) << reply.message;
  EXPECT_EQ(reply.steps_taken, 3000u);
  const std::shared_ptr<const Snapshot> snap = runner.snapshot();
  EXPECT_FALSE(snap->faulted) << snap->fault_reason;
  EXPECT_NE(snap->energy_fallback.find("energy budget overdrawn at t = "), std::string::npos)
      << snap->energy_fallback;
  EXPECT_NE(snap->energy_fallback.find("explicit_euler"), std::string::npos);
  EXPECT_NE(snap->energy_fallback.find("fast_projection takes the steps"), std::string::npos);
  const RunnerReply reset = runner.reset("");
  EXPECT_TRUE(reset.success) << reset.message;
  EXPECT_TRUE(runner.snapshot()->energy_fallback.empty());
}

}  // namespace constrained_particles
