// The yardstick of issue 17 (bench/minimum_kernel.hpp) follows the engine: the same pinned
// chain, RK4 + projection, from the same start, agree to 1e-9 m after 1 s, and the kernel holds
// its links to the projection tolerance. A kernel with different physics (a wrong sign, a
// missed term, another stopping rule) drifts from the engine by far more within that second.
#include "../../bench/minimum_kernel.hpp"

#include "constrained_particles/core/simulator.hpp"

#include <gtest/gtest.h>

namespace constrained_particles
{
namespace
{
constexpr double LENGTH = 0.1, MASS = 0.1, DT = 1e-3, TOLERANCE = 1e-10, GRAVITY = -9.81;

Simulator pinnedChain(int n)
{
  Scene scene;
  scene.masses.assign(n, MASS);
  scene.forces = { GravityForce{} };
  for (int k = 0; k + 1 < n; ++k)
    scene.constraints.push_back(LinkConstraint{ k, k + 1, LENGTH });
  scene.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
  State start;
  start.positions.setZero(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
    start.positions(0, i) = LENGTH * i;
  StepSettings s;
  s.max_substeps = 1;
  s.dt = DT;
  s.integrator = "rk4";
  s.stabilization = Stabilization::Projection;
  s.projection_tolerance = TOLERANCE;
  return Simulator(scene, start, s);
}

TEST(MinimumKernel, FollowsTheEngineForOneSecond)
{
  for (int n : { 2, 10, 100 })
  {
    Simulator engine = pinnedChain(n);
    bench::MinimumChainKernel kernel(n, LENGTH, MASS, GRAVITY, DT, TOLERANCE,
                                     engine.stepSettings().projection_max_iterations);
    kernel.setState(engine.state().positions.data(), engine.state().velocities.data());
    double moved = 0.0;
    for (int k = 0; k < 1000; ++k)
    {
      engine.step();
      kernel.step();
      moved = std::max(moved, -engine.state().positions(2, n - 1));
    }
    const Points& p = engine.state().positions;
    const Points& v = engine.state().velocities;
    double position_difference = 0.0, velocity_difference = 0.0;
    for (int c = 0; c < p.size(); ++c)
    {
      position_difference =
          std::max(position_difference, std::abs(p.data()[c] - kernel.positions()[c]));
      velocity_difference =
          std::max(velocity_difference, std::abs(v.data()[c] - kernel.velocities()[c]));
    }
    // the last particle falls at least half a link: the chain swings, so the check means something
    EXPECT_GT(moved, 0.5 * LENGTH) << "n = " << n;
    EXPECT_LE(position_difference, 1e-9) << "n = " << n;
    EXPECT_LE(velocity_difference, 1e-8) << "n = " << n;
    EXPECT_LE(kernel.maxLinkError(), TOLERANCE) << "n = " << n;
  }
}

}  // namespace
}  // namespace constrained_particles
