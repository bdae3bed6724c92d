/// @file health.cpp
/// @brief The conditions of the node's health, in one table.
#include "constrained_particles/ros/health.hpp"

#include <diagnostic_msgs/DiagnosticStatus.h>

#include <algorithm>

namespace constrained_particles
{
namespace
{
using diagnostic_msgs::DiagnosticStatus;

// One condition: its level, whether it is the snapshot's own status (statusText), whether a
// fault hides it (its figures are of the steps the fault undid), when it holds and its words.
struct Condition
{
  std::uint8_t level;
  bool status;
  bool unless_faulted;
  bool (*holds)(const HealthInputs&);
  std::string (*words)(const HealthInputs&);
};

const Condition CONDITIONS[] = {
  { DiagnosticStatus::ERROR, true, false, [](const HealthInputs& h) { return h.snap.faulted; },
    [](const HealthInputs& h) { return h.snap.fault_reason; } },
  { DiagnosticStatus::OK, true, true, [](const HealthInputs& h) { return h.snap.stepping; },
    [](const HealthInputs&) { return std::string("paused, running a ~step"); } },
  { DiagnosticStatus::OK, true, true,
    [](const HealthInputs& h) { return h.snap.paused && !h.snap.stepping; },
    [](const HealthInputs&) { return std::string("paused"); } },
  { DiagnosticStatus::WARN, true, true,
    [](const HealthInputs& h) { return h.snap.behind && !h.snap.paused; },
    [](const HealthInputs&)
    { return std::string("behind: cannot keep up with the real-time factor; sim time slowed"); } },
  { DiagnosticStatus::WARN, false, true,
    [](const HealthInputs& h) { return h.statistics.solve.singular_count > 0; },
    [](const HealthInputs& h)
    {
      return std::to_string(h.statistics.solve.singular_count) +
             " singular solves (regularised) in the last second";
    } },
  { DiagnosticStatus::WARN, false, true,
    [](const HealthInputs& h) { return !h.statistics.projection.converged; },
    [](const HealthInputs&)
    { return std::string("a projection did not converge within its iteration limit"); } },
  { DiagnosticStatus::WARN, false, true,
    [](const HealthInputs& h) { return h.statistics.unconverged_friction > 0; },
    [](const HealthInputs& h)
    {
      // a friction solve that stopped short (stalled, or at its limit) took its last iterate
      return std::to_string(h.statistics.unconverged_friction) +
             " friction solves stopped short of a fixed point (stalled, or at their limit) in "
             "the last second, their last iterate taken";
    } },
  { DiagnosticStatus::WARN, false, true,
    [](const HealthInputs& h) { return !h.snap.energy_fallback.empty(); },
    [](const HealthInputs& h) { return h.snap.energy_fallback; } },
  { DiagnosticStatus::WARN, false, true, [](const HealthInputs& h) { return h.wrench_drops > 0; },
    [](const HealthInputs& h)
    {
      return std::to_string(h.wrench_drops) + " ~wrench_command messages dropped in the last " +
             "second" +
             (h.wrench_drop_reason.empty() ? " (made for a scene since replaced)"
                                           : "; last: " + h.wrench_drop_reason);
    } },
  { DiagnosticStatus::WARN, false, false, [](const HealthInputs& h) { return h.waiting_for_clock; },
    [](const HealthInputs& h) { return std::string(h.wait_message); } },
  { DiagnosticStatus::WARN, false, false, [](const HealthInputs& h) { return h.holders_warn; },
    [](const HealthInputs& h) { return h.holder_warning; } },  // each says what the particle does
};

std::string join(const HealthInputs& inputs, bool status_only, std::uint8_t* level)
{
  std::string text;
  for (const Condition& c : CONDITIONS)
  {
    if ((status_only && !c.status) || (c.unless_faulted && inputs.snap.faulted) || !c.holds(inputs))
      continue;
    text += (text.empty() ? "" : "; ") + c.words(inputs);
    if (level)
      *level = std::max(*level, c.level);
  }
  return text;
}
}  // namespace

Health assess(const HealthInputs& inputs)
{
  Health health;
  health.level = DiagnosticStatus::OK;
  health.message = join(inputs, false, &health.level);
  const bool status = !statusText(inputs.snap).empty();
  if (!status)  // running as asked: say so first
  {
    const std::string running =
        inputs.waiting_for_clock && inputs.follow_clock ? "waiting for /clock" : "running";
    health.message = health.message.empty() ? running : running + "; " + health.message;
  }
  return health;
}

std::string statusText(const Snapshot& snap)
{
  const StepStatistics none;
  return join(HealthInputs{ snap, none }, true, nullptr);
}

}  // namespace constrained_particles
