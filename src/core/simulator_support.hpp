/// @file simulator_support.hpp
/// @brief What the Simulator's step (simulator.cpp) and its scene changes (scene_changes.cpp)
/// share: the ledger's powers and scale, forgetting the step control, resting the holders'
/// tracks, projecting a state. Private to the core.
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"

#include <string>

namespace constrained_particles
{
/// The power [W] the applied forces put in (`in`), the dissipative ones take out (`dissipated`,
/// >= 0) and the contacts' friction takes out (`friction`, >= 0: against the slip, relative to a
/// moving obstacle) at state `x`; a moving obstacle's work through its contacts is in `in`.
void ledgerPowers(const Model& model, const Data& data, const State& x, double& in,
                  double& dissipated, double& friction);

/// energyScale() at the current state with the forces acting now, the model's and the
/// perturbations' [J].
double ledgerScale(const Model& model, const Data& data);

/// Forgets what the checks learnt of the previous state (reset, teleport, new scene).
void forgetControl(Data& data);

/// Every tracked record (a frame anchor) at rest where its particle is in `positions`, no knot.
void restartTracks(const Model& model, Data& data, const Points& positions);

/// Each carried shape of `to_model` that `from_model` carries too (the same name on the same
/// holder, sameCarrier) takes the old one's track (`rest` false: its motion goes on) or rests where
/// the old one is at the old state's time (`rest` true: a new scene's run).
void carryCarriers(const Model& from_model, const Data& from, const Model& to_model, Data& to,
                   bool rest);

/// Projects `state` (positions, then velocities) onto `model`'s constraints at its time.
/// @throws InvalidInput naming `field`, saying `what` failed; `state` is then half projected
ProjectionReport projectState(const Model& model, Data& data, const StepSettings& settings,
                              State& state, const std::string& field, const std::string& what);

}  // namespace constrained_particles
