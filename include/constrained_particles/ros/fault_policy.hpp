/// @file fault_policy.hpp
/// @brief When a chunk of steps is a fault, and how the node says so: the step checks' wording,
/// the state's own checks, the energy budget's fallback. Pure functions: no thread, no ROS.
#pragma once

#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/ros/parameters.hpp"

#include <string>

namespace constrained_particles
{
/// Why `state`, reached by a chunk of steps with `chunk` statistics from `last_good`, is a fault,
/// or '' if it is not: a step check the finest split failed (worded with the settings that
/// matter), a non-finite state, or a constraint error over ~max_constraint_error (the chunk's
/// own measure where its projection took one, else `simulator`'s diagnostics). A hold over its
/// limit (StepCheck::HoldForce) is not a fault: the caller lets go of it first.
std::string faultOf(const Simulator& simulator, const NodeParameters& parameters,
                    const State& state, const StepStatistics& chunk, const State& last_good);

/// What the energy budget's fallback says while it has the run ('' while it has not).
std::string energyFallbackText(const Simulator& simulator, const NodeParameters& parameters);

/// `reason` with what acted from outside when it faulted (a push the scene cannot follow faults
/// it as an unstable method would) and where stepping stopped.
std::string faultMessage(const std::string& reason, std::size_t applied, std::size_t dragged,
                         std::size_t commanded, double good_time);

}  // namespace constrained_particles
