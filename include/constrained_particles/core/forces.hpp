/// @file forces.hpp
/// @brief The registry of applied-force kinds, and dispatch over them.
///
/// Each kind lives in its own file under effects/: a record (KIND, fields()) with the stateless
/// functions accumulateForce, potentialEnergy, power and validate, and addStiffness for the kinds
/// whose force depends on position (springs: the stability estimate reads it). Adding a kind means
/// writing that file and adding the record to `Force` below; the stepper, validation and scene
/// files follow.
#pragma once

#include "constrained_particles/core/effects/bending.hpp"
#include "constrained_particles/core/effects/external_force.hpp"
#include "constrained_particles/core/effects/gravity.hpp"
#include "constrained_particles/core/effects/linear_damping.hpp"
#include "constrained_particles/core/effects/quadratic_drag.hpp"
#include "constrained_particles/core/effects/spring.hpp"
#include "constrained_particles/core/effects/target_spring.hpp"

#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace constrained_particles
{
/// One applied force of a scene: the registry of force kinds.
using Force = std::variant<GravityForce, LinearDampingForce, ExternalForce, QuadraticDragForce,
                           SpringForce, TargetSpringForce, BendingForce>;

/// Number of force kinds.
constexpr int NUM_FORCE_KINDS = static_cast<int>(std::variant_size_v<Force>);

/// Adds the force [N] to the per-particle accumulator. Stateless.
inline void accumulateForce(const Force& force, const std::vector<double>& masses,
                            const Points& positions, const Points& velocities, Points& forces)
{
  std::visit([&](const auto& f) { accumulateForce(f, masses, positions, velocities, forces); },
             force);
}

/// Potential energy [J] of a conservative force at the given positions; 0 for the others.
inline double potentialEnergy(const Force& force, const std::vector<double>& masses,
                              const Points& positions)
{
  return std::visit([&](const auto& f) { return potentialEnergy(f, masses, positions); }, force);
}

/// The power the force delivers at a state, f . v [W]: 0 for a conservative force (its work
/// is the change of its potential energy). The energy ledger's (EnergyLedger) integrand.
inline double power(const Force& force, const std::vector<double>& masses, const Points& positions,
                    const Points& velocities)
{
  return std::visit([&](const auto& f) { return power(f, masses, positions, velocities); }, force);
}

/// Whether the ledger books the force's power as dissipated (damping, drag) or as work in.
inline bool forceDissipates(const Force& force)
{
  return std::visit([](const auto& f) { return std::decay_t<decltype(f)>::DISSIPATIVE; }, force);
}

namespace detail
{
template <typename Kind, typename = void>
struct HasStiffness : std::false_type
{
};
template <typename Kind>
struct HasStiffness<
    Kind, std::void_t<decltype(addStiffness(std::declval<const Kind&>(), std::declval<double*>()))>>
  : std::true_type
{
};
}  // namespace detail

/// Whether the force depends on position (it gives the stability estimate a stiffness). Named
/// apart from the kinds' addStiffness: a kind converts to Force, so an overload would recurse.
inline bool forceHasStiffness(const Force& force)
{
  return std::visit(
      [](const auto& f) { return detail::HasStiffness<std::decay_t<decltype(f)>>::value; }, force);
}

/// Adds the force's stiffness row sums [N/m] per particle (n entries) for the stability
/// estimate (stability.hpp); nothing for kinds that do not depend on position.
inline void addForceStiffness(const Force& force, double* stiffness)
{
  std::visit(
      [&](const auto& f)
      {
        if constexpr (detail::HasStiffness<std::decay_t<decltype(f)>>::value)
          addStiffness(f, stiffness);
      },
      force);
}

/// Throws InvalidInput if the record is malformed for a scene of num_particles particles.
/// @param field name of the record in messages, e.g. "forces[2]"
inline void validateForce(const Force& force, int num_particles, const std::string& field)
{
  std::visit([&](const auto& f) { validate(f, num_particles, field); }, force);
}

}  // namespace constrained_particles
