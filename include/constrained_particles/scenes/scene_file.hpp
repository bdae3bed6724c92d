/// @file scene_file.hpp
/// @brief Scenes as YAML files: the description a file holds, its loader, and the expansion
/// into a core Scene and initial State. Uses yaml-cpp; no ROS (the core stays Eigen-only).
///
/// The format is documented in README.md ("Scene files") and config/scenes/*.yaml.
#pragma once

#include "constrained_particles/core/dynamics.hpp"
#include "constrained_particles/core/scenarios.hpp"

#include <optional>
#include <string>
#include <vector>

namespace constrained_particles
{
/// Largest scene file read [bytes]: a bigger one is refused before it is read.
constexpr long MAX_SCENE_FILE_BYTES = 1 << 20;

/// One explicitly listed particle.
struct ParticleSpec
{
  double mass = 1.0;             ///< [kg], > 0
  Vec3 position = Vec3::Zero();  ///< initial position [m]
  Vec3 velocity = Vec3::Zero();  ///< initial velocity [m/s]
};

/// A generated chain: `particles` particles joined by links, in a straight line.
struct ChainSpec
{
  int particles = 5;                     ///< n, in [1, MAX_PARTICLES]
  double link_length = 0.5;              ///< l [m], in (0, 1000]
  double particle_mass = 1.0;            ///< [kg], in (0, 1e6]
  Vec3 start = Vec3::Zero();             ///< first particle [m]
  Vec3 direction{ 1.0, 0.0, 0.0 };       ///< along the chain (normalised), non-zero
  Vec3 velocity = Vec3::Zero();          ///< every particle's initial velocity [m/s]
  Vec3 angular_velocity = Vec3::Zero();  ///< initial spin about the chain's centre [rad/s]
  bool pin_first = false;                ///< pin the first particle where it starts
  bool pin_last = false;                 ///< pin the last particle where it starts
  std::string surface;                   ///< if set, the first particle slides on this surface
};

/// A named height field.
struct NamedSurface
{
  std::string name;
  Surface surface;
};

/// Solver settings a scene may set; unset ones keep the caller's.
struct SolverSpec
{
  std::optional<double> dt;                    ///< [s]
  std::optional<Integrator> integrator;        ///< time integrator
  std::optional<Stabilization> stabilization;  ///< drift correction
  SolveMethod solve_method = SolveMethod::Automatic;

  /// `settings` with this scene's choices applied.
  StepSettings applyTo(StepSettings settings) const;
};

/// What a scene file says. Particles are numbered explicit ones first, then each chain's.
struct SceneDescription
{
  std::string name;         ///< from `name`, else the file's stem
  std::string description;  ///< one line for humans
  std::string source;       ///< file it came from, for messages ("" if parsed from text)
  std::vector<NamedSurface> surfaces;
  std::vector<ParticleSpec> particles;
  std::vector<ChainSpec> chains;
  std::vector<Force> forces;
  std::vector<Constraint> constraints;  ///< surface fields index `surfaces`
  std::vector<bool> pin_at_start;       ///< per constraint: a pin whose anchor is its start
  SolverSpec solver;

  /// Total particle count: explicit plus every chain's.
  long numParticles() const;
};

/// Parses a scene from YAML text.
/// @param source file name used in messages
/// @throws InvalidInput whose field is "<source>:<line>: <key path>" and whose reason says what
/// is wrong and what is valid; unknown keys are refused
SceneDescription parseScene(const std::string& yaml, const std::string& source);

/// Reads and parses a scene file. @throws InvalidInput as parseScene, or if it cannot be read or
/// is larger than MAX_SCENE_FILE_BYTES
SceneDescription loadSceneFile(const std::string& path);

/// The scene and initial state a description stands for: chains expanded, particles on surfaces
/// placed at z = Z(x, y) with their velocity lifted into the tangent plane, pins at their starts.
/// @throws InvalidInput naming the bad field
Scenario buildScene(const SceneDescription& description);

/// Names (file stems) of the *.yaml scene files in a directory, sorted.
std::vector<std::string> listScenes(const std::string& directory);

/// The file of a scene: `name_or_path` if it contains '/' or ends in .yaml, else
/// `<directory>/<name>.yaml`. @throws InvalidInput naming `field` if there is no such file
std::string resolveScene(const std::string& name_or_path, const std::string& directory,
                         const std::string& field = "scenario");

/// Applies ~set_chain's change to every chain of the scene (pin_first only to chains not on a
/// surface). @throws InvalidInput if the scene has no chain
void setChains(SceneDescription& description, const ChainParameters& chain);

/// Replaces the scene's first surface. @throws InvalidInput if it has none
void setFirstSurface(SceneDescription& description, const Surface& surface);

/// The gravity [m/s^2] and linear damping [N s/m] the scene's forces hold (0 if absent).
Vec3 sceneGravity(const SceneDescription& description);
double sceneDamping(const SceneDescription& description);

/// Sets the scene's gravity and linear damping, adding, replacing or (for 0) removing those
/// force records and keeping every other force.
void setGravityAndDamping(SceneDescription& description, const Vec3& gravity, double damping);

}  // namespace constrained_particles
