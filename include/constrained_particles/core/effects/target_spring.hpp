/// @file target_spring.hpp
/// @brief A damped spring pulling one particle towards a fixed point (grab and drag).
#pragma once

#include "constrained_particles/core/effect_fields.hpp"

#include <vector>

namespace constrained_particles
{
/// Damped spring from particle i to a fixed target point a: f_i = -k (p_i - a) - c v_i. Box2D's
/// mouse joint written as a force: the node pulls a grabbed particle with one, at k = m w^2 and
/// c = 2 m w (critically damped for the particle alone). Not conservative (the damping).
struct TargetSpringForce
{
  int particle = 0;              ///< particle index
  Vec3 target{ 0.0, 0.0, 0.0 };  ///< a [m]
  double stiffness = 0.0;        ///< k [N/m], >= 0
  double damping = 0.0;          ///< c [N s/m], >= 0

  static constexpr const char* KIND = "target_spring";
  static constexpr bool CONSERVATIVE = false;  ///< the damping takes energy out
  static constexpr bool DISSIPATIVE = false;   ///< the energy ledger books its power as work in
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr auto fields()
  {
    return std::make_tuple(field("particle", &TargetSpringForce::particle, FieldKind::Particle,
                                 nullptr, "particle pulled"),
                           field("target", &TargetSpringForce::target, FieldKind::Vector,
                                 &limits::COORDINATE, "a, the point it is pulled towards"),
                           field("stiffness", &TargetSpringForce::stiffness, FieldKind::Number,
                                 &limits::STIFFNESS, "k"),
                           field("damping", &TargetSpringForce::damping, FieldKind::Number,
                                 &limits::DAMPING, "c, on the particle's velocity"));
  }
};

/// Adds f_i = -k (p_i - a) - c v_i [N]. Stateless.
inline void accumulateForce(const TargetSpringForce& force, const std::vector<double>& /*masses*/,
                            const Points& positions, const Points& velocities, Points& forces)
{
  forces.col(force.particle) -= force.stiffness * (positions.col(force.particle) - force.target) +
                                force.damping * velocities.col(force.particle);
}

/// The power it delivers, (-k (p_i - a) - c v_i) . v_i [W]: a drag's pull and its damping,
/// booked together as work from outside (the energy ledger's work in).
inline double power(const TargetSpringForce& force, const std::vector<double>& /*masses*/,
                    const Points& positions, const Points& velocities)
{
  const Vec3 v = velocities.col(force.particle);
  return -(force.stiffness * (positions.col(force.particle) - force.target) + force.damping * v)
              .dot(v);
}

/// Not conservative: 0 [J] (the work it does comes from outside).
inline double potentialEnergy(const TargetSpringForce&, const std::vector<double>&, const Points&)
{
  return 0.0;
}

/// The stability estimate's row sum at i: Hess(k |p_i - a|^2 / 2) = k I [N/m].
inline void addStiffness(const TargetSpringForce& force, double* stiffness)
{
  stiffness[force.particle] += force.stiffness;
}

/// @throws InvalidInput naming the bad field
inline void validate(const TargetSpringForce& force, int num_particles, const std::string& prefix)
{
  validateFields(force, num_particles, 0, prefix);
}

}  // namespace constrained_particles
