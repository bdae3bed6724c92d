/// @file scene_fixtures.hpp
/// @brief The shipped scenes and node parameters that find them, for the ROS layer's gtests
/// (SCENES_DIR is set by CMakeLists.txt to config/scenes).
#pragma once

#include "constrained_particles/ros/parameters.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <string>

namespace constrained_particles
{
namespace fixtures
{
/// The shipped scene `name` (config/scenes/<name>.yaml).
inline SceneDescription scene(const std::string& name)
{
  return loadSceneFile(std::string(SCENES_DIR) + "/" + name + ".yaml");
}

/// Defaults, with ~scenario `scenario` and ~scene_directory config/scenes.
inline NodeParameters parametersFor(const std::string& scenario)
{
  NodeParameters p;
  p.scenario = scenario;
  p.scene_directory = SCENES_DIR;
  return p;
}
}  // namespace fixtures
}  // namespace constrained_particles
