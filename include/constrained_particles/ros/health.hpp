/// @file health.hpp
/// @brief The node's health in one list of conditions (level and words each): the /diagnostics
/// level and message, ~state.status_message and the status line all read it.
#pragma once

#include "constrained_particles/ros/simulation_runner.hpp"

#include <cstdint>
#include <string>

namespace constrained_particles
{
/// What the health is judged on: the snapshot, the steps' statistics since the last report, and
/// what the node's adapters saw (the clock, dropped commands, holders).
struct HealthInputs
{
  const Snapshot& snap;
  const StepStatistics& statistics;
  bool waiting_for_clock = false;  ///< /use_sim_time and no /clock yet
  const char* wait_message = "";   ///< why nothing goes out then
  bool follow_clock = false;       ///< ~follow_clock: "waiting for /clock" while it waits
  std::uint64_t wrench_drops = 0;  ///< ~wrench_command messages dropped in the last second
  std::string wrench_drop_reason;  ///< the last one's
  bool holders_warn = false;       ///< a holder not followed, or samples dropped (FrameAnchors)
  std::string holder_warning;      ///< which and why
};

/// The /diagnostics level (diagnostic_msgs::DiagnosticStatus OK, WARN or ERROR) and message.
struct Health
{
  std::uint8_t level = 0;
  std::string message;
};

/// Every condition that holds, worst level first wins the level; their words joined with "; ".
Health assess(const HealthInputs& inputs);

/// The status in words from the snapshot alone (the same list's first rows): the fault's reason,
/// "paused, running a ~step", "paused", "behind: ...", or empty while running as asked.
std::string statusText(const Snapshot& snap);

}  // namespace constrained_particles
