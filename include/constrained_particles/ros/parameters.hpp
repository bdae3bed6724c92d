/// @file parameters.hpp
/// @brief simulator_node's private parameters: defaults, reading and validation.
#pragma once

#include "constrained_particles/core/dynamics.hpp"
#include "constrained_particles/core/scenarios.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <ros/node_handle.h>

#include <optional>
#include <string>

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
  SceneOverrides overrides;        ///< start-up changes to the scene
  StepSettings step;               ///< dt [s], integrator, stabilisation
  /// Which of dt, integrator and stabilization were set as parameters: those win over the
  /// start-up scene's own `solver` settings.
  struct
  {
    bool dt = false, integrator = false, stabilization = false;
  } step_set;
  double real_time_factor = 1.0;           ///< sim seconds per wall second, (0, 100]
  double publish_rate = 30.0;              ///< [Hz], [0.1, 1000]
  double status_period = 1.0;              ///< status log period [s], 0 = off
  int max_particles = 100000;              ///< largest scene accepted, [1, MAX_PARTICLES]
  std::string fixed_frame = "world";       ///< parent of every particle frame
  std::string frame_prefix = "particle_";  ///< child frame = prefix + index
  double force_scale = 0.05;               ///< arrow length per newton [m/N], (0, 1e3]
  double max_constraint_error = 0.1;       ///< fault beyond this constraint error [m], (0, 1e3]
  int mesh_cells = 40;                     ///< surface mesh cells per side, [2, MAX_MESH_CELLS]
  bool publish_clock = false;              ///< publish /clock from sim time and stamp with it
};

/// Largest dt the node accepts [s].
constexpr double MAX_NODE_DT = 0.1;
/// Largest |coordinate| [m] and |velocity component| [m/s] ~set_state accepts.
constexpr double MAX_STATE_COORDINATE = 1e6;

/// Reads every parameter from the (private) node handle, over the defaults.
/// @throws InvalidInput naming the parameter ("~chain/link_length") and its valid range
NodeParameters readParameters(const ros::NodeHandle& private_nh);

/// Checks ranges that are the node's own (rates, frames, dt limit, max_particles).
/// @throws InvalidInput naming the parameter
void validateNodeParameters(const NodeParameters& parameters);

/// Checks a chain against the node's limits, with the given field prefix ("" for a service).
/// @throws InvalidInput naming the field and its valid range
void validateChain(const ChainParameters& chain, int max_particles, const std::string& prefix);

}  // namespace constrained_particles
