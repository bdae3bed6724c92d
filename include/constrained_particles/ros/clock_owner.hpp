/// @file clock_owner.hpp
/// @brief Who may publish /clock: the master's view of its other publishers (raw XML-RPC, which
/// roscpp has no call for), and the wording for a node waiting for a foreign clock.
#pragma once

#include <chrono>

namespace constrained_particles
{
/// Only one node may publish /clock: throws naming the others that do. Before advertising, any
/// other counts; after (`advertised`), two started at once each see the other, and the one whose
/// name sorts first keeps /clock. A check after advertising may run before the other node has
/// registered (it passed its own check before we registered, then loaded its scene): the node
/// repeats it for CLOCK_CHECK_PERIOD after advertising (SimulatorNode::refusal()).
inline constexpr std::chrono::seconds CLOCK_CHECK_PERIOD{ 60 };  // wall; longer than a scene's load

/// Why nothing is published under /use_sim_time before a /clock, and the two remedies.
inline constexpr const char* CLOCK_WAIT_MESSAGE =
    "/use_sim_time is true and no /clock has arrived: tf, ~state and markers wait for time to "
    "move (their stamps would all be 0); set ~publish_clock: true to let this node publish "
    "/clock, or start the clock's owner (Gazebo, rosbag play --clock)";
/// ~follow_clock before the first /clock: the scene waits, unstepped.
inline constexpr const char* FOLLOW_WAIT_MESSAGE =
    "~follow_clock: no /clock has arrived: the scene waits at its start, unstepped, and nothing "
    "is published until the clock's owner (Gazebo, rosbag play --clock) starts";

/// @throws InvalidInput naming ~publish_clock and the other publishers of /clock (as this node
/// resolves it) that answer; `advertised`: this node already publishes it (see above).
void requireClockFree(bool advertised);

}  // namespace constrained_particles
