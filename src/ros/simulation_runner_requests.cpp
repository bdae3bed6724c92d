/// @file simulation_runner_requests.cpp
/// @brief SimulationRunner's requests: each queued as a lambda that runs on the physics thread
/// between batches (split from simulation_runner.cpp, which keeps the thread, batches and
/// snapshots).
#include "constrained_particles/ros/simulation_runner.hpp"

#include "constrained_particles/ros/request_checks.hpp"

#include <algorithm>

namespace constrained_particles
{
RunnerReply SimulationRunner::reset(const std::string& scenario)
{
  return queue_.submit(
      [this, scenario]
      {
        apply(session_.forReset(scenario, parameters_.step));
        return acceptedReply("reset to scene '" + session_.scene()->name + "' (" +
                             std::to_string(simulator_->model().numParticles()) +
                             " particles, solve " + solveAlgorithmName(simulator_->model()) + "; " +
                             parameters_.step.integrator + " + " +
                             stabilizationName(parameters_.step.stabilization) +
                             ", dt = " + formatValue(parameters_.step.dt) + " s)");
      });
}

RunnerReply SimulationRunner::changeScene(const std::function<SceneSession::Candidate()>& make,
                                          const std::string& what)
{
  return queue_.submit(
      [this, make, what]
      {
        apply(make());
        return acceptedReply(what + "; scene '" + session_.scene()->name + "' reset (" +
                             std::to_string(simulator_->model().numParticles()) + " particles)");
      });
}

RunnerReply SimulationRunner::setSurface(const std::string& type,
                                         const std::vector<double>& coefficients,
                                         const std::string& expression, bool keep_state)
{
  const auto make = [this, type, coefficients, expression]
  { return session_.forSurface(type, coefficients, expression, parameters_.step); };
  if (keep_state)
    return queue_.submit(
        [this, make, type]
        {
          const SceneSession::Candidate candidate = make();
          const ProjectionReport report = simulator_->setSurfaces(candidate.built.scene.surfaces);
          session_.adoptChange(candidate.description);
          afterChange(true);  // the shadow's scene is not this one any more
          interruptStep("~set_surface");
          RunnerReply reply = acceptedReply(
              "surface set to '" + type +
              "', the state kept: projection moved particles by up to " +
              formatValue(report.max_displacement) + " m and changed velocities by up to " +
              formatValue(report.max_velocity_change) + " m/s");
          reply.max_displacement = report.max_displacement;
          return reply;
        });
  return changeScene(make, "surface set to '" + type + "'");
}

RunnerReply SimulationRunner::setObstacle(
    ObstacleChange change, const std::string& name, const std::string& shape,
    const std::function<std::string(const std::string&, const std::string&)>& holder_refusal)
{
  static const char* const DONE[] = { "added", "replaced", "removed" };
  return queue_.submit(
      [this, change, name, shape, holder_refusal]
      {
        const SceneSession::Candidate candidate =
            session_.forObstacle(change, name, shape, parameters_.step);
        // a carried shape's holder must be one the node can follow
        for (const Shape& placed : candidate.description.shapes)
          if (placed.name == name && placed.carried() && holder_refusal)
            if (const std::string why = holder_refusal(placed.frame, placed.topic); !why.empty())
              throw InvalidInput(placed.frame.empty() ? "shape.topic" : "shape.frame",
                                 "= '" + placed.frame + placed.topic + "' " + why);
        // the scene's obstacle contacts as its description now makes them; the rest (holders
        // attached at run time among it) is the simulator's own
        std::vector<Constraint> contacts;
        for (const Constraint& constraint : candidate.built.scene.constraints)
          if (isObstacleContact(constraint))
            contacts.push_back(constraint);
        const std::vector<Shape> carried = simulator_->model().carriers();
        const ProjectionReport report = simulator_->setObstacles(contacts);
        session_.adoptChange(candidate.description);
        // carried shapes added, removed or on another holder: their holders followed from now,
        // the rest kept (a new holder model restarts every holder's sampling: only if needed)
        const std::vector<Shape>& now = simulator_->model().carriers();
        if (!std::equal(carried.begin(), carried.end(), now.begin(), now.end(), sameCarrier))
          holders_.setModel(simulator_->model(), false);
        afterChange(true);  // the shadow's scene is not this one any more
        interruptStep("~set_obstacle");
        RunnerReply reply = acceptedReply(
            "obstacle '" + name + "' " + DONE[static_cast<int>(change)] +
            ", the state kept: particles moved out by up to " +
            formatValue(report.max_displacement) + " m, velocities changed by up to " +
            formatValue(report.max_velocity_change) + " m/s" +
            (report.change_steps > 1 ? " (too deep at once: the shape moved there in " +
                                           std::to_string(report.change_steps) + " steps)"
                                     : std::string()));
        reply.max_displacement = report.max_displacement;
        reply.max_velocity_change = report.max_velocity_change;
        return reply;
      });
}

RunnerReply SimulationRunner::setChain(const ChainChange& change)
{
  return changeScene([this, change] { return session_.forChain(change, parameters_.step); },
                     "chain set to " + std::to_string(change.num_particles) +
                         " particles, l = " + formatValue(change.link_length) +
                         " m, m = " + formatValue(change.particle_mass) + " kg");
}

RunnerReply SimulationRunner::setState(const Points& positions, const Points& velocities)
{
  return queue_.submit(
      [this, positions, velocities]
      {
        const ProjectionReport report = simulator_->setState(checkedTeleport(
            simulator_->state(), simulator_->model().numParticles(), positions, velocities));
        faulted_ = false;
        fault_reason_.clear();
        pacer_.jump();
        reanchor();
        holders_.rest(*simulator_);  // held where the teleport put them, until their next poses
        afterChange();
        // last: its snapshot must show the teleport whole
        interruptStep("~set_state");
        RunnerReply reply = acceptedReply("state set; projection moved particles by up to " +
                                          formatValue(report.max_displacement) +
                                          " m and changed velocities by up to " +
                                          formatValue(report.max_velocity_change) + " m/s");
        reply.max_displacement = report.max_displacement;
        return reply;
      });
}

RunnerReply SimulationRunner::pause()
{
  return queue_.submit(
      [this]
      {
        interruptStep("~pause");
        paused_ = true;
        return acceptedReply("paused");
      });
}

RunnerReply SimulationRunner::unpause()
{
  return queue_.submit(
      [this]
      {
        interruptStep("~unpause");
        paused_ = false;
        reanchor();
        // the stamps stand for later times now: each holder goes on from its motion, towards
        // its next poses
        holders_.resync(*simulator_);
        return acceptedReply(faulted_ ? "unpaused, but stepping is stopped (" + fault_reason_ + ")"
                                      : "running");
      });
}

RunnerReply SimulationRunner::step(std::uint64_t steps)
{
  // the promise outlives this call if the runner stops first
  auto promise = std::make_shared<std::promise<RunnerReply>>();
  std::future<RunnerReply> future = promise->get_future();
  RunnerReply immediate = queue_.submit(
      [this, steps, promise]
      {
        if (pacer_.source() == Pacer::Source::FollowClock)
          return refusedReply(
              "the node follows /clock (~follow_clock): it steps as the clock moves, "
              "never ahead of it");
        if (!paused_)
          return refusedReply("the simulation is running: call ~pause before ~step");
        if (faulted_)
          return refusedReply("stepping is stopped (" + fault_reason_ + ")");
        if (step_request_)
          return refusedReply("a ~step of " + std::to_string(step_request_->wanted) +
                              " steps is running (" + std::to_string(step_request_->taken) +
                              " taken): wait for it, or ~pause to stop it");
        checkSteps(steps);
        step_request_.emplace();
        step_request_->wanted = steps;
        step_request_->sim_time = simulator_->state().time;
        step_request_->reply = promise;
        return acceptedReply("step under way");
      });
  if (!immediate.success)
    return immediate;
  return queue_.await(future);
}

RunnerReply SimulationRunner::reconfigure(
    const std::function<void(NodeParameters&, const SceneDescription&)>& edit)
{
  return queue_.submit(
      [this, edit]
      {
        NodeParameters candidate = parameters_;
        // held: adoptChange below replaces the session's scene
        const std::shared_ptr<const SceneDescription> held = session_.scene();
        const SceneDescription& scene = *held;
        edit(candidate, scene);
        validateNodeParameters(candidate);
        // new forces recompile the model (and restart dopri5's step control): only on a change;
        // before the settings, so a refused force leaves the run as it was (the budget's
        // fallback too, which new settings end)
        if (const std::optional<SceneDescription> changed = session_.withGravityAndDamping(
                candidate.overrides.gravity.value_or(sceneGravity(scene)),
                candidate.overrides.damping.value_or(sceneDamping(scene))))
        {
          simulator_->setForces(sceneForces(*changed));
          session_.adoptChange(*changed);
          copyModel();
        }
        simulator_->setStepSettings(candidate.step);
        // a step setting changed here is the user's choice from now on, for every scene
        session_.chooseStep(parameters_.step, candidate.step);
        // gravity and damping are now the current scene's (kept by ~reset ''): not overrides that
        // a later reconfigure would bring back into another scene
        candidate.overrides.gravity.reset();
        candidate.overrides.damping.reset();
        // a window measures one method on one scene: any reconfigure ends it unmeasured
        accuracy_.abandon();
        parameters_ = candidate;
        pacer_.setRealTimeFactor(parameters_.real_time_factor);
        step_time_estimate_ = 0;
        last_chunk_ = 1;
        reanchor(Pacer::Anchor::Keep);
        if (perturbations_.draggedCount() > 0)
          noteForces(perturbations_.handTo(*simulator_));  // a drag's spring is scaled to dt
        return acceptedReply("reconfigured");
      });
}

RunnerReply SimulationRunner::applyForce(long particle, const Vec3& force, double duration)
{
  return queue_.submit(
      [this, particle, force, duration]
      {
        const State& now = simulator_->state();
        const Perturbations::Outcome outcome = perturbations_.apply(
            particle, force, duration, simulator_->model().numParticles(), now.steps, now.time,
            simulator_->stepSettings().dt, session_.scene()->name);
        if (!outcome.accepted)
          return refusedReply(outcome.message);
        noteForces(perturbations_.handTo(*simulator_));
        return acceptedReply(outcome.message);
      });
}

RunnerReply SimulationRunner::attach(long particle, const std::string& frame, const Vec3& offset,
                                     bool keep_offset, PoseLookup pose_at)
{
  HolderSession::AttachRequest request;
  request.particle = particle;
  request.frame = frame;
  request.offset = offset;
  request.keep_offset = keep_offset;
  // answered when the frame's pose at the state's stamp is known: the promise outlives this call
  // if the runner stops first
  auto promise = std::make_shared<std::promise<RunnerReply>>();
  std::future<RunnerReply> future = promise->get_future();
  const RunnerReply immediate = queue_.submit(
      [this, request, pose_at, promise]
      {
        if (auto refusal = holders_.beginAttach(
                simulator_->model(), request, parameters_.frame_prefix, pose_at,
                Clock::now() + wallDuration(HolderSession::ATTACH_WAIT)))
          return *refusal;
        attach_reply_ = promise;
        tryAttach();
        return acceptedReply("attach under way");
      });
  if (!immediate.success)
    return immediate;
  return queue_.await(future);
}

bool SimulationRunner::tryAttach()
{
  std::optional<RunnerReply> reply =
      holders_.tryAttach(*simulator_, stampNow(),
                         (paused_ || faulted_) && pacer_.source() != Pacer::Source::PublishClock,
                         Clock::now());  // at rest the node's own clock still stands for the state
  if (!reply)
    return false;
  if (reply->success)
    afterChange(true);
  reply->sim_time = simulator_->state().time;
  const std::shared_ptr<std::promise<RunnerReply>> promise = std::move(attach_reply_);
  makeSnapshot();  // answered after the snapshot, so a caller reading it sees the hold
  promise->set_value(*reply);
  return true;
}

RunnerReply SimulationRunner::detach(long particle)
{
  return queue_.submit(
      [this, particle]
      {
        if (const auto refusal = holders_.detach(*simulator_, particle))
          return refusedReply(*refusal, "particle");
        afterChange(true);
        return acceptedReply("detached particle " + std::to_string(particle));
      });
}

RunnerReply SimulationRunner::clearForces()
{
  return queue_.submit(
      [this]
      {
        const std::size_t count = perturbations_.clearApplied();
        noteForces(perturbations_.handTo(*simulator_));
        return acceptedReply("cleared " + std::to_string(count) + " applied forces");
      });
}

void SimulationRunner::drag(std::uint64_t scene_serial, int particle, const Vec3& target)
{
  perturbations_.queueDrag(scene_serial, particle, target);
  queue_.wake();
}

void SimulationRunner::release(std::uint64_t scene_serial, int particle)
{
  perturbations_.queueRelease(scene_serial, particle);
  queue_.wake();
}

void SimulationRunner::setCommandClock(std::function<double()> now)
{
  command_clock_ = std::move(now);
}

void SimulationRunner::commandWrench(std::uint64_t scene_serial, int particle, const Vec3& force)
{
  perturbations_.queueCommand(scene_serial, particle, force, command_clock_(), wrench_timeout_);
  queue_.wake();
}

void SimulationRunner::followClock(std::int64_t clock_ns)
{
  pacer_.takeClock(clock_ns);  // before the loop's lock: never between its check and its wait
  queue_.wake();
}

void SimulationRunner::postHolderSamples(std::uint64_t tracks_serial, int track,
                                         std::vector<HolderSample> samples)
{
  holders_.post(tracks_serial, track, std::move(samples));
}

void SimulationRunner::noteForces(Perturbations::Effect effect)
{
  if (effect == Perturbations::Effect::None)
    return;
  accuracy_.abandon();  // the shadow reference does not feel them
  if (effect == Perturbations::Effect::Shown)
    snapshot_due_ = true;
}

}  // namespace constrained_particles
