/// @file scenarios.hpp
/// @brief The three built-in systems of the seed derivation, as scenes with initial states.
///
/// - `bead`: one particle on the surface (seed problem 1). Starts at (0.5, 0, Z) m moving
///   along +y at 0.8 m/s in the surface's tangent plane.
/// - `chain`: n particles joined by links of length l (seed problem 2). Starts straight along
///   +x from the origin at rest; with pin_first the first particle is pinned at the origin and the
///   chain swings down, otherwise it falls while spinning about z at 1 rad/s.
/// - `surface_chain`: the first particle slides on the surface, the others hang from it (seed
///   problem 3, generalised to n particles). The bead starts as in `bead`; the chain hangs at
///   30 degrees from vertical toward +x, every particle moving with the bead.
#pragma once

#include "constrained_particles/core/model.hpp"

#include <string>
#include <vector>

namespace constrained_particles
{
/// Largest particle count a scenario accepts.
constexpr int MAX_PARTICLES = 1000000;

/// The chain of the `chain` and `surface_chain` scenarios.
struct ChainParameters
{
  int num_particles = 5;       ///< n, in [1, MAX_PARTICLES]
  double link_length = 0.5;    ///< l [m], in (0, 1e3]
  double particle_mass = 1.0;  ///< m [kg], in (0, 1e6]
  bool pin_first = true;       ///< `chain` only: pin the first particle at the origin
};

/// Everything a built-in scenario is made from.
struct ScenarioParameters
{
  Surface surface;                  ///< for `bead` and `surface_chain` (default bowl)
  ChainParameters chain;            ///< for `chain` and `surface_chain`
  double bead_mass = 1.0;           ///< `bead` particle mass [kg], in (0, 1e6]
  Vec3 gravity{ 0.0, 0.0, -9.81 };  ///< [m/s^2]; a zero vector adds no gravity force
  double damping = 0.0;             ///< linear damping c [N s/m], >= 0; 0 adds no force
};

/// A scene and the state it starts from.
struct Scenario
{
  Scene scene;
  State initial_state;
};

/// Names of the built-in scenarios: bead, chain, surface_chain.
std::vector<std::string> scenarioNames();

/// @throws InvalidInput naming the first bad field (e.g. "chain.link_length") and its range
void validateScenarioParameters(const ScenarioParameters& parameters);

/// The applied forces the parameters call for: gravity unless it is zero, damping unless it
/// is zero.
std::vector<Force> scenarioForces(const ScenarioParameters& parameters);

/// Builds a scenario by name. @throws InvalidInput for an unknown name or bad parameters
Scenario buildScenario(const std::string& name, const ScenarioParameters& parameters);

}  // namespace constrained_particles
