/// @file request_checks.hpp
/// @brief The runner's requests' own checks, each naming the field and its valid range (an
/// ~attach's are HolderSession::checkAttach, scene requests SceneSession's, pushes
/// Perturbations'): nothing changes when one throws.
#pragma once

#include "constrained_particles/core/simulator.hpp"

#include <cstdint>

namespace constrained_particles
{
/// ~set_state's teleport of `current` to `positions` and `velocities` (3 x n each; no
/// velocities: at rest), time and steps kept.
/// @throws InvalidInput naming `positions`, `velocities` or one entry ("positions[3].x") and its
/// range: one per particle, each component in limits::COORDINATE or limits::VELOCITY (finite is
/// not enough: a teleport to 1e300 m would overflow on the first step)
State checkedTeleport(const State& current, int num_particles, const Points& positions,
                      const Points& velocities);

/// ~step's count. @throws InvalidInput naming `steps` unless in limits::STEPS_PER_CALL
void checkSteps(std::uint64_t steps);

}  // namespace constrained_particles
