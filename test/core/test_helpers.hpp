// Shared helpers of the core tests: random states and finite differences.
#pragma once

#include "constrained_particles/core/model.hpp"

#include <random>

namespace constrained_particles
{
namespace testing
{
/// Deterministic random source for tests.
class Random
{
public:
  explicit Random(unsigned seed = 12345) : engine_(seed)
  {
  }
  double uniform(double low, double high)
  {
    return std::uniform_real_distribution<double>(low, high)(engine_);
  }
  Vec3 vector(double scale)
  {
    return Vec3(uniform(-scale, scale), uniform(-scale, scale), uniform(-scale, scale));
  }
  Vec3 unitVector()
  {
    Vec3 v;
    do
      v = vector(1.0);
    while (v.norm() < 0.1 || v.norm() > 1.0);
    return v.normalized();
  }
  std::mt19937& engine()
  {
    return engine_;
  }

private:
  std::mt19937 engine_;
};

/// Standard gravity [m/s^2].
constexpr double G = 9.81;

/// A state at positions p [m] with velocities v [m/s].
inline State stateOf(const Points& p, const Points& v)
{
  State s;
  s.positions = p;
  s.velocities = v;
  return s;
}

/// One particle of mass `mass` [kg] on `surface` under standard gravity.
inline Scene beadScene(const Surface& surface, double mass = 1.0)
{
  Scene scene;
  scene.masses = { mass };
  scene.surfaces = { surface };
  scene.forces = { GravityForce{} };
  scene.constraints = { SurfaceConstraint{ 0, 0 } };
  return scene;
}

/// A chain of the given masses [kg] joined by links of `link_length` [m], particle 0 pinned at
/// `anchor` [m], under standard gravity.
inline Scene pinnedChain(const std::vector<double>& masses, double link_length,
                         const Vec3& anchor = Vec3::Zero())
{
  Scene scene;
  scene.masses = masses;
  for (int i = 0; i + 1 < static_cast<int>(masses.size()); ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, link_length });
  scene.constraints.push_back(PinConstraint{ 0, anchor });
  scene.forces = { GravityForce{} };
  return scene;
}

/// Central difference step for functions of O(1) arguments.
constexpr double FD_STEP = 1e-6;

/// Relative error |a - b| / max(|b|, floor).
inline double relativeError(double a, double b, double floor = 1.0)
{
  return std::abs(a - b) / std::max(std::abs(b), floor);
}

}  // namespace testing
}  // namespace constrained_particles
