/// @file perturbations.hpp
/// @brief What acts on the running scene from outside it: forces ~apply_force started and the
/// target springs of dragged particles (docs/node.md, "Grab, drag and push").
#pragma once

#include "constrained_particles/core/forces.hpp"
#include "constrained_particles/core/types.hpp"

#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace constrained_particles
{
/// The pushes and drags on one scene, turned into the core's perturbation forces
/// (Simulator::setPerturbations) by forces(). Owned by the runner and used on its thread, but for
/// queueDrag() and queueRelease(), which any thread may call (a mouse on the interactive markers).
/// The command streams to come (wrench commands, frame anchors' holders) belong here too.
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
  /// Thread-safe: whether updates wait for takeQueued().
  bool hasQueued() const
  {
    return queued_;
  }
  /// What takeQueued() changed.
  enum class DragChange
  {
    None,     ///< nothing (updates for another scene, bad particles or targets are dropped)
    Targets,  ///< only the targets of particles already dragged moved
    Grabbed,  ///< a particle was grabbed or released
  };
  /// Applies the queued drag updates for the scene `scene_serial` of `num_particles`.
  DragChange takeQueued(std::uint64_t scene_serial, int num_particles);

  /// The external forces and target springs acting now, for particles of `masses` [kg] at the
  /// step `dt` [s].
  std::vector<Force> forces(const std::vector<double>& masses, double dt) const;
  std::size_t appliedCount() const
  {
    return applied_.size();
  }
  std::size_t draggedCount() const
  {
    return drags_.size();
  }
  bool empty() const
  {
    return applied_.empty() && drags_.empty();
  }

private:
  struct AppliedForce
  {
    ExternalForce force;
    std::uint64_t end_step = 0;  // State::steps at which it stops acting; 0: until cleared
  };
  struct DragUpdate
  {
    std::uint64_t scene_serial = 0;
    int particle = 0;
    Vec3 target = Vec3::Zero();
    bool release = false;
  };
  void queue(const DragUpdate& update);

  std::vector<AppliedForce> applied_;
  std::map<int, Vec3> drags_;  // particle -> target [m]
  std::mutex queue_mutex_;     // guards queue_ (any thread posts, the runner's thread takes)
  std::vector<DragUpdate> queue_;
  std::atomic<bool> queued_{ false };
};

}  // namespace constrained_particles
