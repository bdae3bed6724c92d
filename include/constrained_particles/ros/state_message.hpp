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
/// The whole ~state of `snap` (`statistics`: the steps' since the last message): the particles'
/// arrays, steps and status by hand, every other field from the tables (figures, counts, flags,
/// words, and the rows of holders, holds let go and contacts). The header is the caller's.
void fillState(const Snapshot& snap, const StepStatistics& statistics, SimState& msg);
/// Every scalar of the tables as /diagnostics entries (words, counts, flags and figures).
void addSnapshotKeys(const Snapshot& snap, const AddKeyValue& add);
/// The step statistics since the last ~state message into their SimState fields (counts,
/// solve and projection figures, retakes by check, effect evaluations).
void fillStatistics(const StepStatistics& statistics, SimState& msg);
/// The same statistics as /diagnostics entries.
void addStatistics(const StepStatistics& statistics, const AddKeyValue& add);

}  // namespace constrained_particles
