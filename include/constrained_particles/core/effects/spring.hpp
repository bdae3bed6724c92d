/// @file spring.hpp
/// @brief A linear spring between two particles.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"

#include <vector>

namespace constrained_particles
{
/// Spring between particles i and j: f_i = -k (|p_i - p_j| - L) (p_i - p_j) / |p_i - p_j|,
/// f_j = -f_i; potential k (|p_i - p_j| - L)^2 / 2. Coincident particles get no force (no
/// direction); with L > 0 the force flips direction through that point, so motion through it is
/// not smooth (L = 0 gives f = -k (p_i - p_j), smooth everywhere).
struct SpringForce
{
  int first = 0;             ///< particle i
  int second = 1;            ///< particle j, != i
  double stiffness = 1.0;    ///< k [N/m], >= 0
  double rest_length = 0.0;  ///< L [m], >= 0

  static constexpr const char* KIND = "spring";
  static constexpr bool CONSERVATIVE = true;  ///< f = -grad U, U its potentialEnergy()
  static constexpr bool DISSIPATIVE = false;  ///< the energy ledger books its power as work in
  static constexpr bool GALILEAN_INVARIANT =
      true;  ///< between its particles only (Model::isolated())
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("first", &SpringForce::first, FieldKind::Particle, nullptr, "particle i"),
        field("second", &SpringForce::second, FieldKind::Particle, nullptr, "particle j, != i"),
        field("stiffness", &SpringForce::stiffness, FieldKind::Number, &limits::STIFFNESS, "k"),
        field("rest_length", &SpringForce::rest_length, FieldKind::Number, &limits::REST_LENGTH,
              "L"));
  }
};

/// Adds the spring force to particles i and j [N]. Stateless.
inline void accumulateForce(const SpringForce& force, const std::vector<double>& /*masses*/,
                            const Points& positions, const Points& /*velocities*/, Points& forces)
{
  const Vec3 d = positions.col(force.first) - positions.col(force.second);
  const double length = d.norm();
  if (!(length > 0.0))
    return;
  const Vec3 f = (-force.stiffness * (length - force.rest_length) / length) * d;
  forces.col(force.first) += f;
  forces.col(force.second) -= f;
}

/// Conservative: its work is the change of potentialEnergy(), so no power is booked: 0 [W].
inline double power(const SpringForce&, const std::vector<double>&, const Points&, const Points&)
{
  return 0.0;
}

/// k (|p_i - p_j| - L)^2 / 2 [J].
inline double potentialEnergy(const SpringForce& spring, const std::vector<double>& /*masses*/,
                              const Points& positions)
{
  const double stretch =
      (positions.col(spring.first) - positions.col(spring.second)).norm() - spring.rest_length;
  return 0.5 * spring.stiffness * stretch * stretch;
}

/// The stability estimate's row sums: k I blocks at i and j, 2 k each (the geometric part, from
/// the direction's turning, is smaller) [N/m].
inline void addStiffness(const SpringForce& spring, double* stiffness)
{
  stiffness[spring.first] += 2.0 * spring.stiffness;
  stiffness[spring.second] += 2.0 * spring.stiffness;
}

/// @throws InvalidInput naming the bad field
inline void validate(const SpringForce& spring, int num_particles, const std::string& prefix)
{
  validateFields(spring, num_particles, 0, prefix);
  requireDistinctParticles(spring.first, spring.second, prefix);
}

}  // namespace constrained_particles
