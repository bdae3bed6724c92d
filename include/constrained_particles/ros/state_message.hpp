/// @file state_message.hpp
/// @brief What ~state and /diagnostics both report, written once: the figures of a snapshot and
/// of the step statistics (one table of SimState field, /diagnostics key and value), and the
/// status in words.
#pragma once

#include "constrained_particles/SimState.h"
#include "constrained_particles/core/statistics.hpp"
#include "constrained_particles/ros/simulation_runner.hpp"

#include <functional>
#include <string>

namespace constrained_particles
{
/// Receives one /diagnostics key and its value.
using AddKeyValue = std::function<void(const std::string& key, const std::string& value)>;

/// The snapshot's figures (sim time, errors, energies, the ledger, step time, real-time factor)
/// into their SimState fields.
void fillSnapshotFields(const Snapshot& snap, SimState& msg);
/// The same figures as /diagnostics entries, with their units in the keys.
void addSnapshotFields(const Snapshot& snap, const AddKeyValue& add);
/// The step statistics since the last ~state message into their SimState fields (counts,
/// solve and projection figures, retakes by check, effect evaluations).
void fillStatistics(const StepStatistics& statistics, SimState& msg);
/// The same statistics as /diagnostics entries.
void addStatistics(const StepStatistics& statistics, const AddKeyValue& add);

/// The node's status in words, one wording for ~state.status_message, /diagnostics and the
/// status log line: the fault's reason, "paused, running a ~step", "paused", "behind: ...",
/// or empty while running as asked.
std::string statusText(const Snapshot& snap);

}  // namespace constrained_particles
