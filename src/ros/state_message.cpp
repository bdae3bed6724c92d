#include "constrained_particles/ros/state_message.hpp"

#include "constrained_particles/ros/conversions.hpp"
#include "constrained_particles/ros/health.hpp"

#include "constrained_particles/core/rope_readings.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace constrained_particles
{
namespace
{
// A figure ~state and /diagnostics both carry: its SimState field, its /diagnostics key (with
// the unit) and where it comes from. Adding a figure is one row here and one in SimState.msg.
template <typename Source>
struct RealField
{
  double SimState::*member;
  const char* key;
  double (*value)(const Source&);
};
struct CountField
{
  std::uint32_t SimState::*member;
  const char* key;
  long (*value)(const StepStatistics&);
};

const RealField<Snapshot> SNAPSHOT_FIELDS[] = {
  { &SimState::sim_time, "sim_time [s]", [](const Snapshot& s) { return s.state.time; } },
  { &SimState::max_position_error, "max_position_error [m]",
    [](const Snapshot& s) { return s.diagnostics.max_position_error; } },
  { &SimState::max_velocity_error, "max_velocity_error [m/s]",
    [](const Snapshot& s) { return s.diagnostics.max_velocity_error; } },
  { &SimState::kinetic_energy, "kinetic_energy [J]",
    [](const Snapshot& s) { return s.diagnostics.kinetic_energy; } },
  { &SimState::potential_energy, "potential_energy [J]",
    [](const Snapshot& s) { return s.diagnostics.potential_energy; } },
  { &SimState::total_energy, "total_energy [J]",
    [](const Snapshot& s) { return s.diagnostics.totalEnergy(); } },
  { &SimState::energy_t0, "energy ledger since t [s]",
    [](const Snapshot& s) { return s.ledger.t0; } },
  { &SimState::energy_scale, "energy scale [J]", [](const Snapshot& s) { return s.ledger.scale; } },
  { &SimState::energy_work_in, "energy work in [J]",
    [](const Snapshot& s) { return s.ledger.work_in; } },
  { &SimState::energy_dissipated, "energy dissipated [J]",
    [](const Snapshot& s) { return s.ledger.dissipated; } },
  { &SimState::energy_residual, "energy residual [J]",
    [](const Snapshot& s) { return s.ledger.residual(); } },
  { &SimState::step_time, "step_time [s]", [](const Snapshot& s) { return s.step_time; } },
  { &SimState::real_time_factor, "real_time_factor achieved",
    [](const Snapshot& s) { return s.real_time_factor; } },
  { &SimState::anchor_lag, "latency behind the clock [s] (holders' poses arrive first)",
    [](const Snapshot& s) { return s.latency; } },
  { &SimState::accuracy_window_end, "accuracy window end [s]",
    [](const Snapshot& s)
    { return s.accuracy ? s.accuracy->window_start + s.accuracy->window : 0.0; } },
  { &SimState::accuracy_position_error, "accuracy position error [m]",
    [](const Snapshot& s) { return s.accuracy ? s.accuracy->position_error : 0.0; } },
  { &SimState::accuracy_error_growth_rate, "accuracy error growth rate [m/s]",
    [](const Snapshot& s) { return s.accuracy ? s.accuracy->error_growth_rate : 0.0; } },
};

// The snapshot's counts, flags and words (what acts from outside, how it runs), each a SimState
// field and a /diagnostics key.
struct SnapshotCount
{
  std::uint32_t SimState::*member;
  const char* key;
  std::uint64_t (*value)(const Snapshot&);
};
const SnapshotCount SNAPSHOT_COUNTS[] = {
  { &SimState::applied_forces, "applied forces acting",
    [](const Snapshot& s) -> std::uint64_t { return s.applied_forces; } },
  { &SimState::dragged_particles, "dragged particles",
    [](const Snapshot& s) -> std::uint64_t { return s.dragged_particles; } },
  { &SimState::commanded_particles, "particles pushed by ~wrench_command",
    [](const Snapshot& s) -> std::uint64_t { return s.commanded_particles; } },
  { &SimState::accuracy_skipped_windows, "accuracy windows skipped",
    [](const Snapshot& s) -> std::uint64_t { return s.skipped_windows; } },
};
struct SnapshotFlag
{
  std::uint8_t SimState::*member;
  const char* key;
  bool (*value)(const Snapshot&);
};
const SnapshotFlag SNAPSHOT_FLAGS[] = {
  { &SimState::energy_fallback, "energy budget's fallback on",
    [](const Snapshot& s) { return !s.energy_fallback.empty(); } },
  { &SimState::behind, "behind the wanted real-time factor",
    [](const Snapshot& s) { return s.behind; } },
};
// (a key of null: the field is in another row's value on /diagnostics)
struct SnapshotText
{
  std::string SimState::*member;
  const char* key;
  std::string (*value)(const Snapshot&);
  std::string (*diagnostic)(const Snapshot&);  // its /diagnostics value, if not `value`'s
};
const SnapshotText SNAPSHOT_TEXTS[] = {
  { &SimState::scenario, "scenario", [](const Snapshot& s) { return s.scene->name; }, nullptr },
  { &SimState::forward_path, "forward path",
    [](const Snapshot& s) { return std::string(forwardPathName(s.forward_path.path)); },
    [](const Snapshot& s)
    { return std::string(forwardPathName(s.forward_path.path)) + ": " + s.forward_path.reason; } },
  { &SimState::forward_path_reason, nullptr,
    [](const Snapshot& s) { return s.forward_path.reason; }, nullptr },
};

// ~state's arrays of holders, holds let go and contacts: rows of the table too, each filling its
// arrays together (one entry per held particle, per hold let go, per touching contact)
void fillHolders(const Snapshot& snap, SimState& msg)
{
  const Model& model = *snap.model;
  for (std::size_t k = 0; k < model.tracked().size(); ++k)
    if (const auto* anchor =
            std::get_if<FrameAnchorConstraint>(&model.scene().constraints[model.tracked()[k]]))
    {
      msg.held_particles.push_back(anchor->particle);
      msg.holders.push_back(holderOf(*anchor));
      const bool counted = k < snap.holders.size();
      msg.holder_overruns.push_back(counted ? static_cast<std::uint32_t>(snap.holders[k].overruns)
                                            : 0u);
      msg.holder_teleports.push_back(counted ? static_cast<std::uint32_t>(snap.holders[k].jumps)
                                             : 0u);
    }
  // the carried shapes' holders come after the anchors' in the snapshot's holder statuses
  for (std::size_t c = 0; c < model.carriers().size(); ++c)
  {
    const Shape& shape = model.carriers()[c];
    const std::size_t k = model.tracked().size() + c;
    const bool counted = k < snap.holders.size();
    msg.carried_obstacles.push_back(shape.name);
    msg.obstacle_holders.push_back(holderOf(shape));
    msg.obstacle_overruns.push_back(counted ? static_cast<std::uint32_t>(snap.holders[k].overruns)
                                            : 0u);
    msg.obstacle_teleports.push_back(counted ? static_cast<std::uint32_t>(snap.holders[k].jumps)
                                             : 0u);
  }
}

void fillReleases(const Snapshot& snap, SimState& msg)
{
  for (const Release& release : snap.releases)
  {
    msg.released_particles.push_back(release.particle);
    msg.released_holders.push_back(release.holder);
    msg.released_times.push_back(release.time);
    msg.released_max_forces.push_back(release.max_force);
  }
}

void fillContacts(const Snapshot& snap, SimState& msg)
{
  const auto& contacts = snap.model->unilateral();
  const std::size_t count = static_cast<std::size_t>(snap.model->numParticleContacts());
  for (std::size_t k = 0; k < count && k < snap.contacts.size(); ++k)
    if (const ContactState& contact = snap.contacts[k]; contact.mode != ContactMode::Separated &&
                                                        std::isfinite(contact.normal_force) &&
                                                        contact.friction_force.allFinite())
    {
      msg.contact_particles.push_back(contacts[k].particles[0]);
      msg.contact_modes.push_back(contact.mode == ContactMode::Sticking
                                      ? SimState::CONTACT_STICKING
                                      : SimState::CONTACT_SLIDING);
      msg.contact_normal_forces.push_back(contact.normal_force);
      geometry_msgs::Vector3 friction;
      tf2::toMsg(contact.friction_force, friction);  // tf2_eigen converts it
      msg.contact_friction_forces.push_back(friction);
    }
  // the rows of two or four particles touching: where along their links, from the positions
  // and the obstacles' poses published
  const EffectContext context{ snap.model->scene().surfaces, snap.state.time, nullptr,
                               &snap.carriers };
  for (std::size_t k = count; k < contacts.size() && k < snap.contacts.size(); ++k)
  {
    const ContactState& contact = snap.contacts[k];
    if (contact.mode == ContactMode::Separated || !std::isfinite(contact.normal_force))
      continue;
    if (contacts[k].kind == UnilateralKind::SegmentContact)
    {
      const SegmentContact& segment = unilateralRecord<SegmentContact>(*snap.model, contacts[k]);
      msg.segment_contact_first.push_back(segment.first);
      msg.segment_contact_second.push_back(segment.second);
      msg.segment_contact_fractions.push_back(
          nearestPoint(segment, context, snap.state.positions).fraction);
      msg.segment_contact_normal_forces.push_back(contact.normal_force);
    }
    else if (contacts[k].kind == UnilateralKind::LinkPairContact)
    {
      const LinkPairContact& pair = unilateralRecord<LinkPairContact>(*snap.model, contacts[k]);
      const LinkPairFrame frame = linkPairGeometry(pair, snap.state.positions);
      for (const int particle : { pair.first_a, pair.second_a, pair.first_b, pair.second_b })
        msg.link_pair_particles.push_back(particle);
      msg.link_pair_fractions.push_back(frame.s);
      msg.link_pair_fractions.push_back(frame.t);
      msg.link_pair_normal_forces.push_back(contact.normal_force);
    }
  }
}

// each link's tension (with the multipliers) and each bend's moment (the positions alone),
// finite ones only (rope_readings.hpp)
void fillRope(const Snapshot& snap, SimState& msg)
{
  if (snap.state.positions.cols() != snap.model->numParticles())
    return;
  if (snap.multipliers.size() >= snap.model->numRows())
    for (const LinkTension& link :
         linkTensions(*snap.model, snap.state.positions, snap.multipliers))
      if (std::isfinite(link.tension))
      {
        msg.link_first.push_back(link.first);
        msg.link_second.push_back(link.second);
        msg.link_tensions.push_back(link.tension);
      }
  for (const JointMoment& joint : bendingMoments(*snap.model, snap.state.positions))
    if (std::isfinite(joint.moment))
    {
      msg.bend_particles.push_back(joint.particle);
      msg.bending_moments.push_back(joint.moment);
    }
}

void (*const ARRAY_ROWS[])(const Snapshot&, SimState&) = { fillHolders, fillReleases, fillContacts,
                                                           fillRope };

const CountField COUNT_FIELDS[] = {
  { &SimState::interval_steps, "steps in the last second",
    [](const StepStatistics& s) -> long { return s.steps; } },
  { &SimState::factorizations, "factorizations",
    [](const StepStatistics& s) -> long { return s.solve.factorizations; } },
  { &SimState::reused_factorizations, "reused factorizations",
    [](const StepStatistics& s) -> long { return s.solve.reused_factorizations; } },
  { &SimState::singular_solves, "singular solves",
    [](const StepStatistics& s) -> long { return s.solve.singular_count; } },
  { &SimState::solve_fallbacks, "solve fallbacks",
    [](const StepStatistics& s) -> long { return s.solve.fallbacks; } },
  { &SimState::projections, "projections",
    [](const StepStatistics& s) -> long { return s.projection.projections; } },
  { &SimState::projection_iterations, "projection iterations",
    [](const StepStatistics& s) -> long { return s.projection.iterations; } },
  { &SimState::max_projection_iterations, "most projection iterations",
    [](const StepStatistics& s) -> long { return s.projection.max_iterations; } },
  { &SimState::internal_steps, "internal steps",
    [](const StepStatistics& s) -> long { return s.internal_steps; } },
  { &SimState::rejected_internal_steps, "rejected internal steps",
    [](const StepStatistics& s) -> long { return s.rejected_internal_steps; } },
  { &SimState::forced_internal_steps, "forced internal steps",
    [](const StepStatistics& s) -> long { return s.forced_internal_steps; } },
  { &SimState::substeps, "sub-steps", [](const StepStatistics& s) -> long { return s.substeps; } },
  { &SimState::max_substeps_per_step, "most sub-steps per step",
    [](const StepStatistics& s) -> long { return s.max_substeps; } },
  { &SimState::rejected_steps, "steps retaken",
    [](const StepStatistics& s) -> long { return s.rejected_steps; } },
  { &SimState::stiff_steps, "steps taken by fast_projection (stiff fallback)",
    [](const StepStatistics& s) -> long { return s.stiff_steps; } },
  { &SimState::unconverged_friction, "friction fixed points unconverged",
    [](const StepStatistics& s) -> long { return s.unconverged_friction; } },
};

const RealField<StepStatistics> STATISTICS_FIELDS[] = {
  { &SimState::min_pivot_ratio, "min pivot ratio",
    [](const StepStatistics& s) { return s.solve.min_pivot_ratio; } },
  // an estimate overflows only in degenerate geometry: shown as the largest double, not inf
  { &SimState::max_frequency, "max_frequency estimate [rad/s]",
    [](const StepStatistics& s) {
      return std::isfinite(s.max_frequency) ? s.max_frequency : std::numeric_limits<double>::max();
    } },
};

// A count as SimState carries it (uint32: saturated rather than wrapped).
std::uint32_t toCount(long value)
{
  return static_cast<std::uint32_t>(
      std::clamp<long>(value, 0, std::numeric_limits<std::uint32_t>::max()));
}
}  // namespace

void fillSnapshotFields(const Snapshot& snap, SimState& msg)
{
  for (const auto& field : SNAPSHOT_FIELDS)
    msg.*field.member = field.value(snap);
}

void addSnapshotFields(const Snapshot& snap, const AddKeyValue& add)
{
  for (const auto& field : SNAPSHOT_FIELDS)
    add(field.key, formatValue(field.value(snap)));
}

void fillState(const Snapshot& snap, const StepStatistics& statistics, SimState& msg)
{
  // the state itself, by hand: its arrays are the particles'
  msg.positions = toPointMsgs(snap.state.positions);
  msg.velocities = toVectorMsgs(snap.state.velocities);
  msg.constraint_forces = toVectorMsgs(snap.constraint_forces);
  msg.multipliers.assign(snap.multipliers.data(),
                         snap.multipliers.data() + snap.multipliers.size());
  msg.steps = snap.state.steps;
  msg.status = snap.faulted  ? SimState::STATUS_FAULT
               : snap.paused ? SimState::STATUS_PAUSED
                             : SimState::STATUS_RUNNING;
  msg.status_message = statusText(snap);
  // everything else from the tables
  fillSnapshotFields(snap, msg);
  for (const SnapshotCount& field : SNAPSHOT_COUNTS)
    msg.*field.member = toCount(static_cast<long>(field.value(snap)));
  for (const SnapshotFlag& field : SNAPSHOT_FLAGS)
    msg.*field.member = field.value(snap);
  for (const SnapshotText& field : SNAPSHOT_TEXTS)
    msg.*field.member = field.value(snap);
  for (const auto row : ARRAY_ROWS)
    row(snap, msg);
  fillStatistics(statistics, msg);
}

void addSnapshotKeys(const Snapshot& snap, const AddKeyValue& add)
{
  for (const SnapshotText& field : SNAPSHOT_TEXTS)
    if (field.key)
      add(field.key, field.diagnostic ? field.diagnostic(snap) : field.value(snap));
  add("particles", std::to_string(snap.model->numParticles()));
  add("steps", std::to_string(snap.state.steps));
  addSnapshotFields(snap, add);
  for (const SnapshotCount& field : SNAPSHOT_COUNTS)
    add(field.key, std::to_string(field.value(snap)));
  for (const SnapshotFlag& field : SNAPSHOT_FLAGS)
    add(field.key, field.value(snap) ? "yes" : "no");
}

void fillStatistics(const StepStatistics& statistics, SimState& msg)
{
  for (const CountField& field : COUNT_FIELDS)
    msg.*field.member = toCount(field.value(statistics));
  for (const auto& field : STATISTICS_FIELDS)
    msg.*field.member = field.value(statistics);
  msg.projections_converged = statistics.projection.converged;
  for (int k = 0; k < NUM_STEP_CHECKS; ++k)
    if (statistics.rejections[k] > 0)
    {
      msg.rejection_checks.push_back(stepCheckName(static_cast<StepCheck>(k)));
      msg.rejection_counts.push_back(toCount(statistics.rejections[k]));
    }
  forEachEffectCount(statistics.effects,
                     [&msg](const char* name, std::uint64_t count)
                     {
                       msg.effect_names.push_back(name);
                       msg.effect_counts.push_back(count);
                     });
}

void addStatistics(const StepStatistics& statistics, const AddKeyValue& add)
{
  for (const CountField& field : COUNT_FIELDS)
    add(field.key, std::to_string(field.value(statistics)));
  for (const auto& field : STATISTICS_FIELDS)
    add(field.key, formatValue(field.value(statistics)));
  add("projections converged", statistics.projection.converged ? "yes" : "no");
  std::string rejections;
  for (int k = 0; k < NUM_STEP_CHECKS; ++k)
    if (statistics.rejections[k] > 0)
      rejections += (rejections.empty() ? "" : " ") +
                    std::string(stepCheckName(static_cast<StepCheck>(k))) + ":" +
                    std::to_string(statistics.rejections[k]);
  add("steps retaken, by check", rejections.empty() ? "-" : rejections);
  std::string effects;
  forEachEffectCount(statistics.effects,
                     [&effects](const char* name, std::uint64_t count) {
                       effects += (effects.empty() ? "" : " ") + std::string(name) + ":" +
                                  std::to_string(count);
                     });
  add("effect evaluations", effects.empty() ? "-" : effects);
}

}  // namespace constrained_particles
