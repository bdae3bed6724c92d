/// @file scene.hpp
/// @brief Scene (what a user describes) and State (what changes each step).
#pragma once

#include "constrained_particles/core/constraints.hpp"
#include "constrained_particles/core/forces.hpp"
#include "constrained_particles/core/surface.hpp"
#include "constrained_particles/core/types.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace constrained_particles
{
/// One rope that cannot pass through itself: its links (consecutive particles of `particles`) are
/// capsules of radius r, and no two links that share no particle come closer than 2 r
/// (link_pair_contact.hpp). The Simulator keeps a row for each pair of its links a broad phase
/// finds near (self_collision.hpp); two such ropes' links collide too (their 2 r: r_a + r_b).
struct SelfCollision
{
  std::vector<int> particles;  ///< the rope's particles in order along it (at least 2)
  double radius = 0.0;         ///< r [m], limits::ROPE_RADIUS, under half of each link
};

/// A scene: the particles and the forces and constraints acting on them — and nothing else is
/// evaluated. Plain data; Model::compile() validates it.
struct Scene
{
  std::string name;                     ///< scene name, for messages
  std::vector<double> masses;           ///< one per particle [kg], limits::MASS
  std::vector<Surface> surfaces;        ///< height fields referred to by SurfaceConstraint
  std::vector<Force> forces;            ///< applied forces
  std::vector<Constraint> constraints;  ///< rows are ordered as listed (eliminated kinds aside)
  /// ropes whose links collide with each other: their link_pair_contact records are the
  /// Simulator's to make as it finds pairs near (a scene may list none on a rope's links)
  std::vector<SelfCollision> self_collisions;
};

/// Everything that changes while simulating.
struct State
{
  Points positions;         ///< [m], 3 x n
  Points velocities;        ///< [m/s], 3 x n
  double time = 0.0;        ///< simulated time [s]
  std::uint64_t steps = 0;  ///< physics steps taken since reset
};

/// True if every position, velocity and the time are finite.
bool isFinite(const State& state);

}  // namespace constrained_particles
