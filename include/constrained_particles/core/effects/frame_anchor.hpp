/// @file frame_anchor.hpp
/// @brief A particle held at a point that moves with an outside holder (a tf frame, a pose
/// topic), solved by elimination like a pin.
#pragma once

#include "constrained_particles/core/anchor_track.hpp"
#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/effects/row_block.hpp"

#include <string>
#include <vector>

namespace constrained_particles
{
/// Particle i held exactly at the point `offset` of a holder whose poses come from outside the
/// core: p(t), v(t), a(t) are its AnchorTrack's (Data::tracks[track]), written between steps by
/// whoever samples the holder (the node: tf frame `frame`, or PoseStamped topic `topic`).
/// Eliminated: inverse mass 0, its reaction m a(t) - f_i - (J^T lambda)_i reported like a pin's.
/// With no sample yet it rests where it starts.
struct FrameAnchorConstraint
{
  int particle = 0;              ///< particle index
  std::string frame;             ///< the holder's tf frame (or the empty string with `topic`)
  std::string topic;             ///< a geometry_msgs/PoseStamped topic instead of `frame`
  Vec3 offset{ 0.0, 0.0, 0.0 };  ///< the held point in the holder's frame [m]
  /// The largest force [N] the hold carries: a step over it is put back and reported
  /// (StepCheck::HoldForce), for the caller to let go; 0: no limit (the node fills in its own).
  double max_force = 0.0;
  int track = 0;  ///< its index in Data::tracks (Model::compile numbers them in scene order)

  static constexpr const char* KIND = "frame_anchor";
  static constexpr bool ELIMINATED = true;           ///< no rows: inverse mass 0
  static constexpr bool GALILEAN_INVARIANT = false;  ///< acts from outside (Model::isolated())
  static constexpr bool DRIVEN = true;   ///< moves in time: does work (isDriven, EnergyLedger)
  static constexpr bool TRACKED = true;  ///< its motion is Data::tracks[track], not a formula
  static constexpr auto fields()
  {
    return std::make_tuple(field("particle", &FrameAnchorConstraint::particle, FieldKind::Particle,
                                 nullptr, "particle i"),
                           field("frame", &FrameAnchorConstraint::frame, FieldKind::Name, nullptr,
                                 "the holder's tf frame, looked up in ~fixed_frame"),
                           field("topic", &FrameAnchorConstraint::topic, FieldKind::Name, nullptr,
                                 "a geometry_msgs/PoseStamped topic instead of a frame"),
                           field("offset", &FrameAnchorConstraint::offset, FieldKind::Vector,
                                 &limits::COORDINATE, "the held point in the holder's frame"),
                           field("max_force", &FrameAnchorConstraint::max_force, FieldKind::Number,
                                 &limits::HOLD_FORCE,
                                 "the largest force the hold carries before it lets go (0: "
                                 "the node's ~anchor_max_force)"));
  }
};

/// Its holder by name: the tf frame, or the pose topic.
inline const std::string& holderOf(const FrameAnchorConstraint& anchor)
{
  return anchor.frame.empty() ? anchor.topic : anchor.frame;
}

/// The particle it holds.
inline int eliminatedParticle(const FrameAnchorConstraint& anchor)
{
  return anchor.particle;
}

/// p(t), v(t), a(t): its track's.
inline ImposedMotion imposedMotion(const FrameAnchorConstraint& /*anchor*/,
                                   const AnchorTrack& track, double time)
{
  return track.motion(time);
}

/// @throws InvalidInput naming the bad field: exactly one of frame and topic is set
inline void validate(const FrameAnchorConstraint& anchor, int num_particles, int num_surfaces,
                     const std::string& prefix, bool allow_unset = false)
{
  validateFields(anchor, num_particles, num_surfaces, prefix, allow_unset);
  const std::string name = prefix.empty() ? "" : prefix + ".";
  if (anchor.frame.empty() && anchor.topic.empty())
    throw InvalidInput(name + "frame",
                       "is empty and so is topic: name the holder's tf frame, or "
                       "a geometry_msgs/PoseStamped topic");
  if (!anchor.frame.empty() && anchor.frame.front() == '/')
    throw InvalidInput(name + "frame",
                       "= '" + anchor.frame + "': tf2 frame names have no leading /");
  if (!anchor.frame.empty() && !anchor.topic.empty())
    throw InvalidInput(name + "topic", "= '" + anchor.topic + "' beside frame = '" + anchor.frame +
                                           "': give a frame or a topic, not both");
}

}  // namespace constrained_particles
