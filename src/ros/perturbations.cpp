#include "constrained_particles/ros/perturbations.hpp"

#include "constrained_particles/core/limits.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace constrained_particles
{
Perturbations::Outcome Perturbations::apply(long particle, const Vec3& force, double duration,
                                            int num_particles, std::uint64_t steps, double time,
                                            double dt, const std::string& scene)
{
  if (particle < 0 || particle >= num_particles)
    throw InvalidInput("particle", "= " + std::to_string(particle) + ", must be in [0, " +
                                       std::to_string(num_particles - 1) + "] (scene '" + scene +
                                       "' has " + std::to_string(num_particles) + " particles)");
  requireInRange("force", force, limits::FORCE);
  requireInRange("duration", duration, limits::APPLIED_FORCE_DURATION);
  if (applied_.size() >= MAX_APPLIED_FORCES)
    return { false, "applied forces: " + std::to_string(applied_.size()) +
                        " act already, the most at once; call ~clear_forces" };
  // the steps that begin within `duration`: counted in steps, so round-off in the summed time
  // cannot add or drop one (a duration within 1e-9 dt of N dt counts as N steps)
  const auto count =
      static_cast<std::uint64_t>(std::max(1.0, std::ceil(std::min(duration / dt, 1e15) - 1e-9)));
  applied_.push_back(AppliedForce{ ExternalForce{ static_cast<int>(particle), force },
                                   duration > 0.0 ? steps + count : 0 });
  return { true, "force applied to particle " + std::to_string(particle) +
                     (duration > 0.0
                          ? " for " + std::to_string(count) + " steps (" + formatValue(duration) +
                                " s) from t = " + formatValue(time) + " s"
                          : std::string(" until ~clear_forces")) +
                     " (" + std::to_string(applied_.size()) + " acting)" };
}

std::size_t Perturbations::clearApplied()
{
  const std::size_t count = applied_.size();
  applied_.clear();
  return count;
}

void Perturbations::clearAll()
{
  applied_.clear();
  drags_.clear();
  commands_.clear();
  next_command_expiry_ = std::numeric_limits<double>::infinity();
  std::lock_guard<std::mutex> lock(queue_mutex_);
  queue_.clear();
  queued_ = false;
}

bool Perturbations::expire(std::uint64_t steps, std::uint64_t limit, std::uint64_t& next)
{
  const std::size_t before = applied_.size();
  applied_.erase(
      std::remove_if(applied_.begin(), applied_.end(),
                     [&](const AppliedForce& a) { return a.end_step != 0 && a.end_step <= steps; }),
      applied_.end());
  next = limit;
  for (const AppliedForce& a : applied_)
    if (a.end_step != 0)
      next = std::min(next, a.end_step - steps);
  return applied_.size() != before;
}

void Perturbations::queue(const Update& update)
{
  std::lock_guard<std::mutex> lock(queue_mutex_);
  queue_.push_back(update);
  queued_ = true;
}

void Perturbations::queueDrag(std::uint64_t scene_serial, int particle, const Vec3& target)
{
  queue(Update{ Update::Drag, scene_serial, particle, target, {} });
}

void Perturbations::queueRelease(std::uint64_t scene_serial, int particle)
{
  queue(Update{ Update::Release, scene_serial, particle, Vec3::Zero(), {} });
}

void Perturbations::queueCommand(std::uint64_t scene_serial, int particle, const Vec3& force,
                                 double received, double timeout)
{
  queue(Update{ Update::Push, scene_serial, particle, force, received + timeout });
}

int Perturbations::checkCommand(const std::string& frame, const std::string& prefix,
                                const Vec3& force, const Vec3& torque, int num_particles)
{
  // tf2 strips a leading '/' from frame ids; a command names the frame as /tf carries it
  const std::string name = !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
  const std::string index =
      name.compare(0, prefix.size(), prefix) == 0 && name.size() > prefix.size()
          ? name.substr(prefix.size())
          : std::string();
  // a particle frame's index as the node writes it: digits, no leading zero but for 0 itself
  const bool digits =
      !index.empty() && index.size() <= 9 && (index == "0" || index[0] != '0') &&
      std::all_of(index.begin(), index.end(), [](char c) { return c >= '0' && c <= '9'; });
  const int particle = digits ? std::stoi(index) : -1;
  if (particle < 0 || particle >= num_particles)
    throw InvalidInput("header.frame_id", "= '" + frame + "', must name a particle frame, '" +
                                              prefix + "<i>' with i in [0, " +
                                              std::to_string(num_particles - 1) + "]");
  requireInRange("wrench.force", force, limits::FORCE);
  for (int axis = 0; axis < 3; ++axis)
    if (!std::isfinite(torque[axis]))
      throw InvalidInput(std::string("wrench.torque.") + "xyz"[axis],
                         "= " + formatValue(torque[axis]) +
                             ", must be finite (a finite torque is ignored; this command is not)");
  return particle;
}

Perturbations::Change Perturbations::takeQueued(std::uint64_t scene_serial, int num_particles)
{
  if (!queued_)
    return Change::None;
  std::vector<Update> updates;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    updates.swap(queue_);
    queued_ = false;
  }
  const std::size_t before = drags_.size() + commands_.size();
  bool changed = false;
  for (const Update& u : updates)
  {
    // made for another scene (a marker rviz still held across a reset, a command sent before
    // it): not this one's particle
    if (u.scene_serial != scene_serial && u.scene_serial != 0)
    {
      stale_commands_ += u.kind == Update::Push ? 1 : 0;
      continue;
    }
    if (u.kind == Update::Release)
    {
      changed |= u.particle < 0 ? !drags_.empty() : drags_.count(u.particle) > 0;
      if (u.particle < 0)
        drags_.clear();
      else
        drags_.erase(u.particle);
    }
    else if (u.particle < 0 || u.particle >= num_particles)
      continue;
    else if (u.kind == Update::Push)
    {
      // checkCommand checked the force; a newer command replaces the older one
      commands_[u.particle] = Command{ u.value, u.expires };
      changed = true;
    }
    else if (limits::COORDINATE.contains(u.value.x()) && limits::COORDINATE.contains(u.value.y()) &&
             limits::COORDINATE.contains(u.value.z()))
    {
      drags_[u.particle] = u.value;
      changed = true;
    }
  }
  if (!changed)
    return Change::None;
  return drags_.size() + commands_.size() != before ? Change::Acting : Change::Forces;
}

bool Perturbations::expireCommands(double now, double& next)
{
  bool ended = false;
  next = std::numeric_limits<double>::infinity();
  for (auto it = commands_.begin(); it != commands_.end();)
  {
    if (it->second.expires <= now)
    {
      it = commands_.erase(it);
      ended = true;
    }
    else
    {
      next = std::min(next, it->second.expires);
      ++it;
    }
  }
  return ended;
}

std::vector<Force> Perturbations::forces(const std::vector<double>& masses, double dt) const
{
  std::vector<Force> forces;
  forces.reserve(applied_.size() + drags_.size() + commands_.size());
  for (const AppliedForce& applied : applied_)
    forces.push_back(applied.force);
  for (const auto& [particle, command] : commands_)
    forces.push_back(ExternalForce{ particle, command.force });
  for (const auto& [particle, target] : drags_)
  {
    const double m = masses[particle];
    // critically damped (c = 2 m w) within the ranges a target spring takes: a heavy particle
    // is pulled more slowly rather than refused
    const double w =
        std::min({ DRAG_FREQUENCY, DRAG_STEP_LIMIT / dt, limits::DAMPING.high / (2.0 * m),
                   std::sqrt(limits::STIFFNESS.high / m) });
    forces.push_back(TargetSpringForce{ particle, target, m * w * w, 2.0 * m * w });
  }
  return forces;
}

Perturbations::Effect Perturbations::handTo(Simulator& simulator)
{
  try
  {
    simulator.setPerturbations(
        forces(simulator.model().scene().masses, simulator.stepSettings().dt));
  }
  catch (const InvalidInput&)
  {
    // every record was checked on its way in: not reached; never leave forces half set
    clearAll();
    simulator.setPerturbations({});
  }
  return Effect::Forces;
}

Perturbations::Effect Perturbations::takeQueuedInto(Simulator& simulator,
                                                    std::uint64_t scene_serial, double now)
{
  const Change change = takeQueued(scene_serial, simulator.model().numParticles());
  if (change == Change::None)
    return Effect::None;
  expireCommands(now, next_command_expiry_);  // a command's new expiry, or none left
  handTo(simulator);
  // a new target or force moves only the spring or push: the next batch's snapshot shows it; a
  // grab, a release or a new command changes what ~state reports at once
  return change == Change::Acting ? Effect::Shown : Effect::Forces;
}

Perturbations::Effect Perturbations::expireCommandsInto(Simulator& simulator, double now)
{
  if (now < next_command_expiry_ || !expireCommands(now, next_command_expiry_))
    return Effect::None;
  handTo(simulator);
  return Effect::Shown;
}

Perturbations::Effect Perturbations::expireAppliedInto(Simulator& simulator, std::uint64_t limit,
                                                       std::uint64_t& next)
{
  next = limit;
  if (!expire(simulator.state().steps, limit, next))
    return Effect::None;
  handTo(simulator);
  return Effect::Shown;
}

}  // namespace constrained_particles
