/// @file perturbations.hpp
/// @brief What acts on the running scene from outside it: forces ~apply_force started, the
/// target springs of dragged particles and the forces ~wrench_command streams (docs/node.md,
/// "Grab, drag and push").
#pragma once

#include "constrained_particles/core/forces.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/core/types.hpp"

#include <atomic>
#include <cstdint>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace constrained_particles
{
/// The pushes, drags and commanded forces on one scene, turned into the core's perturbation
/// forces (Simulator::setPerturbations) by forces(). Owned by the runner and used on its thread,
/// but for queueDrag(), queueRelease() and queueCommand(), which any thread may call (a mouse on
/// the interactive markers, a controller's command topic).
class Perturbations
{
public:
  /// A dragged particle is pulled by a critically damped target spring of frequency
  /// w = min(DRAG_FREQUENCY, DRAG_STEP_LIMIT / dt): k = m w^2, c = 2 m w. w dt <= 0.2 keeps every
  /// explicit integrator stable on the spring alone (the stability estimate sees it too). A
  /// heavy particle's w is lowered so that k and c stay inside limits::STIFFNESS and
  /// limits::DAMPING (it is pulled more slowly).
  static constexpr double DRAG_FREQUENCY = 10.0;  // [rad/s]
  static constexpr double DRAG_STEP_LIMIT = 0.2;  // [1]
  /// Most forces ~apply_force may have acting at once.
  static constexpr std::size_t MAX_APPLIED_FORCES = 1000;

  /// What apply() did: accepted, with the reply's message, or refused and why.
  struct Outcome
  {
    bool accepted = false;
    std::string message;
  };
  /// Pushes `particle` with `force` [N] from step `steps` on, for ceil(duration / dt) steps (at
  /// least one), or until clear() if `duration` is 0 [s]. `time` [s] and `scene` name the reply.
  /// @throws InvalidInput naming `particle`, `force.x` .. or `duration` and the valid range, for
  /// a scene of `num_particles`; nothing changes. Refused (not thrown) beyond MAX_APPLIED_FORCES.
  Outcome apply(long particle, const Vec3& force, double duration, int num_particles,
                std::uint64_t steps, double time, double dt, const std::string& scene);
  /// Ends every force apply() started; returns how many.
  std::size_t clearApplied();
  /// Ends everything: pushes, drags and queued drag updates (a reset or scene change).
  void clearAll();
  /// Ends the pushes whose last step is before `steps`; returns whether any ended. `next`: the
  /// steps until the next one ends, at most `limit` (a batch's chunk stops there).
  bool expire(std::uint64_t steps, std::uint64_t limit, std::uint64_t& next);

  /// Thread-safe: pull `particle` towards `target` [m] (see DRAG_FREQUENCY) from the next
  /// takeQueued(), for scene `scene_serial` (0: whichever is current then).
  void queueDrag(std::uint64_t scene_serial, int particle, const Vec3& target);
  /// Thread-safe: end the pull on `particle` (-1: on every particle).
  void queueRelease(std::uint64_t scene_serial, int particle);
  /// Thread-safe: push `particle` with `force` [N] (checked by checkCommand) from the next
  /// takeQueued() until a newer command for it, or until `timeout` [s] after `received` [s, on
  /// the caller's command clock] passes without one (expireCommands): a controller's
  /// command-topic contract. For scene `scene_serial` (a command for another scene is dropped
  /// and counted: staleCommands()).
  void queueCommand(std::uint64_t scene_serial, int particle, const Vec3& force, double received,
                    double timeout);
  /// The particle a ~wrench_command names, checked: `frame` is `prefix` followed by a particle
  /// index of a scene of `num_particles` written as tf frames are (no sign, no leading zero; a
  /// leading '/' is ignored, as tf2 does), each force component finite and in limits::FORCE,
  /// each torque component finite (it is ignored).
  /// @throws InvalidInput naming `header.frame_id`, `wrench.force.x` .. or `wrench.torque.x` ..
  /// and what is valid
  static int checkCommand(const std::string& frame, const std::string& prefix, const Vec3& force,
                          const Vec3& torque, int num_particles);
  /// Thread-safe: whether updates wait for takeQueued().
  bool hasQueued() const
  {
    return queued_;
  }
  /// What takeQueued() or expireCommands() changed.
  enum class Change
  {
    None,    ///< nothing (updates for another scene, bad particles or targets are dropped)
    Forces,  ///< only the targets or forces of drags and commands already acting moved
    Acting,  ///< a drag or a command began or ended
  };
  /// Applies the queued drag and command updates for the scene `scene_serial` of
  /// `num_particles`.
  Change takeQueued(std::uint64_t scene_serial, int num_particles);
  /// Ends the commands whose timeout passed by `now` [s, the command clock]; returns whether any
  /// ended. `next`: when the next one ends (+infinity if none acts).
  bool expireCommands(double now, double& next);
  /// Commands takeQueued() dropped because they were made for another scene, so far.
  std::uint64_t staleCommands() const
  {
    return stale_commands_;
  }

  /// The external forces and target springs acting now, for particles of `masses` [kg] at the
  /// step `dt` [s].
  std::vector<Force> forces(const std::vector<double>& masses, double dt) const;
  /// What a hand-over below changed for the runner: nothing; the forces the simulator has (a
  /// live accuracy window then ends: its shadow does not feel them); or also what ~state shows
  /// (a grab, a release, a command begun or ended, an applied force ended: a snapshot is due).
  enum class Effect
  {
    None,
    Forces,
    Shown,
  };
  /// Hands the forces acting now to `simulator` (Simulator::setPerturbations, drag springs at
  /// its dt); never throws: a record it refuses (not reached: each was checked on its way in)
  /// ends them all. Effect::Forces.
  Effect handTo(Simulator& simulator);
  /// takeQueued for `simulator`'s scene `scene_serial`, the commands' expiry at command time
  /// `now` [s], handed over.
  Effect takeQueuedInto(Simulator& simulator, std::uint64_t scene_serial, double now);
  /// expireCommands at command time `now` [s], handed over if any ended.
  Effect expireCommandsInto(Simulator& simulator, double now);
  /// expire at `simulator`'s step count, handed over if any ended; `next`: the steps until the
  /// next one ends (at most `limit`).
  Effect expireAppliedInto(Simulator& simulator, std::uint64_t limit, std::uint64_t& next);
  /// The earliest timeout of an acting command [s, command clock]; infinity while none acts.
  double nextCommandExpiry() const
  {
    return next_command_expiry_;
  }
  std::size_t appliedCount() const
  {
    return applied_.size();
  }
  std::size_t draggedCount() const
  {
    return drags_.size();
  }
  /// Particles a ~wrench_command pushes now.
  std::size_t commandedCount() const
  {
    return commands_.size();
  }
  bool empty() const
  {
    return applied_.empty() && drags_.empty() && commands_.empty();
  }

private:
  struct AppliedForce
  {
    ExternalForce force;
    std::uint64_t end_step = 0;  // State::steps at which it stops acting; 0: until cleared
  };
  struct Command
  {
    Vec3 force = Vec3::Zero();  // [N]
    double expires = 0;         // its timeout after the message that set it [s, command clock]
  };
  struct Update
  {
    enum Kind
    {
      Drag,
      Release,
      Push,  // a ~wrench_command
    } kind = Drag;
    std::uint64_t scene_serial = 0;
    int particle = 0;
    Vec3 value = Vec3::Zero();  // a drag's target [m] or a command's force [N]
    double expires = 0;         // a command's [s, command clock]
  };
  void queue(const Update& update);

  std::vector<AppliedForce> applied_;
  std::map<int, Vec3> drags_;        // particle -> target [m]
  std::map<int, Command> commands_;  // particle -> its commanded force
  std::uint64_t stale_commands_ = 0;
  double next_command_expiry_ = std::numeric_limits<double>::infinity();  // [s, command clock]
  std::mutex queue_mutex_;  // guards queue_ (any thread posts, the runner's thread takes)
  std::vector<Update> queue_;
  std::atomic<bool> queued_{ false };
};

}  // namespace constrained_particles
