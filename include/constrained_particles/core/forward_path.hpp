/// @file forward_path.hpp
/// @brief The one place that decides which stage path a step takes (docs/architecture.md,
/// "Which path a scene takes").
#pragma once

#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"

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

/// forwardPath() with its reason, for the start-up log, ~state and /diagnostics.
inline PathChoice choosePath(const Model& model, const StepSettings& settings)
{
  if (forwardPath(model, settings) == model.path().path)
    return model.path();
  return { ForwardPath::Generic,
           "stabilization = baumgarte: its bias needs the generic rows' "
           "J v and C (else " +
               std::string(forwardPathName(model.path().path)) + ": " + model.path().reason + ")" };
}

}  // namespace constrained_particles
