#include "constrained_particles/core/scenarios.hpp"

#include <Eigen/Geometry>

#include <cmath>

namespace constrained_particles
{
namespace
{
const Vec3 BEAD_START_XY(0.5, 0.0, 0.0);  // [m]; z comes from the surface
constexpr double BEAD_START_SPEED = 0.8;  // along +y [m/s]
constexpr double HANG_ANGLE = M_PI / 6;   // surface_chain links from vertical [rad]
constexpr double FREE_CHAIN_SPIN = 1.0;   // free chain's rate about z [rad/s]

// bead on the surface at BEAD_START_XY, velocity along +y in the tangent plane
void placeBead(const Surface& surface, Vec3& position, Vec3& velocity)
{
  const SurfaceSample s = evaluateSurface(surface, BEAD_START_XY.x(), BEAD_START_XY.y());
  position = Vec3(BEAD_START_XY.x(), BEAD_START_XY.y(), s.z);
  velocity = Vec3(0.0, BEAD_START_SPEED, s.zy * BEAD_START_SPEED);
}

}  // namespace

std::vector<Force> scenarioForces(const ScenarioParameters& parameters)
{
  std::vector<Force> forces;
  if (!parameters.gravity.isZero(0.0))
    forces.push_back(GravityForce{ parameters.gravity });
  if (parameters.damping > 0.0)
    forces.push_back(LinearDampingForce{ parameters.damping });
  return forces;
}

std::vector<std::string> scenarioNames()
{
  return { "bead", "chain", "surface_chain" };
}

void validateScenarioParameters(const ScenarioParameters& parameters)
{
  validateSurface(parameters.surface, "surface");
  const ChainParameters& chain = parameters.chain;
  if (chain.num_particles < 1 || chain.num_particles > MAX_PARTICLES)
  {
    throw InvalidInput("chain.num_particles", "= " + std::to_string(chain.num_particles) +
                                                  ", must be in [1, " +
                                                  std::to_string(MAX_PARTICLES) + "]");
  }
  requirePositive("chain.link_length", chain.link_length, "[m]");
  if (chain.link_length > 1e3)
    throw InvalidInput("chain.link_length",
                       "= " + formatValue(chain.link_length) + ", must be in (0, 1000] [m]");
  requirePositive("chain.particle_mass", chain.particle_mass, "[kg]");
  if (chain.particle_mass > 1e6)
    throw InvalidInput("chain.particle_mass",
                       "= " + formatValue(chain.particle_mass) + ", must be in (0, 1e6] [kg]");
  requirePositive("bead_mass", parameters.bead_mass, "[kg]");
  if (parameters.bead_mass > 1e6)
    throw InvalidInput("bead_mass",
                       "= " + formatValue(parameters.bead_mass) + ", must be in (0, 1e6] [kg]");
  requireFinite("gravity", parameters.gravity, "[m/s^2]");
  requireNonNegative("damping", parameters.damping, "[N s/m]");
}

Scenario buildScenario(const std::string& name, const ScenarioParameters& parameters)
{
  validateScenarioParameters(parameters);
  Scenario scenario;
  Scene& scene = scenario.scene;
  State& state = scenario.initial_state;
  scene.name = name;
  const ChainParameters& chain = parameters.chain;

  if (name == "bead")
  {
    scene.masses = { parameters.bead_mass };
    scene.surfaces = { parameters.surface };
    scene.constraints = { SurfaceConstraint{ 0, 0 } };
    state.positions.resize(3, 1);
    state.velocities.resize(3, 1);
    Vec3 p, v;
    placeBead(parameters.surface, p, v);
    state.positions.col(0) = p;
    state.velocities.col(0) = v;
  }
  else if (name == "chain")
  {
    const int n = chain.num_particles;
    scene.masses.assign(n, chain.particle_mass);
    state.positions.resize(3, n);
    state.velocities.setZero(3, n);
    const Vec3 center(0.5 * (n - 1) * chain.link_length, 0.0, 0.0);
    for (int i = 0; i < n; ++i)
    {
      state.positions.col(i) = Vec3(i * chain.link_length, 0.0, 0.0);
      if (!chain.pin_first)
        state.velocities.col(i) =
            Vec3(0, 0, FREE_CHAIN_SPIN).cross(state.positions.col(i) - center);
    }
    for (int i = 0; i + 1 < n; ++i)
      scene.constraints.push_back(LinkConstraint{ i, i + 1, chain.link_length });
    if (chain.pin_first)
      scene.constraints.push_back(PinConstraint{ 0, Vec3::Zero() });
  }
  else if (name == "surface_chain")
  {
    const int n = chain.num_particles;
    scene.masses.assign(n, chain.particle_mass);
    scene.surfaces = { parameters.surface };
    // rows ordered [surface, link 0-1, link 1-2, ...] keep J W J^T tridiagonal
    scene.constraints.push_back(SurfaceConstraint{ 0, 0 });
    for (int i = 0; i + 1 < n; ++i)
      scene.constraints.push_back(LinkConstraint{ i, i + 1, chain.link_length });
    Vec3 p, v;
    placeBead(parameters.surface, p, v);
    const Vec3 down(std::sin(HANG_ANGLE), 0.0, -std::cos(HANG_ANGLE));
    state.positions.resize(3, n);
    state.velocities.resize(3, n);
    for (int i = 0; i < n; ++i)
    {
      state.positions.col(i) = p + i * chain.link_length * down;
      state.velocities.col(i) = v;
    }
  }
  else
  {
    std::string valid;
    for (const auto& known : scenarioNames())
      valid += (valid.empty() ? "" : ", ") + known;
    throw InvalidInput("scenario", "= '" + name + "' is unknown; valid: " + valid);
  }
  scene.forces = scenarioForces(parameters);
  return scenario;
}

}  // namespace constrained_particles
