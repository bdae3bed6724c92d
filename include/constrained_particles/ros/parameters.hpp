/// @file parameters.hpp
/// @brief simulator_node's private parameters: defaults, reading and validation. Every range is
/// a limits.hpp range, read through the same field descriptors as the core and scene files.
#pragma once

#include "constrained_particles/core/limits.hpp"
#include "constrained_particles/core/settings.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <ros/node_handle.h>

#include <optional>
#include <string>
#include <vector>

namespace constrained_particles
{
/// Start-up changes to the scene, each only if its parameter is set (~chain/*, ~surface/*,
/// ~gravity, ~damping): the scene file says the rest.
struct SceneOverrides
{
  std::optional<int> num_particles;     ///< every chain's particle count
  std::optional<double> link_length;    ///< every chain's link length [m]
  std::optional<double> particle_mass;  ///< every chain's particle mass [kg]
  std::optional<bool> pin_first;        ///< chains not on a surface: pin the first particle
  std::optional<Surface> surface;       ///< replaces the scene's first surface
  std::optional<Vec3> gravity;          ///< [m/s^2], zero = no gravity
  std::optional<double> damping;        ///< linear damping [N s/m], 0 = none

  /// Applies them to a scene description. Chain and surface changes are skipped (and
  /// returned as warnings) when the scene has no chain or no surface.
  /// @throws InvalidInput naming the parameter
  std::vector<std::string> applyTo(SceneDescription& description) const;
};

/// Everything config/default.yaml holds; defaults match it.
struct NodeParameters
{
  std::string scenario = "chain";  ///< scene name in scene_directory, or a scene file path
  std::string scene_directory;     ///< where scene names are looked up (package config/scenes)
  /// The robot's URDF, for scenes' `robot_links`: the `robot_description` parameter (in the
  /// node's namespace, as robot_state_publisher reads it; not a ~ parameter), read at start-up
  std::string robot_description;
  SceneOverrides overrides;  ///< start-up changes to the scene
  StepSettings step;         ///< dt [s], integrator, stabilisation, tolerances
  /// Names of the StepSettings fields set as parameters: those win over the start-up scene's
  /// own `solver` settings.
  std::vector<std::string> step_given;
  double real_time_factor = 1.0;           ///< sim seconds per wall second
  double publish_rate = 30.0;              ///< [Hz]
  double status_period = 0.0;              ///< status log period [s], 0 = off (default)
  int max_particles = 100000;              ///< largest scene accepted
  std::string fixed_frame = "world";       ///< parent of every particle frame
  std::string frame_prefix = "particle_";  ///< child frame = prefix + index
  double force_scale = 0.0;                ///< arrow length per newton [m/N]; 0 = auto
  int tf_frames = -1;  ///< frames on /tf: -1 all up to limits::DEFAULT_TF_FRAMES, 0 none, N first N
  bool interactive = false;           ///< grab-and-drag interactive markers on ~grab (GrabMarkers)
  double max_constraint_error = 0.1;  ///< fault beyond this constraint error [m]
  int mesh_cells = 40;                ///< surface mesh cells per side
  bool publish_clock = false;         ///< publish /clock from sim time and stamp with it
  /// step in lockstep with /clock (use_sim_time, no publish_clock): SimulationRunner::followClock
  bool follow_clock = false;
  /// Live accuracy window against a shadow reference [s], 0 = off (SimulationRunner)
  double accuracy_window = 0.0;
  /// A ~wrench_command acts until a newer one for its particle or this long after it [s]
  double wrench_timeout = 0.5;
  /// The latency a scene with holders runs behind its clock [s]; 0: chosen from their samples
  double anchor_lag = 0.0;
  /// A holder that moves farther between two samples teleported: the scene carried along [m]
  double anchor_max_jump = 0.5;
  /// A holder that moves faster between two samples teleported [m/s]
  double anchor_max_speed = 10.0;
  /// The largest force a hold carries before it lets go [N]; 0: 50 times the scene's weight
  double anchor_max_force = 0.0;

  /// The node's own settings (the step's are StepSettings::fields()): name, member, range.
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("real_time_factor", &NodeParameters::real_time_factor, FieldKind::Number,
              &limits::REAL_TIME_FACTOR, "simulated seconds per wall second"),
        field("publish_rate", &NodeParameters::publish_rate, FieldKind::Number,
              &limits::PUBLISH_RATE, "tf, ~state and marker rate"),
        field("status_period", &NodeParameters::status_period, FieldKind::Number,
              &limits::STATUS_PERIOD, "status log period, 0 = off"),
        field("max_particles", &NodeParameters::max_particles, FieldKind::Number,
              &limits::PARTICLES, "largest scene accepted"),
        field("force_scale", &NodeParameters::force_scale, FieldKind::Number, &limits::FORCE_SCALE,
              "constraint-force arrow length per newton, 0 = scaled to the scene"),
        field("tf_frames", &NodeParameters::tf_frames, FieldKind::Number, &limits::TF_FRAMES,
              "particle frames on /tf: -1 = all up to 1000, 0 = none, N = the first N"),
        field("max_constraint_error", &NodeParameters::max_constraint_error, FieldKind::Number,
              &limits::MAX_CONSTRAINT_ERROR, "stepping stops beyond this constraint error"),
        field("mesh_cells", &NodeParameters::mesh_cells, FieldKind::Number, &limits::MESH_CELLS,
              "surface mesh cells per side"),
        field("accuracy_window", &NodeParameters::accuracy_window, FieldKind::Number,
              &limits::ACCURACY_WINDOW, "live accuracy window against a shadow reference, 0 = off"),
        field("wrench_timeout", &NodeParameters::wrench_timeout, FieldKind::Number,
              &limits::WRENCH_TIMEOUT,
              "a ~wrench_command acts until a newer one or this long after it"),
        field("anchor_lag", &NodeParameters::anchor_lag, FieldKind::Number, &limits::ANCHOR_LAG,
              "the latency a scene with holders runs behind its clock, 0 = chosen from their "
              "samples' arrival"),
        field("anchor_max_jump", &NodeParameters::anchor_max_jump, FieldKind::Number,
              &limits::ANCHOR_MAX_JUMP,
              "a holder that moves farther between two samples teleported: the scene is carried "
              "along"),
        field("anchor_max_speed", &NodeParameters::anchor_max_speed, FieldKind::Number,
              &limits::ANCHOR_MAX_SPEED,
              "a holder that moves faster between two samples teleported"),
        field("anchor_max_force", &NodeParameters::anchor_max_force, FieldKind::Number,
              &limits::HOLD_FORCE,
              "the largest force a hold carries before it lets go, 0 = 50 times the scene's "
              "weight"),
        field("scenario", &NodeParameters::scenario, FieldKind::Name, nullptr,
              "scene name or scene file path"),
        field("scene_directory", &NodeParameters::scene_directory, FieldKind::Name, nullptr,
              "where scene names are looked up"),
        field("fixed_frame", &NodeParameters::fixed_frame, FieldKind::Name, nullptr,
              "parent frame of every particle frame"),
        field("frame_prefix", &NodeParameters::frame_prefix, FieldKind::Name, nullptr,
              "child frames are <frame_prefix><i>"),
        field("publish_clock", &NodeParameters::publish_clock, FieldKind::Flag, nullptr,
              "publish /clock from sim time"),
        field("follow_clock", &NodeParameters::follow_clock, FieldKind::Flag, nullptr,
              "step in lockstep with /clock (use_sim_time)"),
        field("interactive", &NodeParameters::interactive, FieldKind::Flag, nullptr,
              "grab-and-drag interactive markers on ~grab"));
  }
};

/// The range of a setting by the name users give it: a StepSettings or NodeParameters field, a
/// scene override (damping, gravity and dynamic_reconfigure's gravity_x, _y, _z, chain/*); nullptr
/// for names (integrator, frames) and unknown names. dynamic_reconfigure's ranges must be these.
const Range* settingRange(const std::string& name);

/// Particle frames /tf carries for a scene of `particles` with ~tf_frames = `tf_frames`.
int tfFrameCount(int particles, int tf_frames);

/// Reads every parameter from the (private) node handle, over the defaults.
/// @throws InvalidInput naming the parameter ("~chain/link_length") and its valid range
NodeParameters readParameters(const ros::NodeHandle& private_nh);

/// What scene files draw on from the node: its robot_description, and ROS packages' directories
/// (roslib's ros::package::getPath) for `package://` mesh files.
SceneInputs sceneInputs(const NodeParameters& parameters);

/// Checks every setting against its range and the node's own rules (frames, scenario).
/// @throws InvalidInput naming the parameter ("~dt")
void validateNodeParameters(const NodeParameters& parameters);

}  // namespace constrained_particles
