// Pushes and drags without a runner (perturbations.hpp): a push counted in whole steps and ended
// on its step, refusals naming the field and leaving what acts untouched, drag updates for
// another scene or out of range dropped, and each drag's spring critically damped at the
// frequency the step allows.
#include "constrained_particles/ros/perturbations.hpp"

#include "constrained_particles/core/limits.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <variant>

namespace constrained_particles
{
namespace
{
TEST(Perturbations, APushLastsItsStepsAndEndsOnTheLast)
{
  Perturbations p;
  // 10.5 steps of 1 ms begin within 10.5 ms: 11; a duration within 1e-9 dt of 5 dt is 5 steps
  EXPECT_TRUE(p.apply(2, Vec3(1.0, 0.0, 0.0), 0.0105, 5, 100, 0.1, 1e-3, "chain").accepted);
  EXPECT_TRUE(p.apply(3, Vec3(0.0, 1.0, 0.0), 0.005 + 1e-13, 5, 100, 0.1, 1e-3, "chain").accepted);
  EXPECT_EQ(p.appliedCount(), 2u);
  std::uint64_t next = 0;
  EXPECT_FALSE(p.expire(104, 1000, next));
  EXPECT_EQ(next, 1u);  // the second ends at step 105
  EXPECT_TRUE(p.expire(105, 1000, next));
  EXPECT_EQ(p.appliedCount(), 1u);
  EXPECT_EQ(next, 6u);  // the first at 111
  EXPECT_TRUE(p.expire(111, 1000, next));
  EXPECT_TRUE(p.empty());
  EXPECT_EQ(next, 1000u);
  // duration 0: until cleared
  EXPECT_TRUE(p.apply(0, Vec3(0.0, 0.0, 1.0), 0.0, 5, 0, 0.0, 1e-3, "chain").accepted);
  EXPECT_FALSE(p.expire(1000000, 10, next));
  EXPECT_EQ(p.clearApplied(), 1u);
}

TEST(Perturbations, ABadPushIsRefusedNamingTheFieldAndChangesNothing)
{
  Perturbations p;
  ASSERT_TRUE(p.apply(0, Vec3(1.0, 0.0, 0.0), 1.0, 5, 0, 0.0, 1e-3, "chain").accepted);
  try
  {
    p.apply(5, Vec3::Zero(), 1.0, 5, 0, 0.0, 1e-3, "chain");
    FAIL() << "particle 5 of 5 accepted";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_EQ(e.field(), "particle");
    EXPECT_NE(std::string(e.what()).find("[0, 4]"), std::string::npos) << e.what();
  }
  EXPECT_THROW(p.apply(0, Vec3(NAN, 0.0, 0.0), 1.0, 5, 0, 0.0, 1e-3, "chain"), InvalidInput);
  EXPECT_THROW(p.apply(0, Vec3::Zero(), -1.0, 5, 0, 0.0, 1e-3, "chain"), InvalidInput);
  EXPECT_EQ(p.appliedCount(), 1u);
  for (std::size_t k = 1; k < Perturbations::MAX_APPLIED_FORCES; ++k)
    ASSERT_TRUE(p.apply(0, Vec3::Zero(), 0.0, 5, 0, 0.0, 1e-3, "chain").accepted);
  const Perturbations::Outcome full = p.apply(0, Vec3::Zero(), 0.0, 5, 0, 0.0, 1e-3, "chain");
  EXPECT_FALSE(full.accepted);
  EXPECT_NE(full.message.find("~clear_forces"), std::string::npos) << full.message;
  EXPECT_EQ(p.appliedCount(), Perturbations::MAX_APPLIED_FORCES);
}

TEST(Perturbations, DragUpdatesForAnotherSceneOrOutOfRangeAreDropped)
{
  Perturbations p;
  EXPECT_EQ(p.takeQueued(7, 5), Perturbations::Change::None);
  p.queueDrag(6, 1, Vec3(1.0, 0.0, 0.0));                          // another scene
  p.queueDrag(7, 5, Vec3(1.0, 0.0, 0.0));                          // particle out of range
  p.queueDrag(7, 2, Vec3(NAN, 0.0, 0.0));                          // target not finite
  p.queueDrag(0, 2, Vec3(limits::COORDINATE.high * 2, 0.0, 0.0));  // outside the coordinates
  EXPECT_TRUE(p.hasQueued());
  EXPECT_EQ(p.takeQueued(7, 5), Perturbations::Change::None);
  EXPECT_FALSE(p.hasQueued());
  EXPECT_EQ(p.draggedCount(), 0u);
  p.queueDrag(7, 2, Vec3(1.0, 0.0, 0.0));
  EXPECT_EQ(p.takeQueued(7, 5), Perturbations::Change::Acting);
  p.queueDrag(0, 2, Vec3(2.0, 0.0, 0.0));  // 0: the current scene
  EXPECT_EQ(p.takeQueued(7, 5), Perturbations::Change::Forces);
  p.queueRelease(7, -1);
  EXPECT_EQ(p.takeQueued(7, 5), Perturbations::Change::Acting);
  EXPECT_TRUE(p.empty());
}

TEST(Perturbations, ADragsSpringIsCriticallyDampedAtTheFrequencyTheStepAllows)
{
  Perturbations p;
  p.queueDrag(0, 0, Vec3(1.0, 2.0, 3.0));
  p.queueDrag(0, 1, Vec3(0.0, 0.0, 1.0));
  ASSERT_EQ(p.takeQueued(1, 2), Perturbations::Change::Acting);
  const std::vector<double> masses = { 0.5, 2.0 };
  for (const double dt : { 1e-3, 0.05 })
  {
    const double w = std::min(Perturbations::DRAG_FREQUENCY, Perturbations::DRAG_STEP_LIMIT / dt);
    const std::vector<Force> forces = p.forces(masses, dt);
    ASSERT_EQ(forces.size(), 2u);
    for (int i = 0; i < 2; ++i)
    {
      const auto& spring = std::get<TargetSpringForce>(forces[i]);
      EXPECT_EQ(spring.particle, i);
      EXPECT_DOUBLE_EQ(spring.stiffness, masses[i] * w * w) << dt;
      EXPECT_DOUBLE_EQ(spring.damping, 2.0 * masses[i] * w) << dt;
    }
  }
  p.clearAll();
  EXPECT_TRUE(p.forces(masses, 1e-3).empty());
}

TEST(Perturbations, ACommandActsUntilANewerOneOrItsTimeout)
{
  Perturbations p;
  const double t0 = 100.0;  // [s] on the command clock
  p.queueCommand(7, 3, Vec3(1.0, 0.0, 0.0), t0, 0.5);
  p.queueCommand(6, 2, Vec3(1.0, 0.0, 0.0), t0, 0.5);  // for another scene: dropped, counted
  EXPECT_EQ(p.takeQueued(7, 4), Perturbations::Change::Acting);
  EXPECT_EQ(p.commandedCount(), 1u);
  EXPECT_EQ(p.staleCommands(), 1u);
  std::vector<Force> forces = p.forces({ 1.0, 1.0, 1.0, 1.0 }, 1e-3);
  ASSERT_EQ(forces.size(), 1u);
  ASSERT_TRUE(std::holds_alternative<ExternalForce>(forces[0]));
  EXPECT_EQ(std::get<ExternalForce>(forces[0]).particle, 3);
  EXPECT_EQ(std::get<ExternalForce>(forces[0]).force, Vec3(1.0, 0.0, 0.0));
  // a newer command replaces it, and moves its timeout
  p.queueCommand(7, 3, Vec3(0.0, 2.0, 0.0), t0 + 0.25, 0.5);
  EXPECT_EQ(p.takeQueued(7, 4), Perturbations::Change::Forces);
  forces = p.forces({ 1.0, 1.0, 1.0, 1.0 }, 1e-3);
  ASSERT_EQ(forces.size(), 1u);
  EXPECT_EQ(std::get<ExternalForce>(forces[0]).force, Vec3(0.0, 2.0, 0.0));
  double next = 0.0;
  EXPECT_FALSE(p.expireCommands(t0 + 0.7, next));
  EXPECT_EQ(next, t0 + 0.75);
  EXPECT_TRUE(p.expireCommands(t0 + 0.75, next));
  EXPECT_EQ(next, INFINITY);
  EXPECT_TRUE(p.empty());
  // a command for a particle the scene no longer has is dropped
  p.queueCommand(7, 4, Vec3(1.0, 0.0, 0.0), t0, 0.5);
  EXPECT_EQ(p.takeQueued(7, 4), Perturbations::Change::None);
  // a reset ends them
  p.queueCommand(7, 1, Vec3(1.0, 0.0, 0.0), t0, 0.5);
  p.takeQueued(7, 4);
  p.clearAll();
  EXPECT_EQ(p.commandedCount(), 0u);
}

TEST(Perturbations, ACommandNamesAParticleFrameAndFiniteForcesInRange)
{
  const Vec3 zero = Vec3::Zero();
  EXPECT_EQ(Perturbations::checkCommand("particle_3", "particle_", Vec3(1.0, 2.0, 3.0), zero, 4),
            3);
  EXPECT_EQ(Perturbations::checkCommand("/particle_0", "particle_", zero, zero, 4), 0);
  EXPECT_EQ(Perturbations::checkCommand("robot1/particle_12", "robot1/particle_", zero,
                                        Vec3(1.0, 0.0, 0.0), 13),
            12);
  auto field = [](const std::string& frame, const Vec3& force, const Vec3& torque)
  {
    try
    {
      Perturbations::checkCommand(frame, "particle_", force, torque, 4);
    }
    catch (const InvalidInput& e)
    {
      return e.field();
    }
    return std::string("accepted");
  };
  for (const std::string frame :
       { "particle_4", "particle_", "particle_-1", "particle_1x", "world", "",
         "particle_99999999999", "p_1", "particle_01", "particle_+1" })
    EXPECT_EQ(field(frame, zero, zero), "header.frame_id") << frame;
  EXPECT_EQ(field("particle_1", Vec3(NAN, 0.0, 0.0), zero), "wrench.force.x");
  EXPECT_EQ(field("particle_1", Vec3(0.0, INFINITY, 0.0), zero), "wrench.force.y");
  EXPECT_EQ(field("particle_1", Vec3(0.0, 0.0, -2.0 * limits::FORCE.high), zero), "wrench.force.z");
  EXPECT_EQ(field("particle_1", zero, Vec3(0.0, 0.0, NAN)), "wrench.torque.z");
  EXPECT_EQ(field("particle_1", Vec3(0.0, 0.0, limits::FORCE.high), Vec3(1e300, 0.0, 0.0)),
            "accepted");
}

}  // namespace
}  // namespace constrained_particles
