/// @file scene_session.hpp
/// @brief The scene a node runs and the step settings its user chose over every scene's own:
/// what ~reset, ~set_surface, ~set_chain and a gravity or damping reconfigure start from. Scene
/// requests are checked here, whole (their fields, the scene file, the particle limit, the scene's
/// own build), before anything changes, and hands the runner a candidate to apply; the runner makes
/// it current only once the simulator took it. Needs no ROS master.
#pragma once

#include "constrained_particles/ros/parameters.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace constrained_particles
{
/// One session of scenes on one node.
class SceneSession
{
public:
  /// A scene ready to run, not yet current: its description, the settings it runs under and
  /// its compiled form.
  struct Candidate
  {
    SceneDescription description;
    StepSettings settings;
    BuiltScene built;
  };

  /// Starts with `scene` (start-up overrides already in it; adopt it once the simulator took
  /// initial()) and the step settings the user gave (parameters.step, parameters.step_given).
  /// @throws InvalidInput naming `~scenario` if `scene` has over parameters.max_particles
  SceneSession(const NodeParameters& parameters, const SceneDescription& scene);

  /// The first scene, built, under settingsFor(it).
  Candidate initial() const;
  /// ~reset: the current scene under `current` settings (`scenario` empty), else the scene file
  /// `scenario` (a name in ~scene_directory or a path) under its own settings, the user's over
  /// them.
  /// @throws InvalidInput naming `scenario` or the file's field; nothing changes
  Candidate forReset(const std::string& scenario, const StepSettings& current) const;
  /// ~set_surface: the current scene with its first surface of `type` (surface.hpp's names) made
  /// from `coefficients`, or for type 'expression' from the formula `expression`, under
  /// `current` settings.
  /// @throws InvalidInput naming `type`, `coefficients` or `expression` and the valid values, or
  /// the scene's own refusal (no surface); nothing changes
  Candidate forSurface(const std::string& type, const std::vector<double>& coefficients,
                       const std::string& expression, const StepSettings& current) const;
  /// ~set_obstacle: the current scene with obstacle `name` changed (changeObstacle), built
  /// without refusing a start inside it (the change meets the running state), under `current`.
  /// @throws InvalidInput naming `operation`, `name` or `shape` (its key); nothing changes
  Candidate forObstacle(ObstacleChange change, const std::string& name, const std::string& shape,
                        const StepSettings& current) const;
  /// ~set_chain: every chain of the current scene changed by `change`, under `current` settings.
  /// @throws InvalidInput naming `num_particles`, `link_length` or `particle_mass` and its range
  /// (limits.hpp, and ~max_particles for the count), or the scene's own refusal (no chain);
  /// nothing changes
  Candidate forChain(const ChainChange& change, const StepSettings& current) const;
  /// The current scene changed by `edit` (which throws InvalidInput to refuse), under `current`.
  /// @throws InvalidInput; nothing changes
  Candidate forChange(const std::function<void(SceneDescription&)>& edit,
                      const StepSettings& current) const;
  /// The current scene with `gravity` [m/s^2] and `damping` [1/s] in place of its own, or none
  /// if both are already the scene's.
  std::optional<SceneDescription> withGravityAndDamping(const Vec3& gravity, double damping) const;

  /// Makes `description` current, with its region of interest from `initial_state`; one more
  /// serial (frames and markers are published again).
  void adopt(const SceneDescription& description, const State& initial_state);
  /// Makes `description` (the current scene changed in place: other forces, another surface)
  /// current; the region stays.
  void adoptChange(const SceneDescription& description);
  /// A reconfigure moved the step settings from `before` to `after`: each field it changed is
  /// the user's choice from now on, for every scene.
  void chooseStep(const StepSettings& before, const StepSettings& after);

  /// The defaults, then `scene`'s `solver` section, then the step settings the user chose.
  StepSettings settingsFor(const SceneDescription& scene) const;
  /// The current scene (never null).
  const std::shared_ptr<const SceneDescription>& scene() const
  {
    return scene_;
  }
  /// One more per scene adopted (Snapshot::scene_serial): 1 for the first.
  std::uint64_t serial() const
  {
    return serial_;
  }
  /// sceneRegion of the current scene at its start.
  const RegionSpec& region() const
  {
    return region_;
  }

private:
  /// @throws InvalidInput naming `field` if `description` is over ~max_particles
  void requireAtMost(const SceneDescription& description, const std::string& field) const;
  Candidate build(const SceneDescription& description, const StepSettings& settings,
                  bool refuse_start_inside = true) const;

  int max_particles_;
  std::string scene_directory_;
  SceneInputs inputs_;      // the robot description scenes' robot_links read
  SolverSpec chosen_step_;  // the user's step settings: over every scene's own
  std::shared_ptr<const SceneDescription> scene_;
  std::uint64_t serial_ = 0;  // none adopted yet
  RegionSpec region_;
};

}  // namespace constrained_particles
