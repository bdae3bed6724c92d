/// @file simulation_runner.hpp
/// @brief The thread that owns the simulation. Only it steps; every change (reset, new surface or
/// chain, teleport, pause, step N, reconfigure, attach) is queued as a request and applied
/// between batches of steps, and its caller is answered once it is applied (turtlesim's
/// queue-and-apply shape). After batches it hands out immutable snapshots, so publishers never
/// take a lock the physics holds and never solve anything. Pacing and clocks are the Pacer's,
/// holders the HolderSession's, the fault wording fault_policy's: the runner calls them, never
/// the reverse. Needs no ROS master: the tests drive it directly.
#pragma once

#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/ros/accuracy_monitor.hpp"
#include "constrained_particles/ros/holder_session.hpp"
#include "constrained_particles/ros/pacer.hpp"
#include "constrained_particles/ros/parameters.hpp"
#include "constrained_particles/ros/perturbations.hpp"
#include "constrained_particles/ros/runner_queue.hpp"
#include "constrained_particles/ros/scene_session.hpp"
#include "constrained_particles/ros/shadow_reference.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <Eigen/Geometry>

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace constrained_particles
{
/// Everything publishing needs, taken after a batch or a request; never changed afterwards.
struct Snapshot
{
  std::uint64_t serial = 0;        ///< one more for each snapshot
  std::uint64_t scene_serial = 0;  ///< one more for each model change (frames, markers); from 1
  std::shared_ptr<const Model> model;
  std::shared_ptr<const SceneDescription> scene;  ///< with the changes requests made to it
  NodeParameters parameters;  ///< in force: step settings, real-time factor, publish rate
  State state;
  /// Constraint forces [N] (3 x n) and multipliers as the last step used them (its last stage;
  /// after a reset or teleport, at the new state).
  Points constraint_forces;
  Eigen::VectorXd multipliers;
  /// Each surface contact's mode and forces at the last evaluation (Data::contacts)
  std::vector<ContactState> contacts;
  /// The carried shapes' tracks (Data::carriers): where each is at the state's time
  std::vector<AnchorTrack> carriers;
  Diagnostics diagnostics;  ///< errors and energies of `state`
  EnergyLedger ledger;  ///< the energy account since t0 (a reset, teleport, force or world change)
  /// The steps overdrew ~energy_budget: fast_projection takes them (StepControl::budget_fallback)
  /// until the ledger opens again or the settings change; what it said, else ''
  std::string energy_fallback;
  /// The stage path the steps take under the settings in force, and why (forward_path.hpp).
  PathChoice forward_path;
  /// ~publish_clock's clock [s] at this state: sim time plus the time of every earlier reset,
  /// plus Pacer::TIME_JUMP per reset, scene change, teleport or fault, so it never repeats or
  /// goes back (Pacer::base()).
  double stamp = 0;
  /// The ROS time [ns] this state stands for (Pacer::standsFor): its outputs' stamp. -1: none
  /// (no /clock yet; on wall time while paused or faulted: the time it is published at).
  std::int64_t stamp_ns = -1;
  /// /clock epochs (~follow_clock): one more each time the clock went back.
  std::uint64_t epoch = 0;
  /// The latency [s] the scene runs behind its clock so that its holders' samples arrive first
  /// (0 without a holder): a state stamped t is taken no sooner than at clock t + latency.
  double latency = 0;
  double step_time = 0;         ///< wall time per step over the last batch [s]
  double real_time_factor = 0;  ///< achieved sim seconds per wall second over the last window
  bool behind = false;          ///< sustained shortfall against the wanted real-time factor
  bool paused = false;
  bool stepping = false;  ///< a ~step request is running
  bool faulted = false;   ///< stepping stopped until a reset (fault_reason says why)
  std::string fault_reason;
  /// The last live accuracy report (null before the first, or with ~accuracy_window 0 before).
  std::shared_ptr<const AccuracyReport> accuracy;
  /// The shadow reference's positions (3 x n) [m] at this snapshot's time, when a window sample
  /// fell on it (null otherwise): the ghosts drawn beside the particles.
  std::shared_ptr<const Points> reference_positions;
  /// Live accuracy windows skipped so far because the shadow was busy (counted as they pass).
  std::uint64_t skipped_windows = 0;
  /// The scene's region of interest (sceneRegion): camera, surface mesh, force-arrow scale.
  RegionSpec region;
  /// Forces applied by ~apply_force acting now, and particles held by a drag.
  std::uint32_t applied_forces = 0, dragged_particles = 0;
  /// Particles a ~wrench_command pushes now.
  std::uint32_t commanded_particles = 0;
  /// Wrench commands dropped on arrival because a scene change came first (not counted by the
  /// node, which took them).
  std::uint64_t stale_commands = 0;
  /// One more for each change of the model's holders (a scene change, attach, detach, a hold let
  /// go): what SimulationRunner::postHolderSamples is told; from 1.
  std::uint64_t tracks_serial = 0;
  /// Each tracked record's counts (Model::tracked() order) and its holder's orientation at the
  /// state's time (the frame a frame anchor's wrench is expressed in).
  std::vector<HolderStatus> holders;
  std::vector<Eigen::Quaterniond> holder_orientations;
  /// Holds that let go since the scene started (over their max_force, or impossible).
  std::vector<Release> releases;
};

/// Runs one simulation on its own thread.
class SimulationRunner
{
public:
  /// Longest wall time one batch of steps may take before the runner applies requests and
  /// offers a snapshot; at least one step is always taken.
  static constexpr double BATCH_WALL_TIME = 0.02;  // [s]
  /// Steps are taken in chunks of about this wall time, each checked for a fault (non-finite
  /// state, constraint error over ~max_constraint_error, a failed step check, e.g. a dopri5 step
  /// forced at its guards with ~max_substeps 1): a fault keeps every good chunk.
  static constexpr double CHECK_WALL_TIME = 0.002;  // [s]
  static constexpr double BATCH_PERIOD = Pacer::BATCH_PERIOD;
  static constexpr double TIME_JUMP = Pacer::TIME_JUMP;
  static constexpr double RATE_WINDOW = Pacer::RATE_WINDOW;

  /// Who reads statistics: each gets the merged statistics of every step since it last read.
  enum class Reader
  {
    State,
    Diagnostics
  };
  /// The pose [m] of a tf frame in the fixed frame at a stamp [ns], if tf holds it (the node
  /// looks it up without waiting; nullopt: not yet, or never).
  using PoseLookup = HolderSession::PoseLookup;

  /// Compiles `scene` with `parameters` (its `solver` section, then the step settings the user
  /// gave: parameters.step_given). Does not step until start().
  /// @throws InvalidInput naming the bad field; nothing is started
  SimulationRunner(const NodeParameters& parameters, const SceneDescription& scene);
  ~SimulationRunner();

  SimulationRunner(const SimulationRunner&) = delete;
  SimulationRunner& operator=(const SimulationRunner&) = delete;

  /// Starts the physics thread (running, or paused when `paused`).
  void start(bool paused = false);
  /// Stops the physics thread; waiting requests are refused. Returns false if the thread is
  /// still inside a step after `timeout` (it exits after that step; the destructor waits).
  bool stop(std::chrono::milliseconds timeout);

  /// The latest snapshot (never null after construction).
  std::shared_ptr<const Snapshot> snapshot() const;
  /// The latest snapshot, and in `statistics` those of every step up to it since `reader` last
  /// called this, merged (taken together, so they match the snapshot exactly).
  std::shared_ptr<const Snapshot> snapshot(Reader reader, StepStatistics& statistics);

  // Requests: each blocks until the physics thread applied it between batches (or refused it).
  /// Back to the start of the current scene (`scenario` empty) or of another scene (a name in
  /// ~scene_directory or a file path), with its own solver settings under the user's.
  RunnerReply reset(const std::string& scenario);
  /// ~set_surface: the current scene's first surface replaced (SceneSession::forSurface), then a
  /// reset to it, or (`keep_state`) the state going on on it (Simulator::setSurfaces: the reply's
  /// max_displacement the projection's largest move); refused naming the field, with nothing
  /// changed.
  RunnerReply setSurface(const std::string& type, const std::vector<double>& coefficients,
                         const std::string& expression, bool keep_state = false);
  /// ~set_obstacle: an obstacle added, replaced or removed (SceneSession::forObstacle) with the
  /// state going on (Simulator::setObstacles: the reply's max_displacement and
  /// max_velocity_change say how far particles were moved out); a carried one's holder followed
  /// from then on (HolderSession::setModel), a kept one's track going on. Refused naming the
  /// field, with nothing changed (also a frame of this node's ~frame_prefix, or a topic that is
  /// not a valid ROS name: the holder could not be followed).
  /// `holder_refusal` (holderRefusal) says why a carried shape's holder cannot be followed.
  RunnerReply setObstacle(
      ObstacleChange change, const std::string& name, const std::string& shape,
      const std::function<std::string(const std::string& frame, const std::string& topic)>&
          holder_refusal = {});
  /// ~set_chain: every chain of the current scene changed (SceneSession::forChain), then a reset
  /// to it; refused naming the field and its range, with nothing changed.
  RunnerReply setChain(const ChainChange& change);
  /// Teleports (projected onto the constraints); time is kept.
  RunnerReply setState(const Points& positions, const Points& velocities);
  RunnerReply pause();
  RunnerReply unpause();
  /// While paused: `steps` steps in batches; a pause, unpause, reset or scene change sent
  /// meanwhile stops it at the next batch (the reply says how many were taken).
  RunnerReply step(std::uint64_t steps);
  /// Edits a copy of the node parameters (step settings, real-time factor, publish rate, gravity
  /// and damping overrides), given the current scene, and applies it if every value is valid;
  /// refused otherwise, naming the field, with nothing changed.
  RunnerReply reconfigure(
      const std::function<void(NodeParameters&, const SceneDescription&)>& edit);
  /// Pushes `particle` with `force` [N] from the next step on, for ceil(duration / dt) steps at
  /// the dt in force now (at least one), or until clearForces() if `duration` is 0 [s]:
  /// an external force the step evaluates only while it acts (Simulator::setPerturbations).
  /// Refused naming `particle`, `force.x` .. or `duration` and the valid range; at most
  /// Perturbations::MAX_APPLIED_FORCES at once. A reset or scene change ends them all.
  RunnerReply applyForce(long particle, const Vec3& force, double duration);
  /// ~attach: holds `particle` with tf frame `frame` from the state the request is applied at
  /// (stamp t): at `offset` [m] in the frame's axes (the particle moved there, the scene
  /// projected after it: the reply's max_displacement), or where it is (`keep_offset`: the offset
  /// is the particle's place in the frame's pose at t). The frame's pose at t comes from
  /// `pose_at`; while tf has none yet the runner waits for it without stepping, at most
  /// HolderSession::ATTACH_WAIT, then refuses naming `frame`. Refused naming `particle` (out of
  /// range, already held, joined to held particles only), `frame` (empty, a leading /, one of
  /// this node's particle frames) or `offset` (outside limits::COORDINATE), with nothing
  /// changed. Kept across ~pause; a reset or scene change ends every attachment.
  RunnerReply attach(long particle, const std::string& frame, const Vec3& offset, bool keep_offset,
                     PoseLookup pose_at);
  /// ~detach: lets go of an attached `particle`: it goes on from the velocity it has. Refused
  /// naming `particle` if it is not attached (a scene's own pins and anchors stay).
  RunnerReply detach(long particle);
  /// Ends every force applyForce started (the reply says how many).
  RunnerReply clearForces();
  /// Pulls `particle` towards `target` [m] with a critically damped target spring (see
  /// Perturbations::DRAG_FREQUENCY) from the next batch until release(); a later call moves the
  /// target. Not waited for: a mouse sends these at its own rate, and the runner reads the newest
  /// once per batch. `scene_serial` is the Snapshot::scene_serial the caller's particle index
  /// belongs to (0: the current scene); an update for another scene, a particle out of range or a
  /// target outside limits::COORDINATE is dropped. A reset or scene change releases every particle.
  void drag(std::uint64_t scene_serial, int particle, const Vec3& target);
  /// Ends the pull on `particle` (-1: on every particle). Not waited for.
  void release(std::uint64_t scene_serial, int particle);
  /// Pushes `particle` with `force` [N] (Perturbations::checkCommand checked both) from the next
  /// chunk of steps until a newer command for it, or until ~wrench_timeout passes without one
  /// on the command clock (setCommandClock; checked at every chunk of steps and when idle). Not
  /// waited for: a controller streams these. For scene `scene_serial`, like drag(). A reset or
  /// scene change ends them all.
  void commandWrench(std::uint64_t scene_serial, int particle, const Vec3& force);
  /// Thread-safe: the newest /clock [ns since its epoch]. With ~follow_clock the runner steps
  /// the scene up to it less the latency (Pacer), never past it; no clock yet, no steps.
  /// Paced by the clock alone (~real_time_factor unused); ~step refused.
  void followClock(std::int64_t clock_ns);
  /// Thread-safe: the newest /clock followed [ns] (-1: none; without ~follow_clock: -1).
  std::int64_t newestClock() const
  {
    return pacer_.newestClock();
  }
  /// Thread-safe, not waited for: poses of the holder of track `track` (Model::tracked() order)
  /// of the model with Snapshot::tracks_serial `tracks_serial`, stamped on the node's ROS clock:
  /// a sample stamped s is where the held particle is at the sim time that stands for s
  /// (HolderSession), taken at the next chunk of steps. Ignored while paused or faulted.
  void postHolderSamples(std::uint64_t tracks_serial, int track, std::vector<HolderSample> samples);
  /// The clock ~wrench_timeout is measured on [s] (the node's ROS time: wall, or /clock under
  /// /use_sim_time); steady wall seconds until set. Set before start().
  void setCommandClock(std::function<double()> now);

private:
  /// Frame anchors or carried obstacles follow holders outside the node.
  bool hasHolders() const
  {
    return !simulator_->tracks().empty() || !simulator_->carriers().empty();
  }

  using Clock = std::chrono::steady_clock;
  struct StepRequest
  {
    std::uint64_t wanted = 0;
    std::uint64_t taken = 0;
    double sim_time = 0;  // after the steps taken [s]
    std::shared_ptr<std::promise<RunnerReply>> reply;
  };
  /// Applies the candidate `make` returns (SceneSession) and answers "`what`; scene ... reset".
  RunnerReply changeScene(const std::function<SceneSession::Candidate()>& make,
                          const std::string& what);
  /// What a change of the perturbations means here: the accuracy window ends (the shadow does
  /// not feel them), and a snapshot is due where ~state shows it.
  void noteForces(Perturbations::Effect effect);
  void loop();
  /// Applies the queued requests; true if there were any.
  bool applyRequests();
  /// The wait of an idle loop: until a request, the next due step, a clock, a command's timeout.
  void idle(Clock::time_point now);
  /// The steps due now: a ~step's rest, or the Pacer's.
  std::uint64_t stepsDue(Clock::time_point start);
  /// The first clock, or one that went back (Pacer::noticeEpoch), every loop: the holders rest.
  void noticeEpoch();
  /// One batch of due steps, bounded by BATCH_WALL_TIME; false if none were due.
  bool runBatch();
  /// The steps of the next chunk: about CHECK_WALL_TIME of them, at most `left`.
  int chunkSize(std::uint64_t left, Clock::time_point batch_start);
  /// One chunk of at most `steps` steps, its holders followed before and after; false if it
  /// faulted (the good state put back) or a live accuracy sample ends the batch.
  bool runChunk(int steps, StepStatistics& batch);
  /// After a batch: its last step's forces, its time per step, its statistics; a ~step's count;
  /// on wall time the steps it could not take dropped.
  void endBatch(Clock::time_point start, std::uint64_t wanted, std::uint64_t taken,
                bool out_of_time, const StepStatistics& batch);
  /// Stops stepping, puts back `good` and records why.
  void fault(const std::string& reason, const State& good);
  /// Ends a running ~step early (nothing if none runs).
  void interruptStep(const std::string& by);
  void finishStep(bool success, const std::string& message);
  /// Runs `candidate` (SceneSession) from its start, its settings current.
  /// @throws InvalidInput if the simulator refuses it; nothing changes
  void apply(const SceneSession::Candidate& candidate);
  /// Tries the pending ~attach once: applied, refused, or still waiting (false).
  bool tryAttach();
  /// The latency the holders ask, handed to the pacer.
  void updateLatency(Clock::time_point now);
  /// Restarts pacing from the current state.
  void reanchor(Pacer::Anchor anchor = Pacer::Anchor::Now);
  void makeSnapshot();
  /// Live accuracy (AccuracyMonitor::update) after a batch; a finished report makes a snapshot.
  void updateAccuracy();
  /// The forces and multipliers (and, `model_changed`, the model copy) after a change of state
  /// or model between steps; the accuracy window ends; a snapshot due.
  void afterChange(bool model_changed = false);
  /// The snapshots' copy of the simulator's model, and its modelVersion().
  void copyModel();
  /// The stamp [ns] the state stands for now (Pacer::stampAt).
  std::int64_t stampNow() const
  {
    return pacer_.stampAt(simulator_->state().time, simulator_->state().steps, paused_ || faulted_);
  }

  // owned by the physics thread once started (the constructor and stop() before it)
  NodeParameters parameters_;
  SceneSession session_;         // the scene and the user's step settings (scene_session.hpp)
  const double wrench_timeout_;  // ~wrench_timeout [s]: read by commandWrench on any thread
  std::function<double()> command_clock_;  // ~wrench_timeout's clock [s]
  Pacer pacer_;                            // when steps are due, what a state stands for
  HolderSession holders_;                  // holders' samples, attachments, holds let go
  Perturbations perturbations_;            // pushes, drags and wrench commands (perturbations.hpp)
  AccuracyMonitor accuracy_;               // live accuracy windows (accuracy_monitor.hpp)
  RunnerQueue queue_;                      // requests from other threads; this thread's wake-ups
  std::unique_ptr<Simulator> simulator_;
  std::shared_ptr<const Model> model_copy_;
  std::uint64_t model_copy_version_ = 0;  // the Simulator::modelVersion() it was copied at
  std::shared_ptr<std::promise<RunnerReply>> attach_reply_;  // the waiting ~attach's
  std::optional<StepRequest> step_request_;
  bool paused_ = false, faulted_ = false;
  std::string fault_reason_;
  State last_good_;
  Points forces_;  // the constraint forces and multipliers of the snapshot to come
  Eigen::VectorXd multipliers_;
  double step_time_ = 0, step_time_estimate_ = 0;  // [s] per step: last batch, last chunk
  int last_chunk_ = 1;                             // steps in the last chunk
  bool unpublished_ = false;                       // steps taken since the last snapshot
  bool snapshot_due_ = true;
  Clock::time_point last_snapshot_wall_;
  std::uint64_t snapshot_serial_ = 0;  // 0: none yet, for readers

  std::mutex exit_mutex_;
  std::condition_variable exited_cv_;
  bool exited_ = false;
  std::thread thread_;

  mutable std::mutex snapshot_mutex_;  // guards the two below; held only to swap pointers
  std::shared_ptr<const Snapshot> snapshot_;
  std::array<StepStatistics, 2> unread_;  // per Reader, up to snapshot_
  StepStatistics pending_;                // physics thread: batches since the last snapshot
};

}  // namespace constrained_particles
