/// @file reconfigure_mapping.hpp
/// @brief dynamic_reconfigure's SimulatorConfig to and from the node's settings, walking the
/// field descriptors (StepSettings::fields(), NodeParameters::fields()): a cfg parameter named
/// like a field maps to it, with no list of fields written here.
#pragma once

#include "constrained_particles/SimulatorConfig.h"
#include "constrained_particles/ros/parameters.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <string>
#include <vector>

namespace constrained_particles
{
/// The configuration showing `parameters` and the scene's gravity and damping (the cfg's
/// gravity_x, _y, _z and damping, which are scene overrides rather than fields).
SimulatorConfig configFrom(const NodeParameters& parameters, const SceneDescription& scene);

/// Puts into `candidate` every field the request changed (`requested` against `shown`, the
/// configuration the server showed; NaN never equals itself, so it is taken, then refused by
/// the runner's validation), names and enums parsed as the parameters parse them, and the
/// gravity and damping overrides. @throws InvalidInput for an unknown integrator or
/// stabilisation name.
void applyChangedFields(const SimulatorConfig& shown, const SimulatorConfig& requested,
                        const SceneDescription& scene, NodeParameters& candidate);

/// The StepSettings and NodeParameters fields the cfg has a parameter for, in descriptor order.
std::vector<std::string> reconfigurableFields();

}  // namespace constrained_particles
