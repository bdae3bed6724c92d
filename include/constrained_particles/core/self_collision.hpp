/// @file self_collision.hpp
/// @brief Self-collision's broad phase: which link pairs of a rope (Scene::self_collisions) are
/// near enough to need a row (link_pair_contact.hpp), found in O(n) expected time with a uniform
/// grid over the links' midpoints, and each pair's share of the rope's particle balls.
#pragma once

#include "constrained_particles/core/scene.hpp"

#include <string>
#include <vector>

namespace constrained_particles
{
/// The link pairs of `collisions` that share no particle and whose capsules are within `margin`
/// [m] of touching at `positions` (3 x n [m]): |a(s*) - b(t*)| <= 2 r + margin, in a fixed
/// order (by rope, then link a, then link b), each with its `holds_*` flags set so that every
/// particle's ball against a link (or a ball) is one pair's: the link that starts at the particle
/// holds it, unless that link shares a particle with the other link (or there is none: the rope's
/// last particle), when the link that ends there does. A uniform grid of cell 2 r + margin plus
/// the longest link: each link is compared with those in its cell's 27 neighbours only.
/// @throws nothing; `collisions` must have passed validateSelfCollisions
std::vector<LinkPairContact> nearLinkPairs(const std::vector<SelfCollision>& collisions,
                                           const Points& positions, double margin);

/// @throws InvalidInput naming "self_collisions[k].<field>": a particle out of range or listed
/// twice, fewer than 2 particles, a radius out of limits::ROPE_RADIUS, a radius not
/// under half of a link (a link or slack link of `scene` between consecutive particles: two links
/// one apart would touch in a straight rope), or links of unequal length (a joint's fold is one
/// row, exact for equal links); or "constraints[k]": a listed link_pair_contact on a rope's links.
/// Consecutive particles with no link or slack link between them are not checked.
void validateSelfCollisions(const Scene& scene);

/// The margin [m] the Simulator looks ahead by at each step's start: r + 4 dt v_max, v_max the
/// fastest particle's speed [m/s], so a pair that can meet within the step (relative speed at
/// most 2 v_max, doubled for what the step's forces add) has its row before it does.
double linkPairMargin(const std::vector<SelfCollision>& collisions, const Points& velocities,
                      double dt);

}  // namespace constrained_particles
