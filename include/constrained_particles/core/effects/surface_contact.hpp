/// @file surface_contact.hpp
/// @brief A particle that cannot go below a height field: a unilateral contact with Coulomb
/// friction, one row that the contact stage (src/core/contact.hpp) switches on and off.
/// docs/physics.md, "Contact".
#pragma once

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"
#include "constrained_particles/core/effects/surface_constraint.hpp"

#include <array>
#include <cmath>
#include <vector>

namespace constrained_particles
{
/// Particle i on or above z = Z(x, y):  C = z_i - Z(x_i, y_i) >= 0 [m], with multiplier
/// lambda_n >= 0 and lambda_n C = 0: one row, J = (-Z_x, -Z_y, 1), Jdot v = -(Z_xx vx^2 +
/// 2 Z_xy vx vy + Z_yy vy^2), which the contact stage (contact.hpp) switches on and off (an
/// inactive row's blocks are zero and its multiplier 0: RowData::inactive). Coulomb friction
/// |f_t| <= mu |f_n| is a force in the tangent plane that the contact stage solves for with the
/// rows (staggered), not a row: a sticking particle on a chain would make the rows redundant.
struct SurfaceContact
{
  int particle = 0;          ///< particle i
  int surface = 0;           ///< index into Scene::surfaces
  double friction = 0.0;     ///< Coulomb coefficient mu [1]; 0: frictionless
  double restitution = 0.0;  ///< Newton's coefficient e [1]: normal speed out = e x speed in

  static constexpr const char* KIND = "surface_contact";
  static constexpr bool ELIMINATED = false;
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr bool UNILATERAL = true;           ///< rows switch on and off (contact.hpp)
  static constexpr bool PARTICLE_CONTACT = true;     ///< one particle against the world
  static constexpr int ROWS = 1;                     ///< the normal row
  static constexpr int PARTICLES = 1;                ///< on particle i
  static constexpr auto fields()
  {
    return std::make_tuple(
        field("particle", &SurfaceContact::particle, FieldKind::Particle, nullptr, "particle i"),
        field("surface", &SurfaceContact::surface, FieldKind::Surface, nullptr,
              "the height field it cannot go below"),
        field("friction", &SurfaceContact::friction, FieldKind::Number, &limits::FRICTION,
              "Coulomb's mu: sticks while |f_t| <= mu |f_n| (0: frictionless)"),
        field("restitution", &SurfaceContact::restitution, FieldKind::Number, &limits::RESTITUTION,
              "Newton's e: normal speed after an impact over before"));
  }
};

/// How far below its surface a contact's particle may start [m] (rounding of a particle placed on
/// it); a scene file starting one deeper is refused.
constexpr double CONTACT_START_DEPTH = 1e-9;

/// A kind whose rows the contact stage switches declares `static constexpr bool UNILATERAL =
/// true`. Others need not say.
template <class Kind, class = void>
struct IsUnilateral : std::false_type
{
};
template <class Kind>
struct IsUnilateral<Kind, std::void_t<decltype(Kind::UNILATERAL)>>
  : std::bool_constant<Kind::UNILATERAL>
{
};

/// A kind that holds one particle off the world (a surface, an obstacle) declares `static
/// constexpr bool PARTICLE_CONTACT = true` and gives `particle`, `friction`, `restitution`,
/// contactFrame() and penetration(): the contact stage treats every such kind alike.
template <class Kind, class = void>
struct IsParticleContact : std::false_type
{
};
template <class Kind>
struct IsParticleContact<Kind, std::void_t<decltype(Kind::PARTICLE_CONTACT)>>
  : std::bool_constant<Kind::PARTICLE_CONTACT>
{
};

/// Particles the rows touch.
inline std::array<int, 1> rowParticles(const SurfaceContact& contact)
{
  return { { contact.particle } };
}

/// x's component in the plane normal to `normal` (not unit) [x's unit].
inline Vec3 tangentialPart(const Vec3& normal, const Vec3& x)
{
  return x - normal * (normal.dot(x) / normal.squaredNorm());
}

/// The contact's frame at (x, y): the row's Jacobian (-Z_x, -Z_y, 1) [1], C and Jdot v.
struct ContactFrame
{
  Vec3 normal;       ///< J of the row, not unit: |f_n| = lambda_n |normal| [N]
  double gap = 0.0;  ///< C = z - Z [m]
  /// Cddot - J a [m/s^2]: Jdot v, and on a moving obstacle the terms of its motion
  double curvature_term = 0.0;
  /// The velocity of the obstacle's point at the particle [m/s] (0 on a fixed one): speeds that
  /// decide touching, sliding and impacts are relative to it, and the row's dC/dt is
  /// -normal . surface_velocity
  Vec3 surface_velocity = Vec3::Zero();
  /// What the particle must accelerate by to stay on the obstacle's point, less its normal part
  /// there [m/s^2]: a_o + omega x (v - v_o) + omega x w (0 on a fixed obstacle); a sticking
  /// contact's friction supplies its tangential part
  Vec3 surface_acceleration = Vec3::Zero();

  /// v relative to the obstacle's point under the particle [m/s]
  Vec3 relative(const Vec3& v) const
  {
    return v - surface_velocity;
  }
  /// The row's dC/dt at fixed positions [m/s]
  double timeRate() const
  {
    return -normal.dot(surface_velocity);
  }

  /// v's component in the tangent plane [m/s]
  Vec3 tangential(const Vec3& v) const
  {
    return tangentialPart(normal, v);
  }
  /// the speed along the unit normal, > 0 leaving the surface [m/s]
  double normalSpeed(const Vec3& v) const
  {
    return normal.dot(v) / normal.norm();
  }
};

/// The frame of `contact` at positions p [m], velocities v [m/s]. Stateless.
inline ContactFrame contactFrame(const SurfaceContact& contact, const EffectContext& context,
                                 const Points& positions, const Points& velocities)
{
  const std::vector<Surface>& surfaces = context.surfaces;
  const double* p = positions.data() + 3 * contact.particle;
  const double* v = velocities.data() + 3 * contact.particle;
  const SurfaceSample s = evaluateSurface(surfaces[contact.surface], p[0], p[1]);
  ContactFrame f;
  f.normal = Vec3(-s.zx, -s.zy, 1.0);
  f.gap = p[2] - s.z;
  f.curvature_term = -(s.zxx * v[0] * v[0] + 2.0 * s.zxy * v[0] * v[1] + s.zyy * v[1] * v[1]);
  return f;
}

/// A particle contact's row at (p, v) as if active, from its kind's contactFrame() (the contact
/// stage zeroes it when off): J = the frame's normal, C = its gap, Jdot v its curvature term.
template <typename Contact>
void evaluateContactRow(const Contact& contact, const EffectContext& context,
                        const Points& positions, const Points& velocities, RowBlock out)
{
  const ContactFrame f = contactFrame(contact, context, positions, velocities);
  out.jacobian[0] = f.normal;
  out.value[0] = f.gap;
  out.jdot_v[0] = f.curvature_term;
  out.violation[0] = std::abs(f.gap);
  if (out.time_rate)
    out.time_rate[0] = f.timeRate();
}

/// A particle contact on or in what it keeps out of: its approach speed max(0, -Cdot) [m/s];
/// clear of it, 0 (it may leave).
template <typename Contact>
void contactViolationRate(const Contact& contact, const EffectContext& context,
                          const Points& positions, const Points& velocities, double* rates)
{
  const ContactFrame f = contactFrame(contact, context, positions, velocities);
  rates[0] = f.gap > 0.0
                 ? 0.0
                 : std::max(0.0, -f.normal.dot(f.relative(velocities.col(contact.particle))));
}

/// The row at (p, v) as if active (the contact stage zeroes it when off). Stateless.
inline void evaluateRows(const SurfaceContact& contact, const EffectContext& context,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  evaluateContactRow(contact, context, positions, velocities, out);
}

/// Geometric stiffness (stability.hpp): a surface row's (C is minus its, the Hessian's size alike).
inline void addGeometricStiffness(const SurfaceContact& contact, const EffectContext& context,
                                  const Points& positions, const double* multipliers,
                                  double* stiffness)
{
  addGeometricStiffness(SurfaceConstraint{ contact.particle, contact.surface }, context, positions,
                        multipliers, stiffness);
}

/// On or below the surface, the approach speed max(0, -Cdot) [m/s]; above it, 0 (it may fall).
inline void violationRates(const SurfaceContact& contact, const EffectContext& context,
                           const Points& positions, const Points& velocities, double* rates)
{
  contactViolationRate(contact, context, positions, velocities, rates);
}

/// How far below the surface the particle is, max(0, -C) [m]: a contact's position error
/// whether its row acts or not.
inline double penetration(const SurfaceContact& contact, const EffectContext& context,
                          const Points& positions)
{
  const Vec3 p = positions.col(contact.particle);
  return std::max(0.0, evaluateSurface(context.surfaces[contact.surface], p.x(), p.y()).z - p.z());
}

/// @throws InvalidInput naming the bad field
inline void validate(const SurfaceContact& contact, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(contact, num_particles, num_surfaces, prefix, allow_unset);
}

}  // namespace constrained_particles
