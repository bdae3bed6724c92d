/// @file parameters.hpp
/// @brief simulator_node's private parameters: defaults, reading and validation.
#pragma once

#include "constrained_particles/core/dynamics.hpp"
#include "constrained_particles/core/scenarios.hpp"

#include <ros/node_handle.h>

#include <string>

namespace constrained_particles
{
/// Everything config/default.yaml holds; defaults match it.
struct NodeParameters
{
  std::string scenario = "chain";          ///< bead | chain | surface_chain
  StepSettings step;                       ///< dt [s], integrator, stabilisation
  double real_time_factor = 1.0;           ///< sim seconds per wall second, (0, 100]
  double publish_rate = 30.0;              ///< [Hz], [0.1, 1000]
  double status_period = 1.0;              ///< status log period [s], 0 = off
  ScenarioParameters scenario_parameters;  ///< gravity, damping, chain, surface, bead mass
  int max_particles = 100000;              ///< largest chain accepted, [1, MAX_PARTICLES]
  std::string fixed_frame = "world";       ///< parent of every particle frame
  std::string frame_prefix = "particle_";  ///< child frame = prefix + index
  double force_scale = 0.05;               ///< arrow length per newton [m/N], (0, 1e3]
  double max_constraint_error = 0.1;       ///< fault beyond this constraint error [m], (0, 1e3]
};

/// Largest dt the node accepts [s].
constexpr double MAX_NODE_DT = 0.1;

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
