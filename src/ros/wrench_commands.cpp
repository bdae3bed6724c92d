#include "constrained_particles/ros/wrench_commands.hpp"

#include "constrained_particles/ros/perturbations.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace constrained_particles
{
WrenchCommands::WrenchCommands(ros::NodeHandle node, SimulationRunner& runner,
                               std::string frame_prefix)
  : runner_(runner), frame_prefix_(std::move(frame_prefix))
{
  // a controller's stream: a deep queue drops nothing at 1 kHz between two spins
  subscriber_ = node.subscribe("wrench_command", 100, &WrenchCommands::take, this,
                               ros::TransportHints().tcpNoDelay());
}

void WrenchCommands::take(const geometry_msgs::WrenchStamped& message)
{
  const std::shared_ptr<const Snapshot> snap = runner_.snapshot();
  const Vec3 force(message.wrench.force.x, message.wrench.force.y, message.wrench.force.z);
  try
  {
    const Vec3 torque(message.wrench.torque.x, message.wrench.torque.y, message.wrench.torque.z);
    const int particle = Perturbations::checkCommand(message.header.frame_id, frame_prefix_, force,
                                                     torque, snap->model->numParticles());
    if (torque != Vec3::Zero() && !torque_noted_.exchange(true))
      ROS_INFO("simulator: ~wrench_command's torque is ignored (particles take forces only)");
    runner_.commandWrench(snap->scene_serial, particle, force);
    ++taken_;
  }
  catch (const InvalidInput& e)
  {
    ++dropped_;
    const std::string reason = std::string("~wrench_command dropped: ") + e.what();
    {
      std::lock_guard<std::mutex> lock(reason_mutex_);
      last_drop_reason_ = reason;
    }
    ROS_WARN_THROTTLE(5.0, "simulator: %s", reason.c_str());
  }
}

std::uint64_t WrenchCommands::newDrops(const Snapshot& snap)
{
  const std::uint64_t drops = dropped_ + snap.stale_commands;
  const std::uint64_t fresh = drops - std::min(drops, drops_reported_);
  drops_reported_ = drops;
  return fresh;
}

std::string WrenchCommands::lastDropReason() const
{
  std::lock_guard<std::mutex> lock(reason_mutex_);
  return last_drop_reason_;
}

void WrenchCommands::report(
    const Snapshot& snap,
    const std::function<void(const std::string&, const std::string&)>& add) const
{
  // a command taken here that a scene change overtook is dropped by the runner
  add("wrench commands taken", std::to_string(taken_ - snap.stale_commands));
  add("wrench commands dropped", std::to_string(dropped_ + snap.stale_commands));
  const std::string reason = lastDropReason();
  if (!reason.empty())
    add("last wrench command dropped", reason);
}

}  // namespace constrained_particles
