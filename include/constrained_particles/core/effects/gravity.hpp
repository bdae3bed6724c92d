/// @file gravity.hpp
/// @brief Uniform gravity, an applied force.
#pragma once

#include "constrained_particles/core/effect_fields.hpp"

#include <vector>

namespace constrained_particles
{
/// Uniform gravity: f_i = m_i g. Potential energy -sum m_i g.p_i.
struct GravityForce
{
  Vec3 acceleration{ 0.0, 0.0, -9.81 };  ///< g [m/s^2]

  static constexpr const char* KIND = "gravity";
  static constexpr bool CONSERVATIVE = true;  ///< f = -grad U, U its potentialEnergy()
  static constexpr bool DISSIPATIVE = false;  ///< the energy ledger books its power as work in
  static constexpr bool GALILEAN_INVARIANT = true;  ///< alike on every particle (Model::isolated())
  static constexpr auto fields()
  {
    return std::make_tuple(field("acceleration", &GravityForce::acceleration, FieldKind::Vector,
                                 &limits::GRAVITY, "g, the same for every particle"));
  }
};

/// Adds f_i = m_i g to the per-particle accumulator [N]. Stateless.
inline void accumulateForce(const GravityForce& force, const std::vector<double>& masses,
                            const Points& /*positions*/, const Points& /*velocities*/,
                            Points& forces)
{
  // g and n in registers: a store into `forces` might, for all the compiler knows, change them
  const Vec3 g = force.acceleration;
  const int n = static_cast<int>(forces.cols());
  double* f = forces.data();
  for (int i = 0; i < n; ++i)
    Eigen::Map<Vec3>(f + 3 * i) += masses[i] * g;
}

/// Conservative: its work is the change of potentialEnergy(), so no power is booked: 0 [W].
inline double power(const GravityForce&, const std::vector<double>&, const Points&, const Points&)
{
  return 0.0;
}

/// Sets f_i = m_i g [N]: accumulateForce onto zeros, in one pass instead of two (a stage whose
/// first force is gravity skips zeroing the accumulator: at 10^5 particles a pass is 2.4 MB).
/// 0 + m g as written, so a -0 component of m g is +0 as accumulated. Stateless.
inline void assignForce(const GravityForce& force, const std::vector<double>& masses,
                        Points& forces)
{
  const Vec3 g = force.acceleration;
  const int n = static_cast<int>(forces.cols());
  double* f = forces.data();
  for (int i = 0; i < n; ++i)
    Eigen::Map<Vec3>(f + 3 * i) = Vec3::Zero() + masses[i] * g;
}

/// -sum m_i g.p_i [J].
inline double potentialEnergy(const GravityForce& force, const std::vector<double>& masses,
                              const Points& positions)
{
  double energy = 0.0;
  for (int i = 0; i < positions.cols(); ++i)
    energy -= masses[i] * force.acceleration.dot(positions.col(i));
  return energy;
}

/// @throws InvalidInput naming the bad field
inline void validate(const GravityForce& force, int num_particles, const std::string& prefix)
{
  validateFields(force, num_particles, 0, prefix);
}

}  // namespace constrained_particles
