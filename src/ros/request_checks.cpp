/// @file request_checks.cpp
/// @brief The checks of ~set_state and ~step.
#include "constrained_particles/ros/request_checks.hpp"

#include <string>

namespace constrained_particles
{
State checkedTeleport(const State& current, int num_particles, const Points& positions,
                      const Points& velocities)
{
  const int n = num_particles;
  if (positions.cols() != n)
    throw InvalidInput("positions", "has " + std::to_string(positions.cols()) +
                                        " entries, must have one per particle (" +
                                        std::to_string(n) + ")");
  if (velocities.size() != 0 && velocities.cols() != n)
    throw InvalidInput("velocities", "has " + std::to_string(velocities.cols()) +
                                         " entries, must be empty (at rest) or one per particle (" +
                                         std::to_string(n) + ")");
  State state = current;
  state.positions = positions;
  state.velocities = velocities.size() == 0 ? Points(Points::Zero(3, n)) : velocities;
  for (int i = 0; i < n; ++i)
  {
    requireInRange("positions[" + std::to_string(i) + "]", Vec3(state.positions.col(i)),
                   limits::COORDINATE);
    requireInRange("velocities[" + std::to_string(i) + "]", Vec3(state.velocities.col(i)),
                   limits::VELOCITY);
  }
  return state;
}

void checkSteps(std::uint64_t steps)
{
  if (!limits::STEPS_PER_CALL.contains(static_cast<double>(steps)))
    throw InvalidInput(
        "steps", "= " + std::to_string(steps) + ", must be in " + limits::STEPS_PER_CALL.text());
}

}  // namespace constrained_particles
