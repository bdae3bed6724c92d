// Shared helpers of the core tests: random states, the shipped seed scenes, and a window on the
// step's stages (white-box: src/core is on these tests' include path).
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"
#include "constrained_particles/scenes/scene_file.hpp"
#include "stages.hpp"

#include <array>
#include <random>
#include <string>
#include <vector>

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

/// A shape of `type` at `position`, turned by `rpy` [rad], named by its type, of the tests' sizes:
/// radius 0.3, length 0.8, box sides (0.4, 0.6, 0.8) [m].
inline Shape shapeOf(ShapeType type, const Vec3& position = Vec3::Zero(),
                     const Vec3& rpy = Vec3::Zero())
{
  Shape shape;
  shape.name = shapeTypeName(type);
  shape.type = type;
  shape.position = position;
  shape.rotation = rotationFromRpy(rpy);
  shape.radius = 0.3;
  shape.length = 0.8;
  shape.size = Vec3(0.4, 0.6, 0.8);
  return shape;
}

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

/// n particles at rest along +x from the origin, 0.1 m apart: a 0.1 m pinnedChain laid out
/// straight.
inline State horizontalStart(int n)
{
  State start;
  start.positions.setZero(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
    start.positions(0, i) = 0.1 * i;
  return start;
}

/// The seed derivation's three systems, as shipped in config/scenes.
inline std::vector<std::string> seedSceneNames()
{
  return { "bead", "chain", "surface_chain" };
}

/// A shipped scene file's description (config/scenes/<name>.yaml).
inline SceneDescription shippedDescription(const std::string& name)
{
  return loadSceneFile(std::string(SCENES_DIR) + "/" + name + ".yaml");
}

/// A shipped scene, built as the file says.
inline BuiltScene shippedScene(const std::string& name)
{
  return buildScene(shippedDescription(name));
}

/// A shipped scene with every chain changed (as ~set_chain does).
inline BuiltScene shippedScene(const std::string& name, const ChainChange& chain)
{
  SceneDescription description = shippedDescription(name);
  setChains(description, chain);
  return buildScene(description);
}

/// A chain change of n particles, links of l [m] and masses m [kg], the first pinned.
inline ChainChange chainOf(int n, double link_length = 0.5, double mass = 1.0,
                           bool pin_first = true)
{
  ChainChange change;
  change.num_particles = n;
  change.link_length = link_length;
  change.particle_mass = mass;
  change.pin_first = pin_first;
  return change;
}

/// a = W (f + J^T lambda) at (p, v) and time 0 without Baumgarte: the stages in order (forward),
/// leaving rows, forces and multipliers in `data`.
inline SolveReport computeAccelerations(const Model& model, Data& data, const Points& positions,
                                        const Points& velocities, Points& accelerations)
{
  Points p = positions, v = velocities;
  StepSettings settings;
  settings.stabilization = Stabilization::None;
  accelerations.resize(3, model.numParticles());
  return forward(model, data, settings, 0.0, p, v, accelerations);
}

/// One row record's rows, evaluated alone (for finite-difference checks).
template <typename Kind>
struct RecordRows
{
  std::array<int, Kind::PARTICLES> particles;
  std::array<double, Kind::ROWS> value, jdot_v, violation;
  std::array<double, Kind::ROWS> metric_rate;  ///< violationRates() [m/s]
  std::array<Vec3, Kind::ROWS * Kind::PARTICLES> jacobian;

  /// dC_row/dp of the record's k-th particle.
  const Vec3& block(int row, int k) const
  {
    return jacobian[row * Kind::PARTICLES + k];
  }
  /// J_row as one 3-vector per particle of a scene of n particles (zero where untouched).
  Points jacobianRow(int row, int n) const
  {
    Points dense = Points::Zero(3, n);
    for (int k = 0; k < Kind::PARTICLES; ++k)
      dense.col(particles[k]) += block(row, k);
    return dense;
  }
  /// Cdot of a row: J_row v.
  double jv(int row, const Points& velocities) const
  {
    double sum = 0.0;
    for (int k = 0; k < Kind::PARTICLES; ++k)
      sum += block(row, k).dot(velocities.col(particles[k]));
    return sum;
  }
};

/// Evaluates one row record of kind Kind at (p, v) and time t.
template <typename Kind>
RecordRows<Kind> evaluateRecord(const Kind& record, const std::vector<Surface>& surfaces,
                                const Points& positions, const Points& velocities,
                                double time = 0.0)
{
  RecordRows<Kind> rows;
  rows.particles = rowParticles(record);
  const EffectContext context{ surfaces, time };
  evaluateRows(record, context, positions, velocities,
               RowBlock{ rows.value.data(), rows.jdot_v.data(), rows.violation.data(),
                         rows.jacobian.data() });
  violationRates(record, context, positions, velocities, rows.metric_rate.data());
  return rows;
}

/// Central difference step for functions of O(1) arguments.
constexpr double FD_STEP = 1e-6;

/// Relative error |a - b| / max(|b|, floor).
inline double relativeError(double a, double b, double floor = 1.0)
{
  return std::abs(a - b) / std::max(std::abs(b), floor);
}

/// Where a particle flying free under gravity G (down z), at p1 with velocity v1 now, left a
/// surface: the point of its path (a parabola, exact) over the last `span` seconds where `gap`
/// (height over the surface at a point [m]) crosses 0, found by bisection. It left where gravity's
/// normal part stopped holding it on, where the parabola's curvature is the surface's: the gap
/// along it has a triple zero there (in before, out after), found to its cube root of round-off.
template <typename Gap>
Vec3 lastTouch(const Vec3& p1, const Vec3& v1, double span, Gap gap)
{
  auto at = [&](double tau) { return Vec3(p1 + v1 * tau - Vec3(0.0, 0.0, 0.5 * G * tau * tau)); };
  double low = -span, high = 0.0;  // in (or on) at low, out at high
  for (int k = 0; k < 200 && high - low > 1e-15; ++k)
  {
    const double middle = 0.5 * (low + high);
    (gap(at(middle)) > 0.0 ? high : low) = middle;
  }
  return at(0.5 * (low + high));
}

}  // namespace testing
}  // namespace constrained_particles
