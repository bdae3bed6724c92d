/// @file forward_path.hpp
/// @brief The one place that decides which stage path a step takes (docs/architecture.md,
/// "Which path a scene takes").
#pragma once

#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"

#include <string>

namespace constrained_particles
{
/// The path forward() and the projection take for `model` under `settings`: the model's own
/// (Model::path(), fixed at compile) unless Baumgarte stabilisation is on, whose bias needs the
/// generic rows' J v and C, which the sweeps do not form. Asked per stage: an enum compare.
inline ForwardPath forwardPath(const Model& model, const StepSettings& settings)
{
  return settings.stabilization == Stabilization::Baumgarte ? ForwardPath::Generic
                                                            : model.path().path;
}

/// The path the steps take, with its reason, for the start-up log, ~state and /diagnostics:
/// forwardPath(), but generic for an integrator that holds the constraints itself (velocity
/// Verlet, fast projection: SHAKE/RATTLE or a projection on the generic rows; only the forces
/// reported once per batch, and a contact scene's active set and release checks, take
/// forwardPath()).
inline PathChoice choosePath(const Model& model, const StepSettings& settings)
{
  if (model.path().path == ForwardPath::Generic)
    return model.path();
  const std::string otherwise = " (else " + std::string(forwardPathName(model.path().path)) + ": " +
                                model.path().reason + ")";
  if (findIntegrator(settings.integrator).holds_constraints)
    return { ForwardPath::Generic, "integrator = " + settings.integrator +
                                       " holds the constraints itself, on the generic rows" +
                                       otherwise };
  if (forwardPath(model, settings) == ForwardPath::Generic)
    return { ForwardPath::Generic,
             "stabilization = baumgarte: its bias needs the generic rows' J v and C" + otherwise };
  return model.path();
}

}  // namespace constrained_particles
