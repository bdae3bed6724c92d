// ~state and /diagnostics from one table (state_message.hpp): every figure reaches its SimState
// field and its /diagnostics key with the same value, each key once, and the status reads the
// same everywhere.
#include "constrained_particles/ros/state_message.hpp"
#include "constrained_particles/ros/health.hpp"
#include "constrained_particles/ros/markers.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <diagnostic_msgs/DiagnosticStatus.h>

#include <gtest/gtest.h>

#include <memory>

#include <limits>
#include <map>
#include <string>

namespace constrained_particles
{
namespace
{
std::map<std::string, std::string> collect(const std::function<void(const AddKeyValue&)>& fill)
{
  std::map<std::string, std::string> entries;
  fill(
      [&entries](const std::string& key, const std::string& value)
      {
        EXPECT_EQ(entries.count(key), 0u) << "key written twice: " << key;
        entries[key] = value;
      });
  return entries;
}

TEST(StateMessage, TheSnapshotsFiguresReachBothFieldAndKey)
{
  Snapshot snap;
  snap.state.time = 1.25;
  snap.diagnostics.max_position_error = 2e-9;
  snap.diagnostics.max_velocity_error = 3e-8;
  snap.diagnostics.kinetic_energy = 4.5;
  snap.diagnostics.potential_energy = -1.5;
  snap.ledger.t0 = 0.5;
  snap.ledger.scale = 7.0;
  snap.ledger.work_in = 0.25;
  snap.ledger.dissipated = 0.125;
  snap.ledger.kinetic = 4.5;
  snap.ledger.potential = -1.5;
  snap.ledger.initial_energy = 3.0;
  snap.step_time = 1e-6;
  snap.real_time_factor = 0.75;
  SimState msg;
  fillSnapshotFields(snap, msg);
  EXPECT_EQ(msg.sim_time, 1.25);
  EXPECT_EQ(msg.max_position_error, 2e-9);
  EXPECT_EQ(msg.max_velocity_error, 3e-8);
  EXPECT_EQ(msg.kinetic_energy, 4.5);
  EXPECT_EQ(msg.potential_energy, -1.5);
  EXPECT_EQ(msg.total_energy, 3.0);
  EXPECT_EQ(msg.energy_t0, 0.5);
  EXPECT_EQ(msg.energy_scale, 7.0);
  EXPECT_EQ(msg.energy_work_in, 0.25);
  EXPECT_EQ(msg.energy_dissipated, 0.125);
  EXPECT_EQ(msg.energy_residual, snap.ledger.residual());
  EXPECT_EQ(msg.step_time, 1e-6);
  EXPECT_EQ(msg.real_time_factor, 0.75);
  const auto entries = collect([&](const AddKeyValue& add) { addSnapshotFields(snap, add); });
  EXPECT_EQ(entries.at("sim_time [s]"), formatValue(1.25));
  EXPECT_EQ(entries.at("total_energy [J]"), formatValue(3.0));
  EXPECT_EQ(entries.at("energy residual [J]"), formatValue(snap.ledger.residual()));
  EXPECT_EQ(entries.at("real_time_factor achieved"), formatValue(0.75));
  EXPECT_EQ(entries.size(), 17u);
}

// A link resting across a post on its capsule (its particles clear of it): ~state lists the link,
// where along it the post touches and the post's push, the link's weight; a capsule clear of its
// obstacle is not listed.
// ~state of `simulator` after its forces are read between steps (as the node reads them)
SimState stateOf(Simulator& simulator, const SceneDescription& description)
{
  Points forces;
  Eigen::VectorXd multipliers;
  simulator.constraintForces(forces, multipliers);
  Snapshot snap;
  snap.model = std::make_shared<const Model>(simulator.model());
  snap.scene = std::make_shared<const SceneDescription>(description);
  snap.state = simulator.state();
  snap.constraint_forces = forces;
  snap.multipliers = multipliers;
  snap.contacts = simulator.data().contacts;
  SimState msg;
  fillState(snap, StepStatistics{}, msg);
  return msg;
}

// A simulator of `description` after 10 steps at the default settings
std::unique_ptr<Simulator> afterTenSteps(const SceneDescription& description)
{
  const BuiltScene built = buildScene(description);
  auto simulator = std::make_unique<Simulator>(built.scene, built.initial_state, StepSettings{});
  simulator->step(10);
  return simulator;
}

TEST(StateMessage, ALinkCapsuleTouchingAnObstacleIsListed)
{
  const SceneDescription description = parseScene(R"(
name: lever
shapes:
  post: {type: cylinder, position: [0.05, 0, 0], rpy: [1.5707963267948966, 0, 0], radius: 0.05,
         length: 0.5}
  far: {type: sphere, position: [0, 0, 5], radius: 0.1}
particles:
  - {mass: 1, position: [-0.1, 0, 0.06]}
  - {mass: 3, position: [0.1, 0, 0.06]}
constraints:
  - {type: link, first: 0, second: 1}
  - {type: segment_contact, first: 0, second: 1, shape: post, radius: 0.01}
  - {type: segment_contact, first: 0, second: 1, shape: far, radius: 0.01}
forces:
  - {type: gravity}
)",
                                                  "lever.yaml");
  const std::unique_ptr<Simulator> simulator = afterTenSteps(description);
  const SimState msg = stateOf(*simulator, description);
  ASSERT_EQ(msg.segment_contact_first.size(), 1u);
  ASSERT_EQ(msg.segment_contact_second.size(), 1u);
  ASSERT_EQ(msg.segment_contact_fractions.size(), 1u);
  ASSERT_EQ(msg.segment_contact_normal_forces.size(), 1u);
  EXPECT_EQ(msg.segment_contact_first[0], 0);
  EXPECT_EQ(msg.segment_contact_second[0], 1);
  // the post's top, x = 0.05, is 3/4 of the way along the link from x = -0.1 to 0.1: the lever
  // balances there, 1 kg and 3 kg
  EXPECT_NEAR(msg.segment_contact_fractions[0], 0.75, 1e-6);
  EXPECT_NEAR(msg.segment_contact_normal_forces[0], 4.0 * 9.81, 1e-6);
  EXPECT_TRUE(msg.contact_particles.empty());  // the particles touch nothing
}

// Two crossing links, the upper (1 kg and 3 kg at its ends) resting on the lower (pinned) across
// it: listed with its four particles, where along each they touch (the upper balances at 3/4 of
// its length, over the lower's middle) and the push, its weight.
TEST(StateMessage, TwoLinksTouchingEachOtherAreListed)
{
  const SceneDescription description = parseScene(R"(
name: crossing
particles:
  - {mass: 1, position: [-0.1, 0, 0.02]}
  - {mass: 3, position: [0.1, 0, 0.02]}
  - {mass: 1, position: [0.05, -0.2, 0]}
  - {mass: 1, position: [0.05, 0.2, 0]}
constraints:
  - {type: link, first: 0, second: 1}
  - {type: pin, particle: 2}
  - {type: pin, particle: 3}
  - {type: link_pair_contact, first_a: 0, second_a: 1, first_b: 2, second_b: 3, radius: 0.01}
forces:
  - {type: gravity}
)",
                                                  "crossing.yaml");
  const std::unique_ptr<Simulator> simulator = afterTenSteps(description);
  const SimState msg = stateOf(*simulator, description);
  ASSERT_EQ(msg.link_pair_particles.size(), 4u);
  ASSERT_EQ(msg.link_pair_fractions.size(), 2u);
  ASSERT_EQ(msg.link_pair_normal_forces.size(), 1u);
  EXPECT_EQ(msg.link_pair_particles, (std::vector<int>{ 0, 1, 2, 3 }));
  EXPECT_NEAR(msg.link_pair_fractions[0], 0.75, 1e-6);
  EXPECT_NEAR(msg.link_pair_fractions[1], 0.5, 1e-6);
  EXPECT_NEAR(msg.link_pair_normal_forces[0], 4.0 * 9.81, 1e-6);
  EXPECT_TRUE(msg.segment_contact_first.empty());
  // rviz: one green arrow from link a's point over the lower link's middle, up, |f| scale long
  const visualization_msgs::MarkerArray arrows =
      contactForceMarkers(std_msgs::Header(), simulator->model(), simulator->state().positions,
                          simulator->data().contacts, 0.01, 0, nullptr, simulator->state().time);
  int drawn = 0;
  for (const visualization_msgs::Marker& m : arrows.markers)
    if (m.action == visualization_msgs::Marker::ADD)
    {
      ++drawn;
      ASSERT_EQ(m.points.size(), 2u);
      EXPECT_NEAR(m.points[0].x, 0.05, 1e-6);
      EXPECT_NEAR(m.points[0].y, 0.0, 1e-6);
      EXPECT_NEAR(m.points[0].z, 0.02, 1e-6);
      EXPECT_NEAR(m.points[1].z - m.points[0].z, 0.01 * 4.0 * 9.81, 1e-6);
    }
  EXPECT_EQ(drawn, 1);
}

// What the rope carries: a rope hanging straight down from a pin lists each link's tension, the
// weight below it (1e-9 relative), and each bend's moment (0 on its straight joints); a bend held
// at a right angle by pins carries 2 EI tan(pi/4) / (l cos^2(pi/4)) = 4 EI / l. In the order of
// the scene's records: the file's bend first, then the chain's.
TEST(StateMessage, EachLinksTensionAndEachBendsMomentAreListed)
{
  const SceneDescription description = parseScene(R"(
name: hanging
particles:
  - {position: [0, 0, 0]}
  - {position: [1, 0, 0]}
  - {position: [1, 1, 0]}
chains:
  - {particles: 4, link_length: 0.25, particle_mass: 0.5, start: [2, 0, 0], direction: [0, 0, -1],
     pin_first: true, bend_stiffness: 0.5}
constraints:
  - {type: pin, particle: 0}
  - {type: pin, particle: 1}
  - {type: pin, particle: 2}
forces:
  - {type: gravity}
  - {type: bend, first: 0, middle: 1, last: 2, stiffness: 0.5, length: 1}
)",
                                                  "hanging.yaml");
  const std::unique_ptr<Simulator> simulator = afterTenSteps(description);
  const SimState msg = stateOf(*simulator, description);
  EXPECT_EQ(msg.link_first, (std::vector<int>{ 3, 4, 5 }));
  EXPECT_EQ(msg.link_second, (std::vector<int>{ 4, 5, 6 }));
  ASSERT_EQ(msg.link_tensions.size(), 3u);
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(msg.link_tensions[k] / ((3 - k) * 0.5 * 9.81), 1.0, 1e-9) << k;
  EXPECT_EQ(msg.bend_particles, (std::vector<int>{ 1, 4, 5 }));
  ASSERT_EQ(msg.bending_moments.size(), 3u);
  EXPECT_NEAR(msg.bending_moments[0], 4.0 * 0.5 / 1.0, 1e-12);
  EXPECT_LT(msg.bending_moments[1], 1e-9);
  EXPECT_LT(msg.bending_moments[2], 1e-9);
}

// A self-colliding rope with no obstacle is drawn as thick as it collides (2 r), not 0.3 of a link.
TEST(StateMessage, ASelfCollidingRopeIsDrawnItsThickness)
{
  const BuiltScene built = buildScene(
      parseScene("chains: [{particles: 6, link_length: 0.05, start: [0, 0, 1], radius: 0.012, "
                 "self_collision: true}]\n",
                 "rope.yaml"));
  EXPECT_NEAR(particleSize(Model::compile(built.scene)), 0.024, 1e-15);
}

TEST(StateMessage, EveryStatisticReachesItsFieldAndKey)
{
  StepStatistics s;
  s.steps = 1;
  s.solve.factorizations = 2;
  s.solve.reused_factorizations = 3;
  s.solve.singular_count = 4;
  s.solve.fallbacks = 5;
  s.projection.projections = 6;
  s.projection.iterations = 7;
  s.projection.max_iterations = 8;
  s.internal_steps = 9;
  s.rejected_internal_steps = 10;
  s.forced_internal_steps = 11;
  s.substeps = 12;
  s.max_substeps = 13;
  s.rejected_steps = 14;
  s.stiff_steps = 15;
  s.unconverged_friction = 16;
  s.solve.min_pivot_ratio = 0.5;
  s.max_frequency = std::numeric_limits<double>::infinity();
  s.projection.converged = false;
  s.rejections[static_cast<int>(StepCheck::EnergyRise)] = 2;
  SimState msg;
  fillStatistics(s, msg);
  const std::uint32_t counts[] = { msg.interval_steps,        msg.factorizations,
                                   msg.reused_factorizations, msg.singular_solves,
                                   msg.solve_fallbacks,       msg.projections,
                                   msg.projection_iterations, msg.max_projection_iterations,
                                   msg.internal_steps,        msg.rejected_internal_steps,
                                   msg.forced_internal_steps, msg.substeps,
                                   msg.max_substeps_per_step, msg.rejected_steps,
                                   msg.stiff_steps,           msg.unconverged_friction };
  for (std::uint32_t k = 0; k < 16; ++k)
    EXPECT_EQ(counts[k], k + 1) << "count field " << k;
  EXPECT_EQ(msg.min_pivot_ratio, 0.5);
  // never inf on a topic
  EXPECT_EQ(msg.max_frequency, std::numeric_limits<double>::max());
  EXPECT_FALSE(msg.projections_converged);
  ASSERT_EQ(msg.rejection_checks.size(), 1u);
  EXPECT_EQ(msg.rejection_checks[0], stepCheckName(StepCheck::EnergyRise));
  EXPECT_EQ(msg.rejection_counts[0], 2u);
  const auto entries = collect([&](const AddKeyValue& add) { addStatistics(s, add); });
  EXPECT_EQ(entries.at("steps in the last second"), "1");
  EXPECT_EQ(entries.at("steps taken by fast_projection (stiff fallback)"), "15");
  EXPECT_EQ(entries.at("projections converged"), "no");
  EXPECT_EQ(entries.at("friction fixed points unconverged"), "16");
  EXPECT_EQ(entries.at("steps retaken, by check"),
            std::string(stepCheckName(StepCheck::EnergyRise)) + ":2");
  EXPECT_EQ(entries.size(), 16u + 2u + 3u);
}

TEST(StateMessage, ACountBeyondSimStatesRangeIsSaturatedNotWrapped)
{
  StepStatistics s;
  s.steps = (1L << 32) + 5;
  SimState msg;
  fillStatistics(s, msg);
  EXPECT_EQ(msg.interval_steps, std::numeric_limits<std::uint32_t>::max());
}

TEST(StateMessage, OneStatusWordingForEveryReader)
{
  Snapshot snap;
  EXPECT_EQ(statusText(snap), "");
  snap.behind = true;
  EXPECT_NE(statusText(snap).find("behind"), std::string::npos);
  snap.paused = true;
  EXPECT_EQ(statusText(snap), "paused");
  snap.stepping = true;
  EXPECT_EQ(statusText(snap), "paused, running a ~step");
  snap.faulted = true;
  snap.fault_reason = "the state became non-finite";
  EXPECT_EQ(statusText(snap), "the state became non-finite");
}

// /diagnostics' level and message come from the same list: the worst condition's level, every
// condition's words, "running" first when the status says nothing; a fault hides the figures of
// the steps it undid.
TEST(StateMessage, HealthIsTheWorstConditionWithEveryConditionsWords)
{
  Snapshot snap;
  StepStatistics statistics;
  Health health = assess(HealthInputs{ snap, statistics });
  EXPECT_EQ(health.level, diagnostic_msgs::DiagnosticStatus::OK);
  EXPECT_EQ(health.message, "running");
  statistics.solve.singular_count = 3;
  HealthInputs inputs{ snap, statistics };
  inputs.holders_warn = true;
  inputs.holder_warning = "frame_anchor 0 (frame hand) not followed; the particle is held";
  health = assess(inputs);
  EXPECT_EQ(health.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_EQ(health.message,
            "running; 3 singular solves (regularised) in the last second; frame_anchor 0 (frame "
            "hand) not followed; the particle is held");
  snap.faulted = true;
  snap.fault_reason = "a fault";
  health = assess(inputs);
  EXPECT_EQ(health.level, diagnostic_msgs::DiagnosticStatus::ERROR);
  EXPECT_EQ(health.message,
            "a fault; frame_anchor 0 (frame hand) not followed; the particle is held");
}

}  // namespace
}  // namespace constrained_particles
