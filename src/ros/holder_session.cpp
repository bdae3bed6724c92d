/// @file holder_session.cpp
/// @brief HolderSession: holders' samples onto the tracks, their latency, teleports, attach,
/// detach and holds that let go.
#include "constrained_particles/ros/holder_session.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace constrained_particles
{
namespace
{
std::string holderName(const Constraint& constraint)
{
  const auto* anchor = std::get_if<FrameAnchorConstraint>(&constraint);
  return anchor ? holderOf(*anchor) : std::string();
}

// The weight of the whole scene [N], with g at least standard gravity (a scene without gravity
// still has holds that carry something)
double sceneWeight(const Scene& scene)
{
  double g = 0.0;
  for (const Force& force : scene.forces)
    if (const auto* gravity = std::get_if<GravityForce>(&force))
      g = std::max(g, gravity->acceleration.norm());
  double mass = 0.0;
  for (double m : scene.masses)
    mass += m;
  return mass * std::max(g, 9.81);
}
}  // namespace

bool HolderSession::toNewest(Post& post) const
{
  if (post.serial == posted_serial_)
    return true;
  const auto old = keys_.find(post.serial);
  if (old == keys_.end() || post.track < 0 || post.track >= static_cast<int>(old->second.size()))
    return false;
  const TrackKey& key = old->second[post.track];
  // held through every model since: a holder let go and attached again in between is another
  int track = post.track;
  for (std::uint64_t serial = post.serial + 1; serial <= posted_serial_; ++serial)
  {
    const auto keys = keys_.find(serial);
    if (keys == keys_.end())
      return false;
    const auto kept = std::find(keys->second.begin(), keys->second.end(), key);
    if (kept == keys->second.end())
      return false;
    track = static_cast<int>(kept - keys->second.begin());
  }
  post.serial = posted_serial_;
  post.track = track;
  return true;
}

void HolderSession::post(std::uint64_t serial, int track, std::vector<HolderSample> samples)
{
  std::lock_guard<std::mutex> lock(mutex_);
  Post post{ serial, track, std::move(samples) };
  if (post.samples.empty() || !toNewest(post))
    return;
  // bounded: a physics thread that stopped taking them (paused) holds at most this many posts
  if (inbox_.size() >= 10000)
    inbox_.erase(inbox_.begin());
  inbox_.push_back(std::move(post));
}

void HolderSession::setModel(const Model& model, bool scene_changed)
{
  // the new model's holders: anchors, then obstacles, and their tracks' keys
  std::vector<HolderStatus> wanted;
  std::vector<TrackKey> keys;
  for (int k : model.tracked())
  {
    const Constraint& constraint = model.scene().constraints[k];
    const auto* anchor = std::get_if<FrameAnchorConstraint>(&constraint);
    HolderStatus fresh;
    fresh.particle = eliminatedParticle(constraint);
    fresh.holder = holderName(constraint);
    fresh.topic = anchor && anchor->frame.empty();
    wanted.push_back(fresh);
    keys.push_back(TrackKey{ fresh.particle, fresh.holder, fresh.topic,
                             anchor ? anchor->offset : Vec3::Zero(), std::string() });
  }
  for (const Shape& shape : model.carriers())
  {
    HolderStatus fresh;
    fresh.particle = -1;
    fresh.topic = shape.frame.empty();
    fresh.holder = holderOf(shape);
    fresh.shape = shape.name;
    wanted.push_back(fresh);
    keys.push_back(TrackKey{ -1, fresh.holder, fresh.topic, Vec3::Zero(), shape.name });
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    posted_serial_ = ++serial_;
    if (scene_changed)
      keys_.clear();  // another scene's samples stood for another run
    keys_[posted_serial_] = std::move(keys);
    while (keys_.size() > 4)  // posts older than a few changes are stale anyway
      keys_.erase(keys_.begin());
    // what waits goes to the same holders' new tracks (an attach or let-go of another)
    std::vector<Post> kept;
    for (Post& post : inbox_)
      if (toNewest(post))
        kept.push_back(std::move(post));
    inbox_.swap(kept);
  }
  if (scene_changed)
  {
    attachments_.clear();
    releases_.clear();
  }
  std::vector<HolderStatus> status;
  std::vector<Holder> holders;
  for (HolderStatus& fresh : wanted)
  {
    Holder holder;
    // a holder kept (an attach or detach of another): its counts, and its samples' place
    const auto kept = std::find_if(status_.begin(), status_.end(),
                                   [&fresh](const HolderStatus& s)
                                   {
                                     return s.particle == fresh.particle &&
                                            s.holder == fresh.holder && s.topic == fresh.topic &&
                                            s.shape == fresh.shape;
                                   });
    // a scene change starts every holder again: its track, its counts and what its arrivals
    // asked (a new run measures its own)
    if (kept != status_.end() && !scene_changed)
    {
      holder = holders_[static_cast<std::size_t>(kept - status_.begin())];
      fresh = *kept;
    }
    status.push_back(fresh);
    holders.push_back(std::move(holder));
  }
  status_.swap(status);
  holders_.swap(holders);
}

double HolderSession::holdLimit(const Scene& scene) const
{
  return limits_.max_force > 0.0 ? limits_.max_force : MAX_FORCE_WEIGHTS * sceneWeight(scene);
}

void HolderSession::limitHolds(Scene& scene) const
{
  const double limit = holdLimit(scene);
  for (Constraint& constraint : scene.constraints)
    if (auto* anchor = std::get_if<FrameAnchorConstraint>(&constraint);
        anchor && anchor->max_force <= 0.0)
      anchor->max_force = limit;
}

void HolderSession::discard()
{
  std::lock_guard<std::mutex> lock(mutex_);
  inbox_.clear();
}

void HolderSession::measure(int k, const HolderSample& sample)
{
  HolderStatus& status = status_[k];
  Holder& holder = holders_[k];
  if (sample.still)
  {
    holder.still = true;  // a frame on /tf_static: it never moves, and needs no latency
    status.needed_latency = 0.0;
    return;
  }
  holder.still = false;
  std::deque<Arrival>& arrivals = holder.arrivals;
  if (!arrivals.empty() && sample.stamp_ns <= arrivals.back().stamp_ns)
    return;  // repeated or out of order: it measures nothing
  arrivals.push_back(Arrival{ sample.stamp_ns, sample.arrival_ns, 0 });
  const std::size_t n = arrivals.size();
  // the steps leaving knot k - 2 need knot k (its tangent's successor) to have arrived
  if (n >= 3)
  {
    arrivals.back().need_ns =
        std::max<std::int64_t>(0, sample.arrival_ns - arrivals[n - 3].stamp_ns);
  }
  const std::int64_t window = std::llround(LATENCY_WINDOW * 1e9);
  while (arrivals.size() > 3 &&
         (arrivals.front().stamp_ns < sample.stamp_ns - window || arrivals.size() > 4096))
    arrivals.pop_front();
  if (arrivals.size() < 3)
    return;
  std::int64_t worst = 0;
  for (std::size_t i = 2; i < arrivals.size(); ++i)
    worst = std::max(worst, arrivals[i].need_ns);
  status.needed_latency = static_cast<double>(worst) * 1e-9;
  holder.measured = true;
}

void HolderSession::follow(Simulator& simulator, const Pacer& pacer, double lead)
{
  std::vector<Post> posts;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    posts.swap(inbox_);
  }
  const double now = simulator.state().time;
  for (Post& post : posts)
  {
    AnchorTrack* track = trackOf(simulator, post.track);
    if (post.serial != serial_ || !track || post.track >= static_cast<int>(status_.size()))
      continue;
    for (const HolderSample& sample : post.samples)
      take(post.track, sample, *track, now, pacer.simTimeOf(sample.stamp_ns), lead);
  }
  for (AnchorTrack& track : simulator.tracks())
    track.dropBefore(now);
  for (AnchorTrack& track : simulator.carriers())
    track.dropBefore(now);
}

AnchorTrack* HolderSession::trackOf(Simulator& simulator, int k)
{
  const int anchors = static_cast<int>(simulator.tracks().size());
  if (k < 0)
    return nullptr;
  if (k < anchors)
    return &simulator.tracks()[k];
  if (k - anchors < static_cast<int>(simulator.carriers().size()))
    return &simulator.carriers()[k - anchors];
  return nullptr;
}

void HolderSession::take(int k, const HolderSample& sample, AnchorTrack& track, double now,
                         double time, double lead)
{
  HolderStatus& status = status_[k];
  Holder& holder = holders_[k];
  status.last_stamp = static_cast<double>(sample.stamp_ns) * 1e-9;
  if (!std::isfinite(time))
  {
    ++status.late;  // no clock to place it on yet
    return;
  }
  if (time > now + wantedLatency() + FUTURE_LIMIT)
  {
    ++status.future;
    return;
  }
  if (!(sample.position.cwiseAbs().maxCoeff() <= limits::COORDINATE.high) ||
      !sample.orientation.coeffs().allFinite())
  {
    ++status.out_of_range;
    return;
  }
  if (sample.arrival_ns - sample.stamp_ns > std::llround(FUTURE_LIMIT * 1e9))
  {
    ++status.late;  // stamped over FUTURE_LIMIT before it could be used: not of this clock
    return;
  }
  measure(k, sample);  // a sample of the holder's clock, late or not: what latency it needs
  // a teleport: farther than ~anchor_max_jump, or faster than ~anchor_max_speed, from the last
  // sample (or, the first since the track started, from where the point is now)
  const Vec3 from = holder.has_previous ? holder.previous : track.motion(now).position;
  const double interval = holder.has_previous
                              ? static_cast<double>(sample.stamp_ns - holder.previous_ns) * 1e-9
                              : time - now;
  const double distance = (sample.position - from).norm();
  const bool jump = holder.replace || distance > limits_.max_jump ||
                    (interval > 0.0 && distance > limits_.max_speed * interval);
  const double ahead = std::max(lead, MIN_SPACING);
  if (status.particle < 0 && (jump || status.taken == 0))
  {
    // an obstacle's first pose (of the scene, or of a new clock epoch), or its holder's
    // teleport: it is there at once (a sweep from where it rested would strike whatever lies
    // between); it carries no scene along. After a resync its next pose is followed from where
    // it is, as a holder's is
    track.restart(sample.position, sample.orientation);
    if (holder.replace)
      ++status.replaced;
    else if (status.taken > 0)
    {
      ++status.jumps;
      status.last_jump = distance;
    }
    holder.replace = false;
    ++status.taken;
    holder.has_previous = true;
    holder.previous = sample.position;
    holder.previous_ns = sample.stamp_ns;
    return;
  }
  AnchorSample knot;
  // a still holder's pose holds at any time: never too late for the steps (a long dt)
  knot.time = sample.still ? std::max(time, now + ahead) : time;
  knot.position = sample.position;
  knot.orientation = sample.orientation;
  const AnchorTrack::Append appended = jump ? track.appendJump(knot, now, ahead, MIN_SPACING)
                                            : track.append(knot, now, ahead, MIN_SPACING);
  if (appended == AnchorTrack::Append::Unordered)
  {
    ++status.unordered;
    return;
  }
  if (holder.replace)
  {
    ++status.replaced;  // the clock went back: not the holder's own jump
    holder.replace = false;
  }
  else if (jump)
  {
    ++status.jumps;  // scheduled at its time, or (too late for a knot) at once
    status.last_jump = distance;
  }
  else if (appended == AnchorTrack::Append::Late)
    ++status.late;
  if (appended == AnchorTrack::Append::Taken)
    ++status.taken;
  if (sample.still && appended == AnchorTrack::Append::Taken)
    track.settle();  // a still holder: at rest at its pose, not past it
  holder.has_previous = true;
  holder.previous = sample.position;
  holder.previous_ns = sample.stamp_ns;
}

std::uint64_t HolderSession::stepsToNextJump(const Simulator& simulator, std::uint64_t limit) const
{
  const double now = simulator.state().time, dt = simulator.stepSettings().dt;
  std::uint64_t steps = limit;
  for (const AnchorTrack& track : simulator.tracks())
    if (const AnchorTrack::Jump* jump = track.nextJump())
    {
      const double until = std::ceil((jump->time - now) / dt - 1e-9);
      steps = std::min<std::uint64_t>(
          steps, until <= 0.0 ? 0 : static_cast<std::uint64_t>(std::min(until, 1e15)));
    }
  return steps;
}

bool HolderSession::afterChunk(Simulator& simulator)
{
  bool changed = false;
  const Model& model = simulator.model();
  for (std::size_t k = 0; k < simulator.tracks().size() && k < status_.size(); ++k)
  {
    const double now = simulator.state().time;
    AnchorTrack& track = simulator.tracks()[k];
    HolderStatus& status = status_[k];
    while (track.nextJump() && track.nextJump()->time <= now + 1e-12)
    {
      const Vec3 displacement = track.takeJump();
      const int particle = status.particle;
      // held by this holder alone, the scene goes with it rigidly: links exact, velocities (and
      // its kinetic energy) kept; with other holders it is projected onto where they all hold
      State moved = simulator.state();
      if (model.eliminated().size() == 1)
        moved.positions.colwise() += displacement;
      else
        moved.positions.col(particle) += displacement;
      try
      {
        simulator.setState(moved);
        changed = true;
      }
      catch (const InvalidInput& e)
      {
        // the scene cannot follow: the holder rests where its particle is (nothing changed)
        simulator.tracks()[k].restart(simulator.state().positions.col(particle));
        holders_[k].has_previous = false;
        ++status.refused;
        status.last_refusal = e.what();
        break;
      }
    }
    const bool coasting = track.coasting(now);
    if (coasting && !status.coasting)
      ++status.overruns;
    status.coasting = coasting;
  }
  // the obstacles' holders: overruns only (a teleport put them there at once, take())
  const std::size_t anchors = simulator.tracks().size();
  for (std::size_t c = 0; c < simulator.carriers().size() && anchors + c < status_.size(); ++c)
  {
    HolderStatus& status = status_[anchors + c];
    const bool coasting = simulator.carriers()[c].coasting(simulator.state().time);
    if (coasting && !status.coasting)
      ++status.overruns;
    status.coasting = coasting;
  }
  return changed;
}

double HolderSession::wantedLatency() const
{
  if (status_.empty())
    return 0.0;
  if (limits_.lag > 0.0)
    return limits_.lag;
  double worst = 0.0;
  for (std::size_t k = 0; k < status_.size(); ++k)
    worst = std::max(worst, holders_[k].still      ? 0.0
                            : holders_[k].measured ? status_[k].needed_latency
                                                   : INITIAL_LATENCY);
  return std::min(worst * LATENCY_FACTOR + LATENCY_MARGIN, limits::ANCHOR_LAG.high);
}

void HolderSession::rest(Simulator& simulator, bool new_epoch)
{
  discard();
  for (Holder& holder : holders_)
  {
    holder.has_previous = false;
    holder.replace = new_epoch;
  }
  for (HolderStatus& status : status_)
    status.coasting = false;
  simulator.restTracks();
}

void HolderSession::resync(Simulator& simulator)
{
  discard();
  const double now = simulator.state().time;
  for (AnchorTrack& track : simulator.tracks())
    track.resync(now);
  for (AnchorTrack& track : simulator.carriers())
    track.resync(now);
  for (Holder& holder : holders_)
    holder.has_previous = false;
}

std::optional<std::string> HolderSession::checkAttach(const Model& model,
                                                      const AttachRequest& request,
                                                      const std::string& frame_prefix,
                                                      std::string& field) const
{
  const int n = model.numParticles();
  const long particle = request.particle;
  field = "particle";
  if (particle < 0 || particle >= n)
    return "particle = " + std::to_string(particle) + ", must be in [0, " + std::to_string(n - 1) +
           "] (the scene's particles)";
  for (std::size_t k = 0; k < model.eliminated().size(); ++k)
    if (model.eliminatedParticles()[k] == particle)
    {
      const bool attached =
          std::find(attachments_.begin(), attachments_.end(), particle) != attachments_.end();
      return "particle = " + std::to_string(particle) + " is already held (by " +
             (attached ? std::string("an attachment; ~detach it first")
                       : std::string("the scene's ") +
                             kindOf(model.scene().constraints[model.eliminated()[k]])) +
             ")";
    }
  // a row between this particle and held ones only would have nothing left to move: its
  // violation, made by the holders, could not be projected away (a fault, not a grip)
  for (const RowRecord& record : model.rowRecords())
  {
    bool touches = false, free = false;
    for (int b = record.first_block; b < record.first_block + record.rows * record.particles; ++b)
    {
      const int i = model.blockParticle()[b];
      touches = touches || i == particle;
      free = free || (i != particle && model.inverseMasses()[i] > 0.0);
    }
    if (touches && !free)
      return "particle = " + std::to_string(particle) + ": its " +
             kindOf(model.scene().constraints[record.constraint]) +
             " joins it to held particles only (pinned, anchored or attached): held too, nothing "
             "could move to keep it; grab a particle with a free neighbour";
  }
  field = "frame";
  if (request.frame.empty() || request.frame.front() == '/')
    return "frame = '" + request.frame + "', must name a tf frame (non-empty, no leading /)";
  if (request.frame.rfind(frame_prefix, 0) == 0)
    return "frame = '" + request.frame +
           "' is one of this node's particle frames (~frame_prefix '" + frame_prefix +
           "'): a particle cannot follow the scene itself";
  field = "offset";
  try
  {
    requireInRange("offset", request.offset, limits::COORDINATE);
  }
  catch (const InvalidInput& e)
  {
    field = e.field();
    return std::string(e.what());
  }
  field.clear();
  return std::nullopt;
}

std::optional<RunnerReply> HolderSession::beginAttach(
    const Model& model, const AttachRequest& request, const std::string& frame_prefix,
    PoseLookup pose_at, std::chrono::steady_clock::time_point deadline)
{
  std::string field;
  if (const auto refusal = checkAttach(model, request, frame_prefix, field))
    return refusedReply(*refusal, field);
  if (pending_)
    return refusedReply("particle = " + std::to_string(request.particle) +
                            ": another ~attach (particle " +
                            std::to_string(pending_->request.particle) +
                            ") is waiting for its frame's pose; call again when it is answered",
                        "particle");
  pending_ = PendingAttach{ request, std::move(pose_at), deadline };
  return std::nullopt;
}

std::optional<RunnerReply> HolderSession::tryAttach(Simulator& simulator, std::int64_t stamp_ns,
                                                    bool resting,
                                                    std::chrono::steady_clock::time_point now)
{
  if (!pending_)
    return std::nullopt;
  // the frame's pose at the stamp the state stands for is where the hold begins (a resting
  // scene stands for the clock now, which no broadcast reaches: the newest pose tf holds)
  const std::optional<Eigen::Isometry3d> pose = resting         ? pending_->pose_at(-1)
                                                : stamp_ns >= 0 ? pending_->pose_at(stamp_ns)
                                                                : std::nullopt;
  if (!pose && now < pending_->deadline)
    return std::nullopt;  // tf has not reached the stamp yet: no step until it has
  const AttachRequest request = pending_->request;
  pending_.reset();
  if (!pose)
    return refusedReply(
        "frame = '" + request.frame + "': tf held no pose of it at the state's stamp (" +
            (stamp_ns >= 0 ? formatValue(static_cast<double>(stamp_ns) * 1e-9) + " s"
                           : std::string("no clock yet")) +
            ") within " + formatValue(ATTACH_WAIT) + " s (is it still broadcast?); nothing changed",
        "frame");
  try
  {
    const Attached done = attach(simulator, request, *pose, stamp_ns);
    const Vec3& offset = done.anchor.offset;
    RunnerReply reply =
        acceptedReply("attached particle " + std::to_string(request.particle) + " to frame '" +
                      request.frame + "' at t = " + formatValue(simulator.state().time) +
                      " s (stamp " + formatValue(static_cast<double>(stamp_ns) * 1e-9) +
                      " s), offset (" + formatValue(offset.x()) + ", " + formatValue(offset.y()) +
                      ", " + formatValue(offset.z()) + ") m: " +
                      (request.keep_offset ? std::string("held where it is")
                                           : "moved by " + formatValue(done.moved) +
                                                 " m to the held point, particles by up to " +
                                                 formatValue(done.displaced) + " m"));
    reply.max_displacement = done.displaced;
    reply.stamp_ns = stamp_ns;
    return reply;
  }
  catch (const InvalidInput& e)
  {
    return refusedReply(e.what(), e.field());
  }
}

ProjectionReport HolderSession::setConstraints(Simulator& simulator,
                                               const std::vector<Constraint>& constraints)
{
  const ProjectionReport report = simulator.setConstraints(constraints);
  setModel(simulator.model(), false);
  return report;
}

HolderSession::Attached HolderSession::attach(Simulator& simulator, const AttachRequest& request,
                                              const Eigen::Isometry3d& pose, std::int64_t stamp_ns)
{
  const int particle = static_cast<int>(request.particle);
  const Vec3 where = simulator.state().positions.col(particle);
  Attached done;
  done.anchor.particle = particle;
  done.anchor.frame = request.frame;
  // keep_offset: where the particle is, in the frame's axes at the state's stamp
  done.anchor.offset = request.keep_offset ? Vec3(pose.inverse() * where) : request.offset;
  done.anchor.max_force = holdLimit(simulator.model().scene());
  const std::vector<Constraint> old = simulator.model().scene().constraints;
  std::vector<Constraint> constraints = old;
  constraints.push_back(done.anchor);
  try
  {
    done.displaced = setConstraints(simulator, constraints).max_displacement;
  }
  catch (const InvalidInput& e)
  {
    throw InvalidInput("particle", "particle: attaching refused: " + std::string(e.what()));
  }
  // an offset elsewhere: the particle is carried to the held point, the scene projected after it
  const Vec3 held = request.keep_offset ? where : Vec3(pose * done.anchor.offset);
  done.moved = (held - where).norm();
  if (done.moved > 0.0)
  {
    const Model& model = simulator.model();
    for (std::size_t k = 0; k < model.tracked().size(); ++k)
      if (eliminatedParticle(model.scene().constraints[model.tracked()[k]]) == particle)
        simulator.tracks()[k].restart(held);
    try
    {
      done.displaced = std::max(done.moved, simulator.setState(simulator.state()).max_displacement);
    }
    catch (const InvalidInput& e)
    {
      setConstraints(simulator, old);  // nothing changed
      throw InvalidInput("offset", "offset: the scene cannot be projected with particle " +
                                       std::to_string(particle) + " at (" + formatValue(held.x()) +
                                       ", " + formatValue(held.y()) + ", " + formatValue(held.z()) +
                                       ") m: " + e.what() + "; nothing changed");
    }
  }
  attachments_.push_back(particle);
  for (HolderStatus& status : status_)
    if (status.particle == particle)
      status.since_ns = stamp_ns;
  releases_.erase(std::remove_if(releases_.begin(), releases_.end(),
                                 [particle](const Release& r) { return r.particle == particle; }),
                  releases_.end());
  return done;
}

std::optional<std::string> HolderSession::detach(Simulator& simulator, long particle)
{
  if (std::find(attachments_.begin(), attachments_.end(), particle) == attachments_.end())
  {
    std::string attached;
    for (int i : attachments_)
      attached += (attached.empty() ? "" : ", ") + std::to_string(i);
    return "particle = " + std::to_string(particle) +
           " is not attached; attached now: " + (attached.empty() ? "none" : attached);
  }
  std::vector<Constraint> constraints;
  for (const Constraint& c : simulator.model().scene().constraints)
    // the attachment's record: no other can hold its particle (attach refuses a held one)
    if (!(std::holds_alternative<FrameAnchorConstraint>(c) && eliminatedParticle(c) == particle))
      constraints.push_back(c);
  try
  {
    setConstraints(simulator, constraints);
  }
  catch (const InvalidInput& e)
  {
    return "particle: detaching refused: " + std::string(e.what());
  }
  attachments_.erase(std::remove(attachments_.begin(), attachments_.end(), particle),
                     attachments_.end());
  return std::nullopt;
}

void HolderSession::letGo(Simulator& simulator, const StepStatistics& failed)
{
  const Model& model = simulator.model();
  const int record = model.tracked()[failed.hold];
  const Constraint& held = model.scene().constraints[record];
  Release release;
  release.particle = eliminatedParticle(held);
  release.holder = holderName(held);
  release.time = simulator.state().time;
  if (const auto* anchor = std::get_if<FrameAnchorConstraint>(&held))
    release.max_force = anchor->max_force;
  release.why = failed.hold_failure == StepCheck::None
                    ? "it would have carried " + formatValue(failed.hold_force) +
                          " N, over its max_force " + formatValue(release.max_force) + " N"
                    : std::string("the holds made the next step impossible (step check ") +
                          stepCheckName(failed.hold_failure) +
                          " failed at every split): it carried most against its max_force " +
                          formatValue(release.max_force) + " N";
  std::vector<Constraint> constraints;
  for (std::size_t k = 0; k < model.scene().constraints.size(); ++k)
    if (static_cast<int>(k) != record)
      constraints.push_back(model.scene().constraints[k]);
  setConstraints(simulator, constraints);
  releases_.push_back(release);
  attachments_.erase(std::remove(attachments_.begin(), attachments_.end(), release.particle),
                     attachments_.end());
}

}  // namespace constrained_particles
