#include "constrained_particles/ros/scene_session.hpp"

#include <algorithm>

namespace constrained_particles
{
SceneSession::SceneSession(const NodeParameters& parameters, const SceneDescription& scene)
  : max_particles_(parameters.max_particles)
  , scene_directory_(parameters.scene_directory)
  , inputs_(sceneInputs(parameters))
{
  chosen_step_.values = parameters.step;
  chosen_step_.given = parameters.step_given;
  requireAtMost(scene, "~scenario");
  scene_ = std::make_shared<const SceneDescription>(scene);
}

SceneSession::Candidate SceneSession::initial() const
{
  return build(*scene_, settingsFor(*scene_));
}

SceneSession::Candidate SceneSession::forReset(const std::string& scenario,
                                               const StepSettings& current) const
{
  if (scenario.empty())
    return build(*scene_, current);
  const SceneDescription description =
      loadSceneFile(resolveScene(scenario, scene_directory_, "scenario"), inputs_);
  return build(description, settingsFor(description));
}

SceneSession::Candidate SceneSession::forChange(const std::function<void(SceneDescription&)>& edit,
                                                const StepSettings& current) const
{
  SceneDescription changed = *scene_;
  edit(changed);
  return build(changed, current);
}

SceneSession::Candidate SceneSession::forSurface(const std::string& type,
                                                 const std::vector<double>& coefficients,
                                                 const std::string& expression,
                                                 const StepSettings& current) const
{
  const SurfaceType kind = parseSurfaceType(type, "type");
  if (kind == SurfaceType::Expression && !coefficients.empty())
    throw InvalidInput("coefficients", "has " + std::to_string(coefficients.size()) +
                                           " values, must be empty for type 'expression'");
  if (kind != SurfaceType::Expression && !expression.empty())
    throw InvalidInput("expression", "is only for type 'expression' (type is '" + type + "')");
  const Surface surface = kind == SurfaceType::Expression
                              ? makeExpressionSurface(expression, "expression")
                              : makeSurface(kind, coefficients, "coefficients");
  return forChange([&surface](SceneDescription& scene) { setFirstSurface(scene, surface); },
                   current);
}

SceneSession::Candidate SceneSession::forObstacle(ObstacleChange change, const std::string& name,
                                                  const std::string& shape,
                                                  const StepSettings& current) const
{
  SceneDescription changed = *scene_;
  changeObstacle(changed, change, name, shape, inputs_.files);
  return build(changed, current, false);
}

SceneSession::Candidate SceneSession::forChain(const ChainChange& change,
                                               const StepSettings& current) const
{
  validateChainChange(change, max_particles_, "");
  return forChange([&change](SceneDescription& scene) { setChains(scene, change); }, current);
}

std::optional<SceneDescription> SceneSession::withGravityAndDamping(const Vec3& gravity,
                                                                    double damping) const
{
  if (gravity == sceneGravity(*scene_) && damping == sceneDamping(*scene_))
    return std::nullopt;
  SceneDescription changed = *scene_;
  setGravityAndDamping(changed, gravity, damping);
  return changed;
}

void SceneSession::adopt(const SceneDescription& description, const State& initial_state)
{
  scene_ = std::make_shared<const SceneDescription>(description);
  region_ = sceneRegion(description, initial_state);
  ++serial_;
}

void SceneSession::adoptChange(const SceneDescription& description)
{
  scene_ = std::make_shared<const SceneDescription>(description);
  ++serial_;
}

void SceneSession::chooseStep(const StepSettings& before, const StepSettings& after)
{
  forEachField<StepSettings>(
      [&](const auto& spec)
      {
        if (after.*(spec.member) != before.*(spec.member) &&
            std::find(chosen_step_.given.begin(), chosen_step_.given.end(), spec.name) ==
                chosen_step_.given.end())
          chosen_step_.given.push_back(spec.name);
      });
  chosen_step_.values = after;
}

StepSettings SceneSession::settingsFor(const SceneDescription& scene) const
{
  // defaults, then the scene's own, then the user's: nothing carries over from the last scene
  return chosen_step_.applyTo(scene.solver.applyTo(StepSettings{}));
}

void SceneSession::requireAtMost(const SceneDescription& description,
                                 const std::string& field) const
{
  if (description.numParticles() > max_particles_)
    throw InvalidInput(field,
                       "gives scene '" + description.name + "' " +
                           std::to_string(description.numParticles()) +
                           " particles, over ~max_particles = " + std::to_string(max_particles_));
}

SceneSession::Candidate SceneSession::build(const SceneDescription& description,
                                            const StepSettings& settings,
                                            bool refuse_start_inside) const
{
  requireAtMost(description, "num_particles");
  return Candidate{ description, settings, buildScene(description, refuse_start_inside) };
}

}  // namespace constrained_particles
