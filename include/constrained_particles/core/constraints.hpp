/// @file constraints.hpp
/// @brief The registry of constraint kinds, and dispatch over them.
///
/// Each kind lives in its own header under effects/. A row kind (ELIMINATED = false) makes ROWS
/// rows of the Jacobian J = dC/dp per record, each touching the record's PARTICLES particles
/// (rowParticles), through evaluateRows, violationRates and validate. An eliminated kind (a pin,
/// a driven anchor) holds one particle exactly instead: that particle gets inverse mass 0
/// (physics.md), which keeps chains tridiagonal, and the kind gives eliminatedParticle and
/// imposedMotion (position, velocity and acceleration at a time); its reaction is computed after
/// the solve. Either kind may define fillFromStart to complete itself from the initial state.
/// Adding a kind means writing its header and adding it to `Constraint` below.
#pragma once

#include "constrained_particles/core/effects/angle_constraint.hpp"
#include "constrained_particles/core/effects/collinear_constraint.hpp"
#include "constrained_particles/core/effects/frame_anchor.hpp"
#include "constrained_particles/core/effects/link_constraint.hpp"
#include "constrained_particles/core/effects/link_pair_contact.hpp"
#include "constrained_particles/core/effects/moving_anchor.hpp"
#include "constrained_particles/core/effects/pin_constraint.hpp"
#include "constrained_particles/core/effects/point_on_line.hpp"
#include "constrained_particles/core/effects/point_on_plane.hpp"
#include "constrained_particles/core/effects/segment_contact.hpp"
#include "constrained_particles/core/effects/shape_contact.hpp"
#include "constrained_particles/core/effects/slack_link.hpp"
#include "constrained_particles/core/effects/surface_constraint.hpp"
#include "constrained_particles/core/effects/surface_contact.hpp"

#include <type_traits>
#include <variant>

namespace constrained_particles
{
/// One constraint of a scene: the registry of constraint kinds.
using Constraint =
    std::variant<SurfaceConstraint, LinkConstraint, PinConstraint, AngleConstraint,
                 PointOnLineConstraint, PointOnPlaneConstraint, MovingAnchorConstraint,
                 CollinearConstraint, FrameAnchorConstraint, SurfaceContact, SlackLink,
                 ShapeContact, SegmentContact, LinkPairContact>;

/// Number of constraint kinds.
constexpr int NUM_CONSTRAINT_KINDS = static_cast<int>(std::variant_size_v<Constraint>);

/// The registry index of a constraint kind (its index in `Constraint`), at compile time.
template <typename Kind, typename... Kinds>
constexpr int indexOfKind(std::variant<Kinds...>* /*registry*/)
{
  int index = 0, found = -1;
  ((std::is_same_v<Kind, Kinds> ? (found = index, ++index) : ++index), ...);
  return found;
}
template <typename Kind>
constexpr int constraintKindIndex()
{
  return indexOfKind<Kind>(static_cast<Constraint*>(nullptr));
}

/// Largest PARTICLES of any row kind (a row's blocks fit in an array of this size).
template <typename Kind>
constexpr int particlesPerRow()
{
  if constexpr (Kind::ELIMINATED)
    return 0;
  else
    return Kind::PARTICLES;
}
template <typename... Kinds>
constexpr int maxRowParticles(std::variant<Kinds...>* /*registry*/)
{
  int most = 1;
  ((most = particlesPerRow<Kinds>() > most ? particlesPerRow<Kinds>() : most), ...);
  return most;
}
constexpr int MAX_ROW_PARTICLES = maxRowParticles(static_cast<Constraint*>(nullptr));

/// True for kinds solved by elimination (pins, driven anchors), false for row kinds.
inline bool isEliminated(const Constraint& constraint)
{
  return std::visit([](const auto& c) { return std::decay_t<decltype(c)>::ELIMINATED; },
                    constraint);
}

/// A kind whose imposed motion depends on time declares `static constexpr bool DRIVEN = true`:
/// it does work on the system (EnergyLedger books it through its reaction). Others need not say.
template <class Kind, class = void>
struct IsDriven : std::false_type
{
};
template <class Kind>
struct IsDriven<Kind, std::void_t<decltype(Kind::DRIVEN)>> : std::bool_constant<Kind::DRIVEN>
{
};

/// True for kinds that move their particle in time (driven anchors).
inline bool isDriven(const Constraint& constraint)
{
  return std::visit([](const auto& c) { return IsDriven<std::decay_t<decltype(c)>>::value; },
                    constraint);
}

/// Rows a record makes (0 for eliminated kinds).
inline int rowCount(const Constraint& constraint)
{
  return std::visit(
      [](const auto& c)
      {
        using Kind = std::decay_t<decltype(c)>;
        if constexpr (Kind::ELIMINATED)
          return 0;
        else
          return Kind::ROWS;
      },
      constraint);
}

/// Particles each of a record's rows touches, written to `out` (MAX_ROW_PARTICLES long);
/// returns how many (0 for eliminated kinds).
inline int rowParticles(const Constraint& constraint, int* out)
{
  return std::visit(
      [out](const auto& c)
      {
        using Kind = std::decay_t<decltype(c)>;
        if constexpr (Kind::ELIMINATED)
          return 0;
        else
        {
          static_assert(Kind::PARTICLES <= MAX_ROW_PARTICLES, "raise MAX_ROW_PARTICLES");
          const auto particles = rowParticles(c);
          for (int k = 0; k < Kind::PARTICLES; ++k)
            out[k] = particles[k];
          return Kind::PARTICLES;
        }
      },
      constraint);
}

/// Evaluates a row record's rows at (p, v) into `out`. Stateless. Eliminated kinds: nothing.
inline void evaluateRows(const Constraint& constraint, const EffectContext& context,
                         const Points& positions, const Points& velocities, RowBlock out)
{
  std::visit(
      [&](const auto& c)
      {
        if constexpr (!std::decay_t<decltype(c)>::ELIMINATED)
          evaluateRows(c, context, positions, velocities, out);
      },
      constraint);
}

/// |dC/dt| of each of a row record's rows in metric units [m/s]. Eliminated kinds: nothing.
inline void violationRates(const Constraint& constraint, const EffectContext& context,
                           const Points& positions, const Points& velocities, double* rates)
{
  std::visit(
      [&](const auto& c)
      {
        if constexpr (!std::decay_t<decltype(c)>::ELIMINATED)
          violationRates(c, context, positions, velocities, rates);
      },
      constraint);
}

/// The particle an eliminated record holds (-1 for row kinds).
inline int eliminatedParticle(const Constraint& constraint)
{
  return std::visit(
      [](const auto& c)
      {
        if constexpr (std::decay_t<decltype(c)>::ELIMINATED)
          return eliminatedParticle(c);
        else
          return -1;
      },
      constraint);
}

/// A kind whose motion is sampled from outside (AnchorTrack) rather than a formula of time
/// declares `static constexpr bool TRACKED = true` and an `int track` member (its index in
/// Data::tracks); its imposedMotion takes the track. Others need not say.
template <class Kind, class = void>
struct IsTracked : std::false_type
{
};
template <class Kind>
struct IsTracked<Kind, std::void_t<decltype(Kind::TRACKED)>> : std::bool_constant<Kind::TRACKED>
{
};

/// True for kinds whose motion is an AnchorTrack (frame anchors).
inline bool isTracked(const Constraint& constraint)
{
  return std::visit([](const auto& c) { return IsTracked<std::decay_t<decltype(c)>>::value; },
                    constraint);
}

/// A particle contact's (surface_contact, shape_contact) particle inside what it keeps out of:
/// the record, its particle and how deep [m].
/// True for an obstacle's contact record (shape_contact, segment_contact): what
/// Simulator::setObstacles replaces.
inline bool isObstacleContact(const Constraint& constraint)
{
  return std::holds_alternative<ShapeContact>(constraint) ||
         std::holds_alternative<SegmentContact>(constraint);
}

/// The shape an obstacle contact keeps its particle or link out of; nullptr for another kind.
inline const Shape* obstacleShape(const Constraint& constraint)
{
  if (const auto* contact = std::get_if<ShapeContact>(&constraint))
    return &contact->shape;
  if (const auto* segment = std::get_if<SegmentContact>(&constraint))
    return &segment->shape;
  return nullptr;
}
inline Shape* obstacleShape(Constraint& constraint)
{
  return const_cast<Shape*>(obstacleShape(static_cast<const Constraint&>(constraint)));
}

struct BelowSurface
{
  const Constraint* contact = nullptr;  ///< nullptr: none deeper than CONTACT_START_DEPTH
  int particle = -1;
  double depth = 0.0;
};

/// The particle contact (or link capsule, segment_contact, named by its first particle) of
/// `constraints` whose particle lies deepest inside its surface or obstacle at `positions`
/// (3 x n) [m], by more than CONTACT_START_DEPTH; particles with a zero
/// entry in `inverse_masses` (held), when given, are skipped; so are carried shapes' contacts
/// without context.carriers (where their holder will put them is not known). A scene may not
/// start one there (scenes/scene_file.cpp) nor a teleport put one there (Simulator::setState).
inline BelowSurface deepestBelowSurface(const std::vector<Constraint>& constraints,
                                        const EffectContext& context, const Points& positions,
                                        const std::vector<double>* inverse_masses = nullptr)
{
  BelowSurface deepest{ nullptr, -1, CONTACT_START_DEPTH };
  for (const Constraint& constraint : constraints)
    std::visit(
        [&](const auto& contact)
        {
          if constexpr (IsParticleContact<std::decay_t<decltype(contact)>>::value)
          {
            if constexpr (std::is_same_v<std::decay_t<decltype(contact)>, ShapeContact>)
              if (contact.shape.carried() && !context.carriers)
                return;
            const double depth = penetration(contact, context, positions);
            const bool free = !inverse_masses || (*inverse_masses)[contact.particle] > 0.0;
            if (free && depth > deepest.depth)
              deepest = { &constraint, contact.particle, depth };
          }
          else if constexpr (std::is_same_v<std::decay_t<decltype(contact)>, SegmentContact>)
          {
            // a link's capsule: named by its first particle (contactTargetText names the link)
            if (contact.shape.carried() && !context.carriers)
              return;
            const double depth = penetration(contact, context, positions);
            const bool free = !inverse_masses || (*inverse_masses)[contact.first] > 0.0 ||
                              (*inverse_masses)[contact.second] > 0.0;
            if (free && depth > deepest.depth)
              deepest = { &constraint, contact.first, depth };
          }
        },
        constraint);
  return deepest;
}

/// Where a particle contact's particle is when it is too deep, for messages: "below surface
/// 'ground'" (the name from `surface_names`, else its index) or "inside obstacle 'post' (a
/// cylinder)".
inline std::string contactTargetText(const Constraint& constraint,
                                     const std::vector<std::string>& surface_names = {})
{
  if (const auto* surface = std::get_if<SurfaceContact>(&constraint))
    return static_cast<std::size_t>(surface->surface) < surface_names.size()
               ? "below surface '" + surface_names[surface->surface] + "'"
               : "below surface " + std::to_string(surface->surface);
  if (const auto* shape = std::get_if<ShapeContact>(&constraint))
    return "inside obstacle '" + shape->shape.name + "' (a " + shapeTypeName(shape->shape.type) +
           ")";
  if (const auto* segment = std::get_if<SegmentContact>(&constraint))
    return "inside obstacle '" + segment->shape.name + "' (a " +
           shapeTypeName(segment->shape.type) + ") along its link to particle " +
           std::to_string(segment->second);
  return kindOf(constraint);
}

/// The motion one eliminated record of kind `Kind` imposes at `time` [s]; a tracked kind reads
/// tracks[record.track] (Data::tracks), and rests at its hold if `tracks` is too short.
template <typename Kind>
ImposedMotion imposedMotionOf(const Kind& record, double time,
                              const std::vector<AnchorTrack>& tracks)
{
  if constexpr (IsTracked<Kind>::value)
    return static_cast<std::size_t>(record.track) < tracks.size()
               ? imposedMotion(record, tracks[record.track], time)
               : AnchorTrack().motion(time);
  else
    return imposedMotion(record, time);
}

/// Position, velocity and acceleration an eliminated record imposes at `time` [s], tracked kinds
/// from `tracks` (Data::tracks).
inline ImposedMotion imposedMotion(const Constraint& constraint, double time,
                                   const std::vector<AnchorTrack>& tracks)
{
  return std::visit(
      [time, &tracks](const auto& c)
      {
        if constexpr (std::decay_t<decltype(c)>::ELIMINATED)
          return imposedMotionOf(c, time, tracks);
        else
          return ImposedMotion{ Vec3::Zero(), Vec3::Zero(), Vec3::Zero() };
      },
      constraint);
}

/// Kinds without their own fillFromStart have nothing to complete.
template <typename Kind>
void fillFromStart(Kind& /*constraint*/, const std::vector<Surface>& /*surfaces*/,
                   Points& /*positions*/, Points& /*velocities*/)
{
}

/// Completes a record from the initial state (unset anchors and angles) and places its
/// particles where the kind requires (on a surface). Used when scene files are built.
inline void fillFromStart(Constraint& constraint, const std::vector<Surface>& surfaces,
                          Points& positions, Points& velocities)
{
  std::visit([&](auto& c) { fillFromStart(c, surfaces, positions, velocities); }, constraint);
}

/// Throws InvalidInput if the record is malformed for the scene's particles and surfaces.
/// @param field name of the record in messages, e.g. "constraints[2]"
/// @param allow_unset accept fields left for fillFromStart (a scene description)
inline void validateConstraint(const Constraint& constraint, int num_particles, int num_surfaces,
                               const std::string& field, bool allow_unset = false)
{
  std::visit([&](const auto& c) { validate(c, num_particles, num_surfaces, field, allow_unset); },
             constraint);
}

}  // namespace constrained_particles
