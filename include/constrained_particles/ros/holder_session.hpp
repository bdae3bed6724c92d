/// @file holder_session.hpp
/// @brief The scene's holders outside the node (frame anchors, ~attach): their samples onto the
/// simulator's tracks, the latency they need, teleports, holds that let go, attach and detach,
/// and what became of each. Needs no ROS master: the node's FrameAnchors samples tf and posts.
#pragma once

#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/ros/pacer.hpp"
#include "constrained_particles/ros/runner_queue.hpp"

#include <Eigen/Geometry>

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace constrained_particles
{
/// One pose of a holder, as it was broadcast and as it arrived.
struct HolderSample
{
  std::int64_t stamp_ns = 0;     ///< its stamp [ns] on the node's clock (ROS time)
  std::int64_t arrival_ns = 0;   ///< when the node took it [ns], on the same clock
  Vec3 position = Vec3::Zero();  ///< the held point (holder origin plus offset), fixed frame [m]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< the holder's frame
  /// A holder that never moves (a frame resolved through /tf_static only): one sample is its
  /// whole path, and it needs no latency.
  bool still = false;
};

/// What became of one holder's samples since its model was set (HolderSession::status()).
struct HolderStatus
{
  int particle = 0;             ///< the particle it holds; -1: it carries an obstacle
  std::string shape;            ///< the obstacle it carries (Shape::name), or empty
  std::string holder;           ///< its tf frame, or its topic
  bool topic = false;           ///< `holder` is a pose topic (a frame may have the same name)
  std::uint64_t taken = 0;      ///< samples that became knots of its track
  std::uint64_t late = 0;       ///< arrived after the steps passed their time: not followed
  std::uint64_t unordered = 0;  ///< not after the last knot (repeated, or out of order): ignored
  std::uint64_t jumps = 0;      ///< teleports: over ~anchor_max_jump, or ~anchor_max_speed
  std::uint64_t future = 0;     ///< stamped over FUTURE_LIMIT ahead of the scene's clock: ignored
  std::uint64_t out_of_range = 0;  ///< a position outside limits::COORDINATE: ignored
  std::uint64_t refused = 0;       ///< teleports the scene could not be projected onto
  std::uint64_t overruns = 0;      ///< times the steps ran past its newest sample (it coasted)
  /// times the scene was carried to it after the clock went back (a new epoch: its first sample)
  std::uint64_t replaced = 0;
  std::string last_refusal;     ///< why the last teleport could not be followed
  double last_jump = 0.0;       ///< the last teleport's distance between samples [m]
  double last_stamp = -1.0;     ///< the newest sample's stamp [s] (-1: none yet)
  double needed_latency = 0.0;  ///< what its samples' arrival asks of the latency [s]
  bool coasting = false;        ///< the steps are past its newest sample now
  /// Samples are wanted from this stamp on [ns] (an ~attach's: the state it took hold at); -1:
  /// from the newest.
  std::int64_t since_ns = -1;
};

/// A hold that let go (HolderSession::letGo): it carried more than its max_force, or holds made
/// a step impossible.
struct Release
{
  int particle = 0;
  std::string holder;
  double time = 0.0;       ///< sim time [s]
  double max_force = 0.0;  ///< its limit [N]
  std::string why;         ///< what it would have carried, or which check the step failed
};

/// The node's holder parameters (~anchor_lag, ~anchor_max_jump, ~anchor_max_speed,
/// ~anchor_max_force) as the session reads them.
struct HolderLimits
{
  double lag = 0.0;         ///< fixed latency [s]; 0: chosen from the samples' arrival
  double max_jump = 0.5;    ///< a holder farther than this between samples teleported [m]
  double max_speed = 10.0;  ///< one faster than this between samples teleported [m/s]
  double max_force = 0.0;   ///< a hold's limit [N]; 0: MAX_FORCE_WEIGHTS times the scene's weight
};

/// Holders of the running scene. post() from any thread; everything else on the physics thread.
class HolderSession
{
public:
  /// A sample stamped this far [s] past the scene's time plus the latency is not of its clock.
  static constexpr double FUTURE_LIMIT = 5.0;
  /// Knots closer than this [s] are not taken (a 2 kHz holder's are): the spline's acceleration
  /// grows as 1/h^2 of its intervals, and its noise with it.
  static constexpr double MIN_SPACING = 5e-4;
  /// The latency before a holder's arrivals are measured (three samples) [s].
  static constexpr double INITIAL_LATENCY = 0.1;
  /// The latency asked is the slowest arrival measured (a sample two after the knot the steps
  /// are leaving) times this, plus LATENCY_MARGIN [s]: room for jitter and the batch (3 ms let
  /// a delivery hiccup of a shared machine overrun a 1 kHz hand once in about ten runs of
  /// holders_lockstep.test; 10 ms has room for one)
  static constexpr double LATENCY_FACTOR = 1.25;
  static constexpr double LATENCY_MARGIN = 0.010;
  /// Arrivals are measured over the samples stamped within this of the newest [s].
  static constexpr double LATENCY_WINDOW = 2.0;
  /// A hold's default limit: this many times the weight of the whole scene (g at least 9.81).
  static constexpr double MAX_FORCE_WEIGHTS = 50.0;
  /// A keep_offset ~attach waits this long [s] (wall) for tf to hold the frame's pose at the
  /// state's stamp before it is refused.
  static constexpr double ATTACH_WAIT = 1.0;

  explicit HolderSession(const HolderLimits& limits) : limits_(limits)
  {
  }

  /// Thread-safe, not waited for: samples of holder `track` of the model with serial `serial`
  /// (Snapshot::tracks_serial): the frame anchors' in Model::tracked() order, then the carried
  /// obstacles' in Model::carriers() order (their samples: the holder frame's origin and
  /// orientation). A carried obstacle's first sample, and a teleport of its holder, put it there
  /// at once (its track restarted: what it meets is projected out as an impact); it never
  /// carries the scene. Posted for a model since replaced in
  /// the same scene (an attach, a detach, a hold let go), they go to the same holder's track in
  /// the new one, if it kept it; otherwise they are dropped.
  void post(std::uint64_t serial, int track, std::vector<HolderSample> samples);
  /// A new model (a scene change, attach, detach, a hold let go): a new serial; counts go on for
  /// holders it keeps (same particle and holder). `scene_changed`: a reset or new scene
  /// (attachments and releases end).
  void setModel(const Model& model, bool scene_changed);
  std::uint64_t serial() const
  {
    return serial_;
  }
  /// A hold's limit in `scene` [N]: ~anchor_max_force, or MAX_FORCE_WEIGHTS times its weight.
  double holdLimit(const Scene& scene) const;
  /// The scene's frame anchors with max_force 0 get holdLimit(): before it is compiled.
  void limitHolds(Scene& scene) const;
  /// Drops what was posted (a scene at rest follows no holder).
  void discard();

  /// Before a chunk of steps: the posted samples onto the simulator's tracks (sample s at sim
  /// time pacer.simTimeOf(s.stamp_ns), at least `lead` [s] after now); teleports scheduled.
  void follow(Simulator& simulator, const Pacer& pacer, double lead);
  /// Steps until the next teleport of a holder (0: one is due now), at most `limit`.
  std::uint64_t stepsToNextJump(const Simulator& simulator, std::uint64_t limit) const;
  /// After a chunk: teleports whose time the steps reached carry the scene along (one holder:
  /// the whole scene moved rigidly, velocities kept; more: projected, like ~set_state); holders
  /// the steps ran past counted. True if the state was changed.
  bool afterChunk(Simulator& simulator);
  /// The latency [s] the holders need now (0 without one): ~anchor_lag if set, else measured.
  double wantedLatency() const;
  /// Every holder at rest where its point is now, its samples forgotten: the scene was
  /// teleported, or (`new_epoch`) the clock went back, and each holder's first sample then
  /// carries the scene to it as a teleport would (counted as re-placed, not as its jump).
  void rest(Simulator& simulator, bool new_epoch = false);
  /// The stamp-to-sim-time mapping moved forward (wall time dropped): each track goes on from
  /// where and how fast its point moves, its later knots forgotten.
  void resync(Simulator& simulator);

  /// What ~attach asks, checked against `model` (particle, frame, offset; a frame of this node's
  /// `frame_prefix`): the FrameAnchorConstraint to add, or a refusal naming the field.
  struct AttachRequest
  {
    long particle = 0;
    std::string frame;
    Vec3 offset = Vec3::Zero();
    bool keep_offset = false;
  };
  /// Checks `request` (particle in range and not held, not joined to held particles only; frame
  /// non-empty, no leading '/', not one of this node's particle frames; offset in range): the
  /// refusal naming the field, or nullopt.
  std::optional<std::string> checkAttach(const Model& model, const AttachRequest& request,
                                         const std::string& frame_prefix, std::string& field) const;
  /// The pose [m] of a tf frame in the fixed frame at a stamp [ns] (-1: the newest tf holds), if
  /// tf holds it (looked up without waiting; nullopt: not yet, or never).
  using PoseLookup = std::function<std::optional<Eigen::Isometry3d>(std::int64_t stamp_ns)>;
  /// An ~attach to take effect as soon as `pose_at` gives its frame's pose at the state's stamp
  /// (the caller takes no step meanwhile), by `deadline` at the latest. The refusal naming the
  /// field (checkAttach's, or another attach waiting), or nullopt.
  std::optional<RunnerReply> beginAttach(const Model& model, const AttachRequest& request,
                                         const std::string& frame_prefix, PoseLookup pose_at,
                                         std::chrono::steady_clock::time_point deadline);
  /// An ~attach waits for its frame's pose.
  bool attaching() const
  {
    return pending_.has_value();
  }
  /// The waiting ~attach at the state now (stamp `stamp_ns`, -1: no clock yet): its reply once
  /// its frame's pose there is known (attach()), or refused naming `frame` after its deadline;
  /// nullopt while it still waits.
  /// A `resting` scene (paused, faulted) stands for the clock now: the frame's newest pose then.
  std::optional<RunnerReply> tryAttach(Simulator& simulator, std::int64_t stamp_ns, bool resting,
                                       std::chrono::steady_clock::time_point now);
  /// Forgets the waiting ~attach (the node shuts down).
  void cancelAttach()
  {
    pending_.reset();
  }

  /// What an attach did.
  struct Attached
  {
    FrameAnchorConstraint anchor;  ///< the record added (its offset, its max_force)
    double moved = 0.0;            ///< the particle's move to the held point [m]
    double displaced = 0.0;        ///< the largest move of a particle the projection made [m]
  };
  /// Adds the hold `request` asks for to `simulator` at the state now, its frame at `pose` (in
  /// the fixed frame at the state's stamp `stamp_ns`, from which the holder is then sampled):
  /// the particle held where it is (keep_offset) or carried to pose * offset, the scene
  /// projected after it; the model set anew (a new serial).
  /// @throws InvalidInput naming `particle` or `offset`, with nothing changed
  Attached attach(Simulator& simulator, const AttachRequest& request, const Eigen::Isometry3d& pose,
                  std::int64_t stamp_ns);
  /// Lets go of the attachment of `particle` on `simulator` (it goes on with its velocity); the
  /// refusal naming `particle` (not attached: `attached_now` lists those that are), or nullopt.
  std::optional<std::string> detach(Simulator& simulator, long particle);
  /// A hold over its limit (StepStatistics::hold, hold_force, hold_failure) lets go of its
  /// particle on `simulator`, the release noted (Release).
  /// @throws InvalidInput if the scene refuses the constraints without it (not reached)
  void letGo(Simulator& simulator, const StepStatistics& failed);

  /// Each holder's counts, in track order.
  const std::vector<HolderStatus>& status() const
  {
    return status_;
  }
  const std::vector<Release>& releases() const
  {
    return releases_;
  }

private:
  /// `simulator`'s constraints replaced (state kept), the model set anew.
  /// @throws InvalidInput if the scene refuses them; nothing changed
  ProjectionReport setConstraints(Simulator& simulator, const std::vector<Constraint>& constraints);
  struct Arrival
  {
    std::int64_t stamp_ns, arrival_ns;
    std::int64_t need_ns;  // its arrival less the stamp of the sample two before
  };
  struct Holder
  {
    std::deque<Arrival> arrivals;  // recent samples, by stamp
    bool measured = false;         // three samples arrived: needed_latency is measured
    bool still = false;            // a /tf_static holder
    bool replace = false;          // its next sample carries the scene to it (a new epoch)
    bool has_previous = false;     // a sample taken since the track (re)started
    std::int64_t previous_ns = 0;  // its stamp and where it was (before any jump)
    Vec3 previous = Vec3::Zero();
  };
  struct Post
  {
    std::uint64_t serial;
    int track;
    std::vector<HolderSample> samples;
  };
  /// A holder by what it is, across models: its particle, its holder's name and the offset its
  /// samples were made with (a re-attach at another offset is another holder).
  struct TrackKey
  {
    int particle;  // -1: an obstacle's
    std::string holder;
    bool topic;  // holder is a pose topic, not a tf frame of the same name
    Vec3 offset;
    std::string shape;  // the obstacle's name, or empty
    bool operator==(const TrackKey& other) const
    {
      return particle == other.particle && holder == other.holder && topic == other.topic &&
             offset == other.offset && shape == other.shape;
    }
  };
  /// Holder k's track: a frame anchor's (Simulator::tracks()), or after them an obstacle's
  /// (Simulator::carriers()); nullptr past both.
  static AnchorTrack* trackOf(Simulator& simulator, int k);
  /// `post`'s track in the newest model (posted_serial_), or false if its holder was not held
  /// through every model since the post's (or one of them is forgotten). Caller holds mutex_.
  bool toNewest(Post& post) const;
  /// One sample of holder `k` onto `track`.
  void take(int k, const HolderSample& sample, AnchorTrack& track, double now, double time,
            double lead);
  /// Notes an arrival and updates the holder's needed latency.
  void measure(int k, const HolderSample& sample);

  HolderLimits limits_;
  std::mutex mutex_;  // guards inbox_, posted_serial_ and keys_
  std::vector<Post> inbox_;
  std::uint64_t posted_serial_ = 0;
  std::map<std::uint64_t, std::vector<TrackKey>> keys_;  // each recent serial's holders, this scene
  std::uint64_t serial_ = 0;
  std::vector<HolderStatus> status_;  // per track
  std::vector<Holder> holders_;       // per track
  std::vector<int> attachments_;      // particles ~attach holds (scene order)
  std::vector<Release> releases_;     // since the scene started
  struct PendingAttach
  {
    AttachRequest request;
    PoseLookup pose_at;
    std::chrono::steady_clock::time_point deadline;
  };
  std::optional<PendingAttach> pending_;  // an ~attach waiting for its frame's pose
};

}  // namespace constrained_particles
