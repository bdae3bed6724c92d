/// @file simulation_runner.cpp
/// @brief SimulationRunner: the physics thread, its request queue, batches and snapshots (the
/// requests themselves are in simulation_runner_requests.cpp).
#include "constrained_particles/ros/simulation_runner.hpp"

#include "constrained_particles/ros/fault_policy.hpp"

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
namespace
{
constexpr auto IDLE_WAIT = std::chrono::milliseconds(100);
constexpr auto ATTACH_POLL = std::chrono::milliseconds(5);  // a pending ~attach asks tf again

Pacer::Source sourceOf(const NodeParameters& parameters)
{
  return parameters.follow_clock    ? Pacer::Source::FollowClock
         : parameters.publish_clock ? Pacer::Source::PublishClock
                                    : Pacer::Source::Wall;
}

HolderLimits holderLimits(const NodeParameters& parameters)
{
  HolderLimits limits;
  limits.lag = parameters.anchor_lag;
  limits.max_jump = parameters.anchor_max_jump;
  limits.max_speed = parameters.anchor_max_speed;
  limits.max_force = parameters.anchor_max_force;
  return limits;
}
}  // namespace

SimulationRunner::SimulationRunner(const NodeParameters& parameters, const SceneDescription& scene)
  : parameters_(parameters)
  , session_(parameters, scene)
  , wrench_timeout_(parameters.wrench_timeout)
  , command_clock_([] { return seconds(Clock::now().time_since_epoch()); })
  , pacer_(sourceOf(parameters), parameters.real_time_factor, [this] { return command_clock_(); })
  , holders_(holderLimits(parameters))
{
  // start-up overrides are already in `scene`; kept, a reconfigure would carry them to other scenes
  parameters_.overrides = SceneOverrides{};
  const SceneSession::Candidate first = session_.initial();
  Scene held = first.built.scene;
  holders_.limitHolds(held);
  simulator_ = std::make_unique<Simulator>(held, first.built.initial_state, first.settings,
                                           scene.solver.solve_method);
  parameters_.step = first.settings;
  session_.adopt(first.description, first.built.initial_state);
  holders_.setModel(simulator_->model(), true);
  afterChange(true);
  makeSnapshot();
}

SimulationRunner::~SimulationRunner()
{
  queue_.stop();
  if (thread_.joinable())
    thread_.join();
}

void SimulationRunner::start(bool paused)
{
  paused_ = paused;
  reanchor();
  pacer_.beginWindow(simulator_->state().time);
  thread_ = std::thread(&SimulationRunner::loop, this);
}

bool SimulationRunner::stop(std::chrono::milliseconds timeout)
{
  queue_.stop();
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

// ---- the physics thread ----

void SimulationRunner::loop()
{
  while (!queue_.stopping())
  {
    bool applied = applyRequests();
    noticeEpoch();
    if (holders_.attaching() && tryAttach())
      applied = true;
    noteForces(perturbations_.takeQueuedInto(*simulator_, session_.serial(), command_clock_()));
    // a silent commander's push ends while idle too (no clock read while none acts)
    if (std::isfinite(perturbations_.nextCommandExpiry()))
      noteForces(perturbations_.expireCommandsInto(*simulator_, command_clock_()));
    const bool stepped = !queue_.stopping() && runBatch();
    updateAccuracy();
    const Clock::time_point now = Clock::now();
    if (pacer_.updateRate(now, simulator_->state().time, simulator_->state().steps,
                          faulted_ || (paused_ && !step_request_), paused_))
      snapshot_due_ = true;
    if (snapshot_due_ || applied ||
        (unpublished_ && seconds(now - last_snapshot_wall_) >= 1.0 / parameters_.publish_rate))
      makeSnapshot();
    if (step_request_ && step_request_->taken == step_request_->wanted)
      finishStep(true, "stepped " + std::to_string(step_request_->taken) + " steps");
    if (!stepped && !queue_.stopping())
      idle(now);
  }
  // refuse what is still queued, a waiting attach, and a running ~step with what it took
  std::uint64_t batches = 0;
  for (const auto& request : queue_.take(batches))
    request->reply.set_value(refusedReply("the node is shutting down"));
  if (holders_.attaching())
  {
    holders_.cancelAttach();
    attach_reply_->set_value(refusedReply("the node is shutting down"));
  }
  if (step_request_)
    finishStep(false, "the node is shutting down after " + std::to_string(step_request_->taken) +
                          " of " + std::to_string(step_request_->wanted) + " steps");
  std::lock_guard<std::mutex> lock(exit_mutex_);
  exited_ = true;
  exited_cv_.notify_all();
}

void SimulationRunner::idle(Clock::time_point now)
{
  // until a request, the next due step, or a while (to refresh the rate window)
  const double time = simulator_->state().time, dt = simulator_->stepSettings().dt;
  const bool running = !paused_ && !faulted_ && !holders_.attaching();
  Clock::time_point wake = std::min(now + IDLE_WAIT, pacer_.nextDue(now, time, dt, running));
  if (holders_.attaching())
    wake = std::min(wake, now + ATTACH_POLL);
  // steps a snapshot has not shown (the last ones before a clock stopped): at the next period
  if (unpublished_)
    wake = std::min(wake, last_snapshot_wall_ + wallDuration(1.0 / parameters_.publish_rate));
  // a command's timeout ends it while idle too (the command clock taken to run as the wall)
  if (const double expiry = perturbations_.nextCommandExpiry(); std::isfinite(expiry))
    wake = std::min(wake, now + wallDuration(std::clamp(expiry - command_clock_(), 0.0, 1.0)));
  // a clock that came within the batch period of the last batch: taken when the period ends
  const bool follows = pacer_.source() == Pacer::Source::FollowClock;
  const bool clock_pending = follows && pacer_.clockMoved() && running;
  queue_.wait(wake,
              [this, clock_pending, running, follows]
              {
                return perturbations_.hasQueued() ||
                       (follows && !clock_pending && pacer_.clockMoved() && running);
              });
}

bool SimulationRunner::applyRequests()
{
  std::uint64_t batches = 0;
  const std::deque<std::shared_ptr<RunnerQueue::Request>> requests = queue_.take(batches);
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
      replies.push_back(refusedReply(e.what(), e.field()));
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

void SimulationRunner::updateLatency(Clock::time_point now)
{
  pacer_.setLatency(holders_.wantedLatency(), now);
}

std::uint64_t SimulationRunner::stepsDue(Clock::time_point start)
{
  if (step_request_)
    return step_request_->wanted - step_request_->taken;
  updateLatency(start);
  return pacer_.due(start, simulator_->state().time, simulator_->state().steps);
}

void SimulationRunner::noticeEpoch()
{
  const Pacer::Epoch epoch =
      pacer_.noticeEpoch(simulator_->state().time, simulator_->state().steps);
  if (epoch == Pacer::Epoch::Same)
    return;
  // the first clock, or one that went back: the state at the clock is published at once; after
  // a jump back the holders' samples stood for the old epoch, and each one's first pose in the
  // new one carries the scene to it
  holders_.rest(*simulator_, epoch == Pacer::Epoch::Back);
  afterChange();
}

bool SimulationRunner::runBatch()
{
  if (faulted_ || (paused_ && !step_request_))
  {
    holders_.discard();  // a scene at rest follows no holder: its poses meanwhile are stale
    return false;
  }
  if (holders_.attaching())
    return false;  // the state waits at the attach's stamp until the frame's pose is there
  const Clock::time_point start = Clock::now();
  const std::uint64_t wanted = stepsDue(start);
  if (wanted == 0)
    return false;
  last_good_ = simulator_->state();
  std::uint64_t taken = 0;
  bool out_of_time = false;  // the batch ran out of wall time with steps still due
  StepStatistics batch;
  while (taken < wanted && !faulted_)
  {
    const std::uint64_t kept = simulator_->state().steps;
    const bool go_on = runChunk(chunkSize(wanted - taken, start), batch);
    // the steps that stand (a fault put the chunk's back)
    taken += simulator_->state().steps > kept ? simulator_->state().steps - kept : 0;
    if (!go_on)
      break;  // faulted, or a live accuracy sample ended the batch
    if (seconds(Clock::now() - start) >= BATCH_WALL_TIME || queue_.stopping())
    {
      out_of_time = !queue_.stopping();
      break;
    }
  }
  endBatch(start, wanted, taken, out_of_time, batch);
  return true;
}

int SimulationRunner::chunkSize(std::uint64_t left, Clock::time_point batch_start)
{
  // chunks of about CHECK_WALL_TIME, each checked: a fault loses only the chunk it happened in
  const double wall =
      std::min(CHECK_WALL_TIME, BATCH_WALL_TIME - seconds(Clock::now() - batch_start));
  const double fit = step_time_estimate_ > 0 ? wall / step_time_estimate_ : 1.0;
  // grown at most twofold per chunk: a step much slower than the estimate (a new integrator,
  // dopri5 meeting a hard stretch) cannot make one chunk run for seconds
  last_chunk_ = static_cast<int>(std::clamp<double>(
      std::floor(fit), 1.0,
      std::min({ static_cast<double>(left), 1e6, 2.0 * static_cast<double>(last_chunk_) })));
  return last_chunk_;
}

void SimulationRunner::endBatch(Clock::time_point start, std::uint64_t wanted, std::uint64_t taken,
                                bool out_of_time, const StepStatistics& batch)
{
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
  queue_.countBatch();
  pending_.merge(batch);
  if (step_request_)
  {
    step_request_->taken += taken;
    step_request_->sim_time = simulator_->state().time;
    if (faulted_)
      finishStep(false, fault_reason_ + " (" + std::to_string(step_request_->taken) + " of " +
                            std::to_string(step_request_->wanted) + " steps kept)");
  }
  else if (!faulted_ && out_of_time && taken < wanted &&
           pacer_.source() != Pacer::Source::FollowClock)
  {
    // behind wall time: slow sim time down instead of building a backlog, and count the loss;
    // on wall time the stamps then stand for later times: the holders move with them
    const double dt = simulator_->stepSettings().dt;
    if (pacer_.dropped(static_cast<double>(wanted - taken) * dt, simulator_->state().time))
      holders_.resync(*simulator_);
  }
}

bool SimulationRunner::runChunk(int steps, StepStatistics& batch)
{
  // a live accuracy sample ends a chunk exactly on its step
  int steps_now = accuracy_.stepsToNextSample(simulator_->state().steps, steps);
  // an applied force's last step ends a chunk too: it is dropped exactly after it
  std::uint64_t until_expiry = 0;
  noteForces(perturbations_.expireAppliedInto(
      *simulator_, static_cast<std::uint64_t>(std::max(steps_now, 1)), until_expiry));
  steps_now = static_cast<int>(until_expiry);
  // holders' poses posted since the last chunk, known before the steps that reach them; a
  // holder's teleport ends the chunk on its step
  if (hasHolders())
  {
    holders_.follow(*simulator_, pacer_, simulator_->stepSettings().dt);
    if (holders_.stepsToNextJump(*simulator_, 1) == 0 && holders_.afterChunk(*simulator_))
      afterChange();
    steps_now = static_cast<int>(
        std::max<std::uint64_t>(holders_.stepsToNextJump(*simulator_, steps_now), 1));
  }
  const Clock::time_point chunk_start = Clock::now();
  const double cpu_start = accuracy_.open() ? threadCpuSeconds() : 0.0;
  StepStatistics statistics = simulator_->step(steps_now);
  if (simulator_->modelVersion() != model_copy_version_)
    copyModel();  // a self-colliding rope's link pairs changed: the snapshots' rows are the new
  if (accuracy_.open())
    accuracy_.addLiveCpu(threadCpuSeconds() - cpu_start);
  accuracy_.clearReferenceNow();
  step_time_estimate_ = seconds(Clock::now() - chunk_start) / steps_now;
  if (statistics.failed_check == StepCheck::HoldForce)
  {
    // the steps before the one over the hold's limit stand; the hold lets go of its particle
    const StepStatistics over = statistics;
    statistics.failed_check = StepCheck::None;
    batch.merge(statistics);
    unpublished_ = true;
    try
    {
      holders_.letGo(*simulator_, over);
      afterChange(true);
    }
    catch (const InvalidInput& e)  // not reached: fewer holds can always be met where more were
    {
      fault("a hold over its limit could not let go: " + std::string(e.what()), last_good_);
    }
    last_good_ = simulator_->state();
    return !faulted_;
  }
  // an undone chunk's statistics go with it: reports count the steps that stand
  if (const std::string reason =
          faultOf(*simulator_, parameters_, simulator_->state(), statistics, last_good_);
      !reason.empty())
  {
    fault(reason, last_good_);
    return false;
  }
  batch.merge(statistics);
  unpublished_ = true;
  std::uint64_t next = 0;
  noteForces(perturbations_.expireAppliedInto(*simulator_, 0, next));
  // a command takes effect, and a silent commander's push ends, within a chunk
  noteForces(perturbations_.takeQueuedInto(*simulator_, session_.serial(), command_clock_()));
  if (std::isfinite(perturbations_.nextCommandExpiry()))
    noteForces(perturbations_.expireCommandsInto(*simulator_, command_clock_()));
  if (hasHolders() && holders_.afterChunk(*simulator_))
    afterChange();  // a teleport: the shadow cannot know it
  last_good_ = simulator_->state();
  if (accuracy_.record(simulator_->state()))
  {
    // the batch ends on a sample: its snapshot can carry the reference beside it; the steps
    // still due are no loss, and the next batch takes them without waiting a period
    snapshot_due_ = true;
    pacer_.startBatch(Clock::time_point{});
    return false;
  }
  return true;
}

void SimulationRunner::fault(const std::string& reason, const State& good)
{
  accuracy_.abandon();
  faulted_ = true;
  fault_reason_ = faultMessage(reason, perturbations_.appliedCount(), perturbations_.draggedCount(),
                               perturbations_.commandedCount(), good.time);
  simulator_->restoreState(good);
  simulator_->constraintForces(forces_, multipliers_);
  // put back like a teleport: the fault's snapshot gets a stamp of its own
  pacer_.jump();
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
  RunnerReply reply = success ? acceptedReply(message) : refusedReply(message);
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
  Scene scene = candidate.built.scene;
  holders_.limitHolds(scene);
  // the settings with the scene: a refused scene leaves both (and the run) as they were
  simulator_->setScene(scene, candidate.built.initial_state, candidate.settings,
                       candidate.description.solver.solve_method);
  accuracy_.abandon();
  // an ~attach waiting for its frame asked for a particle of the scene that was
  if (holders_.attaching())
  {
    holders_.cancelAttach();
    attach_reply_->set_value(
        refusedReply("particle: a reset or scene change came first; nothing attached", "particle"));
    attach_reply_.reset();
  }
  // the new Data holds no perturbations: pushes and drags end with the scene they acted on
  perturbations_.clearAll();
  session_.adopt(candidate.description, candidate.built.initial_state);
  // the clock runs on across the reset: stamps never go back (see Snapshot::stamp)
  pacer_.restart(time_before, candidate.settings.dt);
  parameters_.step = candidate.settings;
  faulted_ = false;
  fault_reason_.clear();
  holders_.setModel(simulator_->model(), true);  // attachments held the scene that was
  afterChange(true);
  step_time_estimate_ = 0;
  last_chunk_ = 1;
  // last: its snapshot must show the new scene whole (model, forces, frames and clock together)
  interruptStep("a reset or scene change");
}

void SimulationRunner::afterChange(bool model_changed)
{
  accuracy_.abandon();  // the state changed under the window
  if (model_changed)
    copyModel();
  simulator_->constraintForces(forces_, multipliers_);
  last_good_ = simulator_->state();
  snapshot_due_ = true;
}

void SimulationRunner::copyModel()
{
  model_copy_ = std::make_shared<const Model>(simulator_->model());
  model_copy_version_ = simulator_->modelVersion();
}

void SimulationRunner::reanchor(Pacer::Anchor anchor)
{
  const State& state = simulator_->state();
  pacer_.reanchor(state.time, state.steps, simulator_->stepSettings().dt, anchor);
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
  s->carriers = simulator_->carriers();
  s->diagnostics = simulator_->diagnostics();
  s->ledger = simulator_->energyLedger();
  s->forward_path = simulator_->forwardPath();
  s->energy_fallback = energyFallbackText(*simulator_, parameters_);
  s->stamp = pacer_.base() + s->state.time;
  // a resting scene stands for the clock now: the newest /clock, or (wall) the publishing time
  s->stamp_ns = (paused_ || faulted_) && pacer_.source() == Pacer::Source::Wall ? -1 : stampNow();
  s->epoch = pacer_.epoch();
  s->latency = pacer_.latency();
  s->step_time = step_time_;
  s->real_time_factor = pacer_.achievedRealTimeFactor();
  s->behind = pacer_.behind() && !paused_ && !faulted_;
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
  s->stale_commands = perturbations_.staleCommands();
  s->tracks_serial = holders_.serial();
  s->holders = holders_.status();
  s->releases = holders_.releases();
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

void SimulationRunner::updateAccuracy()
{
  // pushed or dragged, the live state follows forces the shadow does not feel: no window opens
  const bool stepping = !faulted_ && (!paused_ || step_request_) && perturbations_.empty();
  // the shadow reference cannot know where holders outside the node go: no window with one
  const bool measurable = stepping && !hasHolders();
  if (accuracy_.update(simulator_->state(), measurable, parameters_.step,
                       parameters_.accuracy_window, parameters_.publish_rate,
                       simulator_->model().numParticles(), session_.scene(), pacer_.base()))
    snapshot_due_ = true;
}

}  // namespace constrained_particles
