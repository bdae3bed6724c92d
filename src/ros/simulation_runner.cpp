#include "constrained_particles/ros/simulation_runner.hpp"

#include "constrained_particles/core/integrators.hpp"

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
namespace
{
constexpr auto IDLE_WAIT = std::chrono::milliseconds(100);
constexpr auto REPLY_POLL = std::chrono::milliseconds(50);

double seconds(std::chrono::steady_clock::duration d)
{
  return std::chrono::duration<double>(d).count();
}

// seconds() the other way: a wait of `s` seconds on the steady clock
std::chrono::steady_clock::duration wallDuration(double s)
{
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(s));
}

RunnerReply refused(const std::string& message)
{
  RunnerReply reply;
  reply.success = false;
  reply.message = message;
  return reply;
}

RunnerReply accepted(const std::string& message)
{
  RunnerReply reply;
  reply.success = true;
  reply.message = message;
  return reply;
}

}  // namespace

SimulationRunner::SimulationRunner(const NodeParameters& parameters, const SceneDescription& scene)
  : parameters_(parameters)
  , session_(parameters, scene)
  , wrench_timeout_(parameters.wrench_timeout)
  , follow_clock_(parameters.follow_clock)
  , command_clock_([] { return seconds(Clock::now().time_since_epoch()); })
{
  // start-up overrides are already in `scene`; kept, a reconfigure would carry them to other scenes
  parameters_.overrides = SceneOverrides{};
  const SceneSession::Candidate first = session_.initial();
  simulator_ = std::make_unique<Simulator>(first.built.scene, first.built.initial_state,
                                           first.settings, scene.solver.solve_method);
  parameters_.step = first.settings;
  session_.adopt(first.description, first.built.initial_state);
  model_copy_ = std::make_shared<const Model>(simulator_->model());
  holders_.setModel(++tracks_serial_, simulator_->model());
  simulator_->constraintForces(forces_, multipliers_);
  makeSnapshot();
}

SimulationRunner::~SimulationRunner()
{
  requestStop();
  if (thread_.joinable())
    thread_.join();
}

void SimulationRunner::start(bool paused)
{
  paused_ = paused;
  reanchor();
  window_wall_ = Clock::now();
  window_sim_ = simulator_->state().time;
  window_valid_ = true;
  thread_ = std::thread(&SimulationRunner::loop, this);
}

void SimulationRunner::requestStop()
{
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);  // not between the loop's check and its wait
    stopping_ = true;
  }
  wake_.notify_all();
}

bool SimulationRunner::stop(std::chrono::milliseconds timeout)
{
  requestStop();
  if (!thread_.joinable())
    return true;
  std::unique_lock<std::mutex> lock(exit_mutex_);
  if (!exited_cv_.wait_for(lock, timeout, [this] { return exited_; }))
    return false;
  lock.unlock();
  thread_.join();
  return true;
}

std::shared_ptr<const Snapshot> SimulationRunner::snapshot() const
{
  std::lock_guard<std::mutex> lock(snapshot_mutex_);
  return snapshot_;
}

std::shared_ptr<const Snapshot> SimulationRunner::snapshot(Reader reader,
                                                           StepStatistics& statistics)
{
  std::lock_guard<std::mutex> lock(snapshot_mutex_);
  statistics = StepStatistics{};
  std::swap(statistics, unread_[static_cast<int>(reader)]);
  return snapshot_;
}

RunnerReply SimulationRunner::await(std::future<RunnerReply>& future)
{
  while (future.wait_for(REPLY_POLL) != std::future_status::ready)
    if (stopping_ && future.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
      return refused("the node is shutting down");
  return future.get();
}

RunnerReply SimulationRunner::submit(std::function<RunnerReply()> apply)
{
  auto request = std::make_shared<Request>();
  request->apply = std::move(apply);
  std::future<RunnerReply> future = request->reply.get_future();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (stopping_)
      return refused("the node is shutting down");
    request->queued_at_batch = batches_;
    queue_.push_back(request);
  }
  wake_.notify_all();
  return await(future);
}

// ---- requests (their lambdas run on the physics thread) ----

RunnerReply SimulationRunner::reset(const std::string& scenario)
{
  return submit(
      [this, scenario]
      {
        apply(session_.forReset(scenario, parameters_.step));
        return accepted("reset to scene '" + session_.scene()->name + "' (" +
                        std::to_string(simulator_->model().numParticles()) + " particles, solve " +
                        solveAlgorithmName(simulator_->model()) + "; " +
                        parameters_.step.integrator + " + " +
                        stabilizationName(parameters_.step.stabilization) +
                        ", dt = " + formatValue(parameters_.step.dt) + " s)");
      });
}

RunnerReply SimulationRunner::changeScene(const std::function<SceneSession::Candidate()>& make,
                                          const std::string& what)
{
  return submit(
      [this, make, what]
      {
        apply(make());
        return accepted(what + "; scene '" + session_.scene()->name + "' reset (" +
                        std::to_string(simulator_->model().numParticles()) + " particles)");
      });
}

RunnerReply SimulationRunner::setSurface(const std::string& type,
                                         const std::vector<double>& coefficients,
                                         const std::string& expression)
{
  return changeScene(
      [this, type, coefficients, expression]
      { return session_.forSurface(type, coefficients, expression, parameters_.step); },
      "surface set to '" + type + "'");
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
  return submit(
      [this, positions, velocities]
      {
        const int n = simulator_->model().numParticles();
        if (positions.cols() != n)
          throw InvalidInput("positions", "has " + std::to_string(positions.cols()) +
                                              " entries, must have one per particle (" +
                                              std::to_string(n) + ")");
        if (velocities.size() != 0 && velocities.cols() != n)
          throw InvalidInput("velocities",
                             "has " + std::to_string(velocities.cols()) +
                                 " entries, must be empty (at rest) or one per particle (" +
                                 std::to_string(n) + ")");
        State state = simulator_->state();
        state.positions = positions;
        state.velocities = velocities.size() == 0 ? Points(Points::Zero(3, n)) : velocities;
        // finite is not enough: a teleport to 1e300 m would overflow on the first step
        for (int i = 0; i < n; ++i)
        {
          requireInRange("positions[" + std::to_string(i) + "]", Vec3(state.positions.col(i)),
                         limits::COORDINATE);
          requireInRange("velocities[" + std::to_string(i) + "]", Vec3(state.velocities.col(i)),
                         limits::VELOCITY);
        }
        const ProjectionReport report = simulator_->setState(state);
        abandonWindow();
        faulted_ = false;
        fault_reason_.clear();
        clock_base_ += TIME_JUMP;
        simulator_->constraintForces(forces_, multipliers_);
        reanchor();
        restHolders();
        // last: its snapshot must show the teleport whole
        interruptStep("~set_state");
        RunnerReply reply =
            accepted("state set; projection moved particles by up to " +
                     formatValue(report.max_displacement) + " m and changed velocities by up to " +
                     formatValue(report.max_velocity_change) + " m/s");
        reply.max_displacement = report.max_displacement;
        return reply;
      });
}

RunnerReply SimulationRunner::pause()
{
  return submit(
      [this]
      {
        interruptStep("~pause");
        paused_ = true;
        return accepted("paused");
      });
}

RunnerReply SimulationRunner::unpause()
{
  return submit(
      [this]
      {
        interruptStep("~unpause");
        paused_ = false;
        reanchor();
        restHolders();
        return accepted(faulted_ ? "unpaused, but stepping is stopped (" + fault_reason_ + ")"
                                 : "running");
      });
}

RunnerReply SimulationRunner::step(std::uint64_t steps)
{
  // the promise outlives this call if the runner stops first
  auto promise = std::make_shared<std::promise<RunnerReply>>();
  std::future<RunnerReply> future = promise->get_future();
  RunnerReply immediate = submit(
      [this, steps, promise]
      {
        if (follow_clock_)
          return refused(
              "the node follows /clock (~follow_clock): it steps as the clock moves, "
              "never ahead of it");
        if (!paused_)
          return refused("the simulation is running: call ~pause before ~step");
        if (faulted_)
          return refused("stepping is stopped (" + fault_reason_ + ")");
        if (step_request_)
          return refused("a ~step of " + std::to_string(step_request_->wanted) +
                         " steps is running (" + std::to_string(step_request_->taken) +
                         " taken): wait for it, or ~pause to stop it");
        if (!limits::STEPS_PER_CALL.contains(static_cast<double>(steps)))
          throw InvalidInput("steps", "= " + std::to_string(steps) + ", must be in " +
                                          limits::STEPS_PER_CALL.text());
        step_request_.emplace();
        step_request_->wanted = steps;
        step_request_->sim_time = simulator_->state().time;
        step_request_->reply = promise;
        return accepted("step under way");
      });
  if (!immediate.success)
    return immediate;
  return await(future);
}

RunnerReply SimulationRunner::reconfigure(
    const std::function<void(NodeParameters&, const SceneDescription&)>& edit)
{
  return submit(
      [this, edit]
      {
        NodeParameters candidate = parameters_;
        // held: adoptForces below replaces the session's scene
        const std::shared_ptr<const SceneDescription> held = session_.scene();
        const SceneDescription& scene = *held;
        edit(candidate, scene);
        validateNodeParameters(candidate);
        simulator_->setStepSettings(candidate.step);
        // new forces recompile the model (and restart dopri5's step control): only on a change
        if (const std::optional<SceneDescription> changed = session_.withGravityAndDamping(
                candidate.overrides.gravity.value_or(sceneGravity(scene)),
                candidate.overrides.damping.value_or(sceneDamping(scene))))
        {
          try
          {
            simulator_->setForces(changed->forces);
          }
          catch (const InvalidInput&)
          {
            simulator_->setStepSettings(parameters_.step);
            throw;
          }
          session_.adoptForces(*changed);
          model_copy_ = std::make_shared<const Model>(simulator_->model());
        }
        // a step setting changed here is the user's choice from now on, for every scene
        session_.chooseStep(parameters_.step, candidate.step);
        // gravity and damping are now the current scene's (kept by ~reset ''): not overrides that
        // a later reconfigure would bring back into another scene
        candidate.overrides.gravity.reset();
        candidate.overrides.damping.reset();
        // a window measures one method on one scene: any reconfigure ends it unmeasured
        abandonWindow();
        parameters_ = candidate;
        step_time_estimate_ = 0;
        last_chunk_ = 1;
        reanchor(ClockAnchor::Keep);
        if (perturbations_.draggedCount() > 0)
          updatePerturbations();  // a drag's spring is scaled to dt
        return accepted("reconfigured");
      });
}

RunnerReply SimulationRunner::applyForce(long particle, const Vec3& force, double duration)
{
  return submit(
      [this, particle, force, duration]
      {
        const State& now = simulator_->state();
        const Perturbations::Outcome outcome = perturbations_.apply(
            particle, force, duration, simulator_->model().numParticles(), now.steps, now.time,
            simulator_->stepSettings().dt, session_.scene()->name);
        if (!outcome.accepted)
          return refused(outcome.message);
        updatePerturbations();
        return accepted(outcome.message);
      });
}

RunnerReply SimulationRunner::attach(long particle, const std::string& frame, const Vec3& offset)
{
  return submit(
      [this, particle, frame, offset]
      {
        const Model& model = simulator_->model();
        const int n = model.numParticles();
        RunnerReply reply;
        if (particle < 0 || particle >= n)
        {
          reply.field = "particle";
          reply.message = "particle = " + std::to_string(particle) + ", must be in [0, " +
                          std::to_string(n - 1) + "] (the scene's particles)";
          return reply;
        }
        for (std::size_t k = 0; k < model.eliminated().size(); ++k)
          if (model.eliminatedParticles()[k] == particle)
          {
            const Constraint& holder = model.scene().constraints[model.eliminated()[k]];
            const bool attached =
                std::find(attachments_.begin(), attachments_.end(), particle) != attachments_.end();
            reply.field = "particle";
            reply.message = "particle = " + std::to_string(particle) + " is already held (by " +
                            (attached ? std::string("an attachment; ~detach it first")
                                      : std::string("the scene's ") + kindOf(holder)) +
                            ")";
            return reply;
          }
        // a row between this particle and held ones only would have nothing left to move: its
        // violation, made by the holders, could not be projected away (a fault, not a grip)
        for (const RowRecord& record : model.rowRecords())
        {
          bool touches = false, free = false;
          for (int b = record.first_block; b < record.first_block + record.rows * record.particles;
               ++b)
          {
            const int i = model.blockParticle()[b];
            touches = touches || i == particle;
            free = free || (i != particle && model.inverseMasses()[i] > 0.0);
          }
          if (touches && !free)
          {
            reply.field = "particle";
            reply.message = "particle = " + std::to_string(particle) + ": its " +
                            kindOf(model.scene().constraints[record.constraint]) +
                            " joins it to held particles only (pinned, anchored or attached): "
                            "held too, nothing could move to keep it; grab a particle with a free "
                            "neighbour";
            return reply;
          }
        }
        if (frame.empty() || frame.front() == '/')
        {
          reply.field = "frame";
          reply.message = "frame = '" + frame + "', must name a tf frame (non-empty, no leading /)";
          return reply;
        }
        if (frame.rfind(parameters_.frame_prefix, 0) == 0)
        {
          reply.field = "frame";
          reply.message =
              "frame = '" + frame + "' is one of this node's particle frames (~frame_prefix '" +
              parameters_.frame_prefix + "'): a particle cannot follow the scene itself";
          return reply;
        }
        try
        {
          requireInRange("offset", offset, limits::COORDINATE);
        }
        catch (const InvalidInput& e)
        {
          reply.field = e.field();
          reply.message = e.what();
          return reply;
        }
        FrameAnchorConstraint anchor;
        anchor.particle = static_cast<int>(particle);
        anchor.frame = frame;
        anchor.offset = offset;
        std::vector<Constraint> constraints = model.scene().constraints;
        constraints.push_back(anchor);
        reply = changeHolders(constraints, "attached particle " + std::to_string(particle) +
                                               " to frame '" + frame + "'");
        if (reply.success)
          attachments_.push_back(static_cast<int>(particle));
        return reply;
      });
}

RunnerReply SimulationRunner::detach(long particle)
{
  return submit(
      [this, particle]
      {
        const auto found = std::find(attachments_.begin(), attachments_.end(), particle);
        if (found == attachments_.end())
        {
          RunnerReply reply;
          reply.field = "particle";
          std::string held;
          for (int i : attachments_)
            held += (held.empty() ? "" : ", ") + std::to_string(i);
          reply.message = "particle = " + std::to_string(particle) +
                          " is not attached; attached now: " + (held.empty() ? "none" : held);
          return reply;
        }
        const Model& model = simulator_->model();
        std::vector<Constraint> constraints;
        for (const Constraint& c : model.scene().constraints)
          // the attachment's record: no other can hold its particle (attach refuses a held one)
          if (!(std::holds_alternative<FrameAnchorConstraint>(c) &&
                eliminatedParticle(c) == particle))
            constraints.push_back(c);
        RunnerReply reply =
            changeHolders(constraints, "detached particle " + std::to_string(particle));
        if (reply.success)
          attachments_.erase(std::find(attachments_.begin(), attachments_.end(), particle));
        return reply;
      });
}

RunnerReply SimulationRunner::changeHolders(const std::vector<Constraint>& constraints,
                                            const std::string& what)
{
  ProjectionReport report;
  try
  {
    report = simulator_->setConstraints(constraints);
  }
  catch (const InvalidInput& e)
  {
    // the request's field is its particle: the scene cannot hold (or free) that one
    RunnerReply reply;
    reply.field = "particle";
    reply.message = "particle: " + what + " refused: " + e.what();
    return reply;
  }
  abandonWindow();
  model_copy_ = std::make_shared<const Model>(simulator_->model());
  holders_.setModel(++tracks_serial_, simulator_->model());
  simulator_->constraintForces(forces_, multipliers_);
  last_good_ = simulator_->state();
  snapshot_due_ = true;
  return accepted(what + " (the scene projected onto it: particles moved by up to " +
                  formatValue(report.max_displacement) + " m)");
}

RunnerReply SimulationRunner::clearForces()
{
  return submit(
      [this]
      {
        const std::size_t count = perturbations_.clearApplied();
        updatePerturbations();
        return accepted("cleared " + std::to_string(count) + " applied forces");
      });
}

void SimulationRunner::wakeLoop()
{
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
  }
  wake_.notify_all();
}

void SimulationRunner::drag(std::uint64_t scene_serial, int particle, const Vec3& target)
{
  perturbations_.queueDrag(scene_serial, particle, target);
  wakeLoop();
}

void SimulationRunner::release(std::uint64_t scene_serial, int particle)
{
  perturbations_.queueRelease(scene_serial, particle);
  wakeLoop();
}

void SimulationRunner::setCommandClock(std::function<double()> now)
{
  command_clock_ = std::move(now);
}

void SimulationRunner::commandWrench(std::uint64_t scene_serial, int particle, const Vec3& force)
{
  perturbations_.queueCommand(scene_serial, particle, force, command_clock_(), wrench_timeout_);
  wakeLoop();
}

void SimulationRunner::followClock(std::int64_t clock_ns)
{
  clock_now_ns_ = clock_ns;
  clock_moved_ = true;  // before the loop's lock (wakeLoop): never between its check and its wait
  wakeLoop();
}

void SimulationRunner::applyInbox()
{
  const Perturbations::Change change =
      perturbations_.takeQueued(session_.serial(), simulator_->model().numParticles());
  if (change == Perturbations::Change::None)
    return;
  // a command's new expiry, or none left
  perturbations_.expireCommands(command_clock_(), next_command_expiry_);
  updatePerturbations();
  // a new target or force moves only the spring or push: the next batch's snapshot shows it; a
  // grab, a release or a new command changes what ~state reports at once
  if (change == Perturbations::Change::Acting)
    snapshot_due_ = true;
}

void SimulationRunner::expireCommands()
{
  if (!std::isfinite(next_command_expiry_))
    return;  // none acts: no clock read on the chunks' path
  const double now = command_clock_();
  if (now < next_command_expiry_)
    return;
  if (perturbations_.expireCommands(now, next_command_expiry_))
  {
    updatePerturbations();
    snapshot_due_ = true;
  }
}

void SimulationRunner::updatePerturbations()
{
  try
  {
    simulator_->setPerturbations(
        perturbations_.forces(simulator_->model().scene().masses, simulator_->stepSettings().dt));
  }
  catch (const InvalidInput&)
  {
    // every record was checked on its way in: not reached; never leave forces half set
    perturbations_.clearAll();
    simulator_->setPerturbations({});
  }
  // the shadow reference does not feel them: the window would measure the push, not the method
  abandonWindow();
}

std::uint64_t SimulationRunner::expireForces(std::uint64_t limit)
{
  std::uint64_t next = limit;
  if (perturbations_.expire(simulator_->state().steps, limit, next))
  {
    updatePerturbations();
    snapshot_due_ = true;
  }
  return next;
}

// ---- the physics thread ----

void SimulationRunner::loop()
{
  while (!stopping_)
  {
    const bool applied = applyRequests();
    applyInbox();
    expireCommands();
    const bool stepped = !stopping_ && runBatch();
    updateAccuracy();
    const Clock::time_point now = Clock::now();
    updateRate(now);
    const double publish_period = 1.0 / parameters_.publish_rate;
    if (snapshot_due_ || applied ||
        (unpublished_ && seconds(now - last_snapshot_wall_) >= publish_period))
      makeSnapshot();
    if (step_request_ && step_request_->taken == step_request_->wanted)
      finishStep(true, "stepped " + std::to_string(step_request_->taken) + " steps");
    if (stepped || stopping_)
      continue;
    // idle: until a request, the next due step, or a while (to refresh the rate window)
    Clock::time_point wake = now + IDLE_WAIT;
    if (!paused_ && !faulted_ && !follow_clock_)  // a clock that moves wakes the loop itself
    {
      const double dt = simulator_->stepSettings().dt;
      const double until_next =
          (simulator_->state().time + dt - anchor_sim_) / parameters_.real_time_factor;
      const Clock::time_point due = anchor_wall_ + wallDuration(until_next);
      const Clock::time_point period = last_batch_start_ + wallDuration(BATCH_PERIOD);
      wake = std::min(wake, std::max(due, period));
    }
    // steps a snapshot has not shown (the last ones before a clock stopped): at the next period
    if (unpublished_)
      wake = std::min(wake, last_snapshot_wall_ + wallDuration(publish_period));
    // a command's timeout ends it while idle too (the command clock taken to run as the wall)
    if (std::isfinite(next_command_expiry_))
      wake = std::min(
          wake, now + wallDuration(std::clamp(next_command_expiry_ - command_clock_(), 0.0, 1.0)));
    // a clock that came within BATCH_PERIOD of the last batch: taken when the period ends
    const bool clock_pending = follow_clock_ && clock_moved_ && !paused_ && !faulted_;
    if (clock_pending)
      wake = std::min(wake, last_batch_start_ + wallDuration(BATCH_PERIOD));
    std::unique_lock<std::mutex> lock(queue_mutex_);
    wake_.wait_until(lock, wake,
                     [this, clock_pending]
                     {
                       return stopping_ || !queue_.empty() || perturbations_.hasQueued() ||
                              (!clock_pending && clock_moved_ && !paused_ && !faulted_);
                     });
  }
  // refuse what is still queued, and a running ~step with what it took
  std::deque<std::shared_ptr<Request>> left;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    left.swap(queue_);
  }
  for (const auto& request : left)
    request->reply.set_value(refused("the node is shutting down"));
  if (step_request_)
    finishStep(false, "the node is shutting down after " + std::to_string(step_request_->taken) +
                          " of " + std::to_string(step_request_->wanted) + " steps");
  std::lock_guard<std::mutex> lock(exit_mutex_);
  exited_ = true;
  exited_cv_.notify_all();
}

bool SimulationRunner::applyRequests()
{
  std::deque<std::shared_ptr<Request>> requests;
  std::uint64_t batches = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    requests.swap(queue_);
    batches = batches_;
  }
  if (requests.empty())
    return false;
  std::vector<RunnerReply> replies;
  for (const auto& request : requests)
  {
    try
    {
      replies.push_back(request->apply());
    }
    catch (const InvalidInput& e)
    {
      replies.push_back(refused(e.what()));
      replies.back().field = e.field();
    }
    replies.back().sim_time = simulator_->state().time;
    replies.back().batches_waited = batches - request->queued_at_batch;
  }
  // answered after the snapshot, so a caller reading it sees what it asked for
  makeSnapshot();
  for (std::size_t k = 0; k < requests.size(); ++k)
    requests[k]->reply.set_value(replies[k]);
  return true;
}

bool SimulationRunner::runBatch()
{
  if (faulted_ || (paused_ && !step_request_))
  {
    holders_.discard();  // a scene at rest follows no holder: its poses meanwhile are stale
    return false;
  }
  const double dt = simulator_->stepSettings().dt;
  const Clock::time_point start = Clock::now();
  std::uint64_t wanted = 0;
  if (step_request_)
  {
    wanted = step_request_->wanted - step_request_->taken;
  }
  else if (follow_clock_)
  {
    if (seconds(start - last_batch_start_) < BATCH_PERIOD)
      return false;  // clock_moved_ stays: the loop wakes when the period ends
    clock_moved_ = false;
    const std::int64_t clock = clock_now_ns_;
    if (clock < 0)
      return false;  // no /clock yet: nothing to follow
    // the first clock, or one that went back (a bag played again): the scene goes on from it
    if (anchor_clock_ns_ < 0 || clock < clockStandsFor() - static_cast<std::int64_t>(dt * 1e9))
    {
      reanchor(ClockAnchor::Now);
      restHolders();
    }
    // whole steps since the anchor, from integer nanoseconds: exact for clocks near the epoch
    // and for increments of exactly dt (the 1e-9 absorbs the quotient's rounding)
    const double since_anchor =
        std::floor(static_cast<double>(clock - anchor_clock_ns_) * 1e-9 / dt + 1e-9);
    const double due =
        since_anchor - static_cast<double>(simulator_->state().steps - anchor_steps_);
    if (!(due >= 1.0))
      return false;
    wanted = static_cast<std::uint64_t>(std::min(due, 1e15));
    last_batch_start_ = start;
  }
  else
  {
    if (seconds(start - last_batch_start_) < BATCH_PERIOD)
      return false;
    const double target =
        anchor_sim_ + parameters_.real_time_factor * seconds(start - anchor_wall_);
    const double due = std::floor((target - simulator_->state().time) / dt + 1e-9);
    if (!(due >= 1.0))
      return false;
    wanted = static_cast<std::uint64_t>(std::min(due, 1e15));
    last_batch_start_ = start;
  }
  last_good_ = simulator_->state();
  std::uint64_t taken = 0;
  bool out_of_time = false;  // the batch ran out of wall time with steps still due
  StepStatistics batch;
  while (taken < wanted && !faulted_)
  {
    // chunks of about CHECK_WALL_TIME, each checked: a fault loses only the chunk it happened in
    const double left = std::min(CHECK_WALL_TIME, BATCH_WALL_TIME - seconds(Clock::now() - start));
    const double fit = step_time_estimate_ > 0 ? left / step_time_estimate_ : 1.0;
    // grown at most twofold per chunk: a step much slower than the estimate (a new integrator,
    // dopri5 meeting a hard stretch) cannot make one chunk run for seconds
    const auto chunk =
        static_cast<int>(std::clamp<double>(std::floor(fit), 1.0,
                                            std::min({ static_cast<double>(wanted - taken), 1e6,
                                                       2.0 * static_cast<double>(last_chunk_) })));
    // a live accuracy sample ends a chunk exactly on its step
    int steps_now = accuracy_.stepsToNextSample(simulator_->state().steps, chunk);
    // an applied force's last step ends a chunk too: it is dropped exactly after it
    steps_now = static_cast<int>(expireForces(static_cast<std::uint64_t>(std::max(steps_now, 1))));
    last_chunk_ = chunk;
    // holders' poses posted since the last chunk: known before the steps that reach them
    followHolders();
    const Clock::time_point chunk_start = Clock::now();
    const double cpu_start = accuracy_.open() ? threadCpuSeconds() : 0.0;
    const StepStatistics statistics = simulator_->step(steps_now);
    if (accuracy_.open())
      accuracy_.addLiveCpu(threadCpuSeconds() - cpu_start);
    accuracy_.clearReferenceNow();
    step_time_estimate_ = seconds(Clock::now() - chunk_start) / steps_now;
    // an undone chunk's statistics go with it: reports count the steps that stand
    if (const std::string reason = faultIn(simulator_->state(), statistics); !reason.empty())
      fault(reason, last_good_);
    else
    {
      batch.merge(statistics);
      taken += static_cast<std::uint64_t>(steps_now);
      unpublished_ = true;
      expireForces(0);
      // a command takes effect, and a silent commander's push ends, within a chunk
      applyInbox();
      expireCommands();
      last_good_ = simulator_->state();
      if (accuracy_.record(simulator_->state()))
      {
        // the batch ends on a sample: its snapshot can carry the reference beside it; the
        // steps still due are no loss, and the next batch takes them without waiting a period
        snapshot_due_ = true;
        last_batch_start_ = Clock::time_point{};
        break;
      }
    }
    if (seconds(Clock::now() - start) >= BATCH_WALL_TIME || stopping_)
    {
      out_of_time = !stopping_;
      break;
    }
  }
  // the last step's forces, once per batch (after a fault, fault() took them at the good state)
  if (!faulted_)
  {
    if (simulator_->data().control.multipliers_current)
    {
      forces_ = simulator_->data().constraint_forces;
      multipliers_ = simulator_->data().multipliers;
    }
    else  // velocity Verlet and fast projection solve for none: one evaluation per batch
      simulator_->constraintForces(forces_, multipliers_);
  }
  step_time_ =
      seconds(Clock::now() - start) / static_cast<double>(std::max<std::uint64_t>(taken, 1));
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    ++batches_;
  }
  pending_.merge(batch);
  if (step_request_)
  {
    step_request_->taken += taken;
    step_request_->sim_time = simulator_->state().time;
    if (faulted_)
      finishStep(false, fault_reason_ + " (" + std::to_string(step_request_->taken) + " of " +
                            std::to_string(step_request_->wanted) + " steps kept)");
  }
  else if (!faulted_ && out_of_time && taken < wanted && !follow_clock_)
  {
    // behind wall time: slow sim time down instead of building a backlog, and count the loss
    window_dropped_ += static_cast<double>(wanted - taken) * dt;
    reanchor();
  }
  return true;
}

std::string SimulationRunner::faultIn(const State& state, const StepStatistics& chunk) const
{
  std::string reason = checkFault(state, chunk);
  // the fault ends the fallback (the state is restored, the ledger opened again): say it was on
  if (const StepControl& control = simulator_->data().control;
      !reason.empty() && control.budget_fallback)
    reason += "; the run had been taken by " + std::string(Simulator::STIFF_FALLBACK) +
              " since t = " + formatValue(control.budget_fallback_time) + " s, after " +
              parameters_.step.integrator + " overdrew ~energy_budget";
  return reason;
}

std::string SimulationRunner::checkFault(const State& state, const StepStatistics& chunk) const
{
  const StepSettings& step = parameters_.step;
  // the wording only where a check failed: this runs after every chunk
  if (chunk.failed_check == StepCheck::None)
    return checkState(state, chunk);
  const std::string split =
      step.max_substeps > 1
          ? " even in ~max_substeps = " + std::to_string(step.max_substeps) + " sub-steps"
          : " (~max_substeps = 1: no sub-steps)";
  const std::string when = " at t = " + formatValue(state.time) + " s";
  switch (chunk.failed_check)
  {
    case StepCheck::AdaptiveGuard:
      return "dopri5 could not meet ~adaptive_tolerance = " + formatValue(step.adaptive_tolerance) +
             " within " + formatValue(step.dt) + " s" + when + " (over " +
             std::to_string(DOPRI5_MAX_INTERNAL_STEPS) + " internal steps, or one under " +
             formatValue(DOPRI5_MIN_INTERNAL_STEP) + " dt): loosen the tolerance or shorten ~dt";
    case StepCheck::NonFinite:
      return "step check non_finite failed" + split + when +
             ": the state became non-finite; shorten ~dt, raise ~max_substeps or use "
             "~integrator fast_projection";
    case StepCheck::Projection:
      return "step check projection failed" + split + when + ": a projection did not reach " +
             "~projection_tolerance = " + formatValue(step.projection_tolerance) + " m in " +
             "~projection_max_iterations = " + std::to_string(step.projection_max_iterations);
    case StepCheck::EnergyRise:
      return "step check energy_rise failed" + split + when +
             ": the total energy of this conservative scene rose by more than " +
             formatValue(Simulator::ENERGY_RISE_TOLERANCE) + " of its scale in one sub-step; " +
             "shorten ~dt, raise ~max_substeps or change ~integrator";
    case StepCheck::EnergyBudget:
    {
      const EnergyLedger& ledger = simulator_->energyLedger();
      const double scale = simulator_->data().control.budget_failure_scale;
      return "step check energy_budget failed" + when + ": energy budget exceeded, residual " +
             formatValue(simulator_->data().control.budget_failure_residual) + " J > " +
             formatValue(step.energy_budget * scale) + " J (~energy_budget " +
             formatValue(step.energy_budget) + " of scale " + formatValue(scale) +
             " J, since t = " + formatValue(ledger.t0) + " s): the run gained energy" +
             (step.max_substeps > 1 ? std::string(" even in steps of ") +
                                          Simulator::STIFF_FALLBACK + ", the stiff-safe method"
                                    : std::string(" (~max_substeps = 1: no fallback to ") +
                                          Simulator::STIFF_FALLBACK + ")") +
             "; use rk4 or velocity_verlet, shorten ~dt, or set ~energy_budget 0 to run "
             "unchecked";
    }
    default:
      break;
  }
  return checkState(state, chunk);
}

std::string SimulationRunner::checkState(const State& state, const StepStatistics& chunk) const
{
  if (!isFinite(state))
    return "the state became non-finite between t = " + formatValue(last_good_.time) +
           " s and t = " + formatValue(state.time) + " s";
  // the step's own measure where its projection took one: no rows evaluated again per chunk
  const double error = chunk.end_position_error >= 0.0
                           ? chunk.end_position_error
                           : simulator_->diagnostics().max_position_error;
  if (!(error <= parameters_.max_constraint_error))
    return "the constraint error reached " + formatValue(error) +
           " m at t = " + formatValue(state.time) +
           " s, over ~max_constraint_error = " + formatValue(parameters_.max_constraint_error) +
           " m";
  return "";
}

void SimulationRunner::fault(const std::string& reason, const State& good)
{
  abandonWindow();
  faulted_ = true;
  // a push the scene cannot follow faults it as an unstable method would: say that one acted
  const std::string pushed =
      perturbations_.empty()
          ? std::string()
          : "; forces from outside acted (" + std::to_string(perturbations_.appliedCount()) +
                " ~apply_force, " + std::to_string(perturbations_.draggedCount()) + " drags, " +
                std::to_string(perturbations_.commandedCount()) +
                " ~wrench_command): one too large for the scene faults it as a method would";
  fault_reason_ = reason + pushed +
                  "; stepping stopped at the last good state (t = " + formatValue(good.time) +
                  " s); call ~reset";
  simulator_->restoreState(good);
  simulator_->constraintForces(forces_, multipliers_);
  // put back like a teleport: the fault's snapshot gets a stamp of its own
  clock_base_ += TIME_JUMP;
  snapshot_due_ = true;
}

void SimulationRunner::interruptStep(const std::string& by)
{
  if (step_request_)
    finishStep(false, "stopped by " + by + " after " + std::to_string(step_request_->taken) +
                          " of " + std::to_string(step_request_->wanted) + " steps");
}

void SimulationRunner::finishStep(bool success, const std::string& message)
{
  RunnerReply reply = success ? accepted(message) : refused(message);
  reply.sim_time = step_request_->sim_time;  // not a new scene's, when a reset stopped it
  reply.steps_taken = step_request_->taken;
  const std::shared_ptr<std::promise<RunnerReply>> promise = step_request_->reply;
  step_request_.reset();
  // answered after the snapshot, so a caller reading it sees the step's end
  makeSnapshot();
  promise->set_value(reply);
}

void SimulationRunner::apply(const SceneSession::Candidate& candidate)
{
  const double time_before = simulator_->state().time;
  // settings first: if the scene is refused, put them back
  const StepSettings saved = simulator_->stepSettings();
  simulator_->setStepSettings(candidate.settings);
  try
  {
    simulator_->setScene(candidate.built.scene, candidate.built.initial_state,
                         candidate.description.solver.solve_method);
  }
  catch (const InvalidInput&)
  {
    simulator_->setStepSettings(saved);
    throw;
  }
  abandonWindow();
  // the new Data holds no perturbations: pushes and drags end with the scene they acted on
  perturbations_.clearAll();
  session_.adopt(candidate.description, candidate.built.initial_state);
  // the clock runs on across the reset: stamps never go back (see Snapshot::stamp)
  clock_base_ += time_before + TIME_JUMP;
  parameters_.step = candidate.settings;
  faulted_ = false;
  fault_reason_.clear();
  model_copy_ = std::make_shared<const Model>(simulator_->model());
  attachments_.clear();  // they held particles of the scene that was
  holders_.setModel(++tracks_serial_, simulator_->model());
  simulator_->constraintForces(forces_, multipliers_);
  step_time_estimate_ = 0;
  last_chunk_ = 1;
  window_valid_ = false;
  reanchor();
  // last: its snapshot must show the new scene whole (model, forces, frames and clock together)
  interruptStep("a reset or scene change");
}

void SimulationRunner::postHolderSamples(std::uint64_t tracks_serial, int track,
                                         std::vector<HolderSample> samples)
{
  holders_.post(tracks_serial, track, std::move(samples));
}

double SimulationRunner::simTimeOf(std::int64_t stamp_ns) const
{
  if (follow_clock_)
    return anchor_clock_ns_ < 0
               ? std::numeric_limits<double>::quiet_NaN()
               : anchor_clock_sim_ + static_cast<double>(stamp_ns - anchor_clock_ns_) * 1e-9;
  if (parameters_.publish_clock)  // the node's clock is clock_base_ + sim time (Snapshot::stamp)
    return static_cast<double>(stamp_ns) * 1e-9 - clock_base_;
  return anchor_sim_ +
         parameters_.real_time_factor * static_cast<double>(stamp_ns - anchor_ros_ns_) * 1e-9;
}

void SimulationRunner::followHolders()
{
  if (simulator_->tracks().empty())
    return;
  // a knot no sooner than a step ahead: a shorter first interval's acceleration (~1/h^2) explodes
  const std::vector<std::pair<int, Vec3>> jumped = holders_.apply(
      *simulator_, [this](std::int64_t stamp_ns) { return simTimeOf(stamp_ns); },
      std::llround(parameters_.anchor_lag * 1e9), parameters_.anchor_max_jump,
      simulator_->stepSettings().dt);
  if (jumped.empty())
    return;
  // a teleported holder: where it alone holds the scene, the scene is carried along by its jump
  // (links stay exact), then projected onto where the holders rest, like ~set_state
  State moved = simulator_->state();
  if (jumped.size() == simulator_->model().eliminated().size())
  {
    Vec3 carry = Vec3::Zero();
    for (const auto& jump : jumped)
      carry += jump.second / static_cast<double>(jumped.size());
    moved.positions.colwise() += carry;
  }
  try
  {
    simulator_->setState(moved);
  }
  catch (const InvalidInput& e)
  {
    // the scene cannot follow: the holders rest where their particles are (nothing changed)
    const Model& model = simulator_->model();
    for (const auto& jump : jumped)
    {
      const int particle =
          eliminatedParticle(model.scene().constraints[model.tracked()[jump.first]]);
      simulator_->tracks()[jump.first].restart(simulator_->state().positions.col(particle));
      holders_.refuseTeleport(jump.first, e.what());
    }
    return;
  }
  abandonWindow();
  simulator_->constraintForces(forces_, multipliers_);
  last_good_ = simulator_->state();
  snapshot_due_ = true;
}

void SimulationRunner::restHolders()
{
  holders_.discard();
  simulator_->restTracks();
  simulator_->constraintForces(forces_, multipliers_);
}

void SimulationRunner::reanchor(ClockAnchor clock)
{
  anchor_wall_ = Clock::now();
  anchor_sim_ = simulator_->state().time;
  anchor_ros_ns_ = std::llround(command_clock_() * 1e9);
  if (!follow_clock_)
    return;
  // following /clock: from the clock's time now (-1: from the first one), or from the time the
  // state stands for (a settings change keeps the backlog and the count since the anchor)
  anchor_clock_ns_ =
      clock == ClockAnchor::Keep && anchor_clock_ns_ >= 0 ? clockStandsFor() : clock_now_ns_.load();
  anchor_steps_ = simulator_->state().steps;
  anchor_clock_sim_ = simulator_->state().time;
}

std::int64_t SimulationRunner::clockStandsFor() const
{
  if (anchor_clock_ns_ < 0)
    return -1;
  return anchor_clock_ns_ + std::llround((simulator_->state().time - anchor_clock_sim_) * 1e9);
}

void SimulationRunner::updateRate(Clock::time_point now)
{
  const double wall = seconds(now - window_wall_);
  if (wall < RATE_WINDOW)
    return;
  const double sim = simulator_->state().time;
  const bool idle = faulted_ || (paused_ && !step_request_);
  if (window_valid_)
    achieved_rtf_ = idle ? 0.0 : std::max(0.0, sim - window_sim_) / wall;
  // lag: the share of the wanted sim time that was dropped to keep up (running only)
  double lag = (idle || paused_) ? 0.0 : window_dropped_ / (parameters_.real_time_factor * wall);
  if (follow_clock_)
  {
    // following /clock nothing is dropped: behind is the backlog against the clock's advance
    const std::int64_t clock = clock_now_ns_;
    lag = 0.0;
    if (!idle && !paused_ && anchor_clock_ns_ >= 0 && window_clock_ns_ >= 0 &&
        clock > window_clock_ns_)
      lag = std::max(0.0, static_cast<double>(clock - clockStandsFor()) * 1e-9 -
                              simulator_->stepSettings().dt) /
            (static_cast<double>(clock - window_clock_ns_) * 1e-9);
    window_clock_ns_ = clock;
  }
  behind_ = behind_monitor_.update(lag);
  window_wall_ = now;
  window_sim_ = sim;
  window_dropped_ = 0;
  window_valid_ = true;
  snapshot_due_ = true;
}

void SimulationRunner::makeSnapshot()
{
  auto s = std::make_shared<Snapshot>();
  s->serial = ++snapshot_serial_;
  s->scene_serial = session_.serial();
  s->model = model_copy_;
  s->scene = session_.scene();
  s->parameters = parameters_;
  s->state = simulator_->state();
  s->constraint_forces = forces_;
  s->multipliers = multipliers_;
  s->contacts = simulator_->data().contacts;
  s->diagnostics = simulator_->diagnostics();
  s->ledger = simulator_->energyLedger();
  s->forward_path = simulator_->forwardPath();
  if (const StepControl& control = simulator_->data().control; control.budget_fallback)
    s->energy_fallback =
        "energy budget overdrawn at t = " + formatValue(control.budget_fallback_time) + " s by " +
        parameters_.step.integrator + " (residual " + formatValue(control.budget_failure_residual) +
        " J > " + formatValue(parameters_.step.energy_budget * control.budget_failure_scale) +
        " J, ~energy_budget " + formatValue(parameters_.step.energy_budget) + " of " +
        formatValue(control.budget_failure_scale) + " J): " + Simulator::STIFF_FALLBACK +
        " takes the steps until a reset, ~set_state or a settings change; use rk4 or "
        "velocity_verlet, or shorten ~dt";
  s->stamp = clock_base_ + s->state.time;
  s->step_time = step_time_;
  s->real_time_factor = achieved_rtf_;
  s->behind = behind_ && !paused_ && !faulted_;
  s->paused = paused_;
  s->stepping = step_request_.has_value();
  s->faulted = faulted_;
  s->fault_reason = fault_reason_;
  s->accuracy = accuracy_.report();
  s->reference_positions = accuracy_.referenceNow();
  s->skipped_windows =
      accuracy_.skippedWindows(simulator_->state().time, parameters_.accuracy_window);
  s->region = session_.region();
  s->applied_forces = static_cast<std::uint32_t>(perturbations_.appliedCount());
  s->dragged_particles = static_cast<std::uint32_t>(perturbations_.draggedCount());
  s->commanded_particles = static_cast<std::uint32_t>(perturbations_.commandedCount());
  // following /clock, a resting scene stands for the clock's time now: its state still goes out
  if (follow_clock_)
    s->clock_stamp_ns = paused_ || faulted_ ? clock_now_ns_.load() : clockStandsFor();
  s->stale_commands = perturbations_.staleCommands();
  s->tracks_serial = tracks_serial_;
  s->holders = holders_.status();
  s->anchor_lag = parameters_.anchor_lag;
  for (const AnchorTrack& track : simulator_->tracks())
    s->holder_orientations.push_back(track.orientation(s->state.time));
  unpublished_ = false;
  {
    std::lock_guard<std::mutex> lock(snapshot_mutex_);
    snapshot_ = std::move(s);
    for (StepStatistics& unread : unread_)
      unread.merge(pending_);
  }
  pending_ = StepStatistics{};
  last_snapshot_wall_ = Clock::now();
  snapshot_due_ = false;
}

void SimulationRunner::abandonWindow()
{
  accuracy_.abandon();
}

void SimulationRunner::updateAccuracy()
{
  // pushed or dragged, the live state follows forces the shadow does not feel: no window opens
  const bool stepping = !faulted_ && (!paused_ || step_request_) && perturbations_.empty();
  // the shadow reference cannot know where holders outside the node go: no window with one
  const bool measurable = stepping && simulator_->tracks().empty();
  if (accuracy_.update(simulator_->state(), measurable, parameters_.step,
                       parameters_.accuracy_window, parameters_.publish_rate,
                       simulator_->model().numParticles(), session_.scene(), clock_base_))
    snapshot_due_ = true;
}

bool BehindMonitor::update(double lag)
{
  lagging_windows_ = lag > SET ? lagging_windows_ + 1 : 0;
  if (lagging_windows_ >= WINDOWS)
    behind_ = true;
  else if (lag < CLEAR)
    behind_ = false;
  return behind_;
}

}  // namespace constrained_particles
