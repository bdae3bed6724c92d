/// @file self_collision.cpp
/// @brief Self-collision's broad phase (self_collision.hpp).
#include "constrained_particles/core/self_collision.hpp"

#include "constrained_particles/core/limits.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <unordered_map>
#include <utility>

namespace constrained_particles
{
namespace
{
// A grid cell's key: its three integer coordinates packed (21 bits each; the coordinates are
// limits::COORDINATE over a cell no smaller than a radius, well inside that)
std::int64_t cellKey(std::int64_t x, std::int64_t y, std::int64_t z)
{
  constexpr std::int64_t BIAS = std::int64_t(1) << 20, MASK = (std::int64_t(1) << 21) - 1;
  return (((x + BIAS) & MASK) << 42) | (((y + BIAS) & MASK) << 21) | ((z + BIAS) & MASK);
}

}  // namespace

std::vector<LinkPairContact> nearLinkPairs(const std::vector<SelfCollision>& collisions,
                                           const Points& positions, double margin)
{
  // every rope's links in one grid: a rope's own pairs and two ropes' pairs alike
  struct Link
  {
    int rope, index;  // its rope (collisions' index) and its place along it (link k: p_k-p_k+1)
  };
  std::vector<Link> links;
  double longest = 0.0, widest = 0.0;
  for (std::size_t r = 0; r < collisions.size(); ++r)
  {
    const std::vector<int>& p = collisions[r].particles;
    widest = std::max(widest, collisions[r].radius);
    for (int k = 0; k + 1 < static_cast<int>(p.size()); ++k)
    {
      links.push_back(Link{ static_cast<int>(r), k });
      longest = std::max(longest, (positions.col(p[k + 1]) - positions.col(p[k])).norm());
    }
  }
  auto end = [&](const Link& link, int which)
  { return collisions[link.rope].particles[link.index + which]; };
  // two links within r_a + r_b + margin have midpoints within longest + that: neighbouring cells
  const double cell = longest + 2.0 * widest + margin;
  std::unordered_map<std::int64_t, std::vector<int>> grid;
  std::vector<std::array<std::int64_t, 3>> cells(links.size());
  for (std::size_t k = 0; k < links.size(); ++k)
  {
    const Vec3 middle =
        0.5 * (positions.col(end(links[k], 0)) + positions.col(end(links[k], 1))) / cell;
    cells[k] = { static_cast<std::int64_t>(std::floor(middle.x())),
                 static_cast<std::int64_t>(std::floor(middle.y())),
                 static_cast<std::int64_t>(std::floor(middle.z())) };
    grid[cellKey(cells[k][0], cells[k][1], cells[k][2])].push_back(static_cast<int>(k));
  }
  std::vector<std::pair<int, int>> found;
  for (std::size_t a = 0; a < links.size(); ++a)
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz)
        {
          const auto it = grid.find(cellKey(cells[a][0] + dx, cells[a][1] + dy, cells[a][2] + dz));
          if (it == grid.end())
            continue;
          for (const int b : it->second)
          {
            // each pair once (links are listed by rope, then along it); a rope's links sharing
            // a particle are neighbours
            if (b <= static_cast<int>(a) ||
                (links[b].rope == links[a].rope && links[b].index < links[a].index + 2))
              continue;
            const Vec3 pi = positions.col(end(links[a], 0)), pj = positions.col(end(links[a], 1));
            const Vec3 pk = positions.col(end(links[b], 0)), pl = positions.col(end(links[b], 1));
            const SegmentPairSample near = closestOnSegments(pi, pj, pk, pl);
            const Vec3 w = (1.0 - near.s) * pi + near.s * pj - (1.0 - near.t) * pk - near.t * pl;
            const double reach =
                collisions[links[a].rope].radius + collisions[links[b].rope].radius + margin;
            if (w.norm() <= reach)
              found.emplace_back(static_cast<int>(a), b);
          }
        }
  std::sort(found.begin(), found.end());
  std::vector<LinkPairContact> pairs;
  pairs.reserve(found.size());
  for (const auto& [a, b] : found)
  {
    const Link& la = links[a];
    const Link& lb = links[b];
    const int links_a = static_cast<int>(collisions[la.rope].particles.size()) - 1;
    const int links_b = static_cast<int>(collisions[lb.rope].particles.size()) - 1;
    LinkPairContact pair;
    pair.first_a = end(la, 0);
    pair.second_a = end(la, 1);
    pair.first_b = end(lb, 0);
    pair.second_b = end(lb, 1);
    // C = |a(s*) - b(t*)| - 2 r with 2 r the two ropes' radii
    pair.radius = 0.5 * (collisions[la.rope].radius + collisions[lb.rope].radius);
    pair.generated = true;
    // a particle's ball: the link starting there holds it unless it touches the other link
    // (or there is none), then the link ending there (a's start and b's are always held). Links
    // one apart on a rope (b = a + 2) fold at the joint between them, p_{a+2}: p_{a+1}'s ball
    // against b and p_{a+3}'s against link a + 1 are both that joint's angle (with the two
    // links' rows, four rows on three degrees of freedom: J W J^T singular), so the first is left
    // to the second's pair (a + 1, a + 3), where there is one. Two ropes' links share nothing.
    const int i = la.index, k = lb.index;
    if (la.rope == lb.rope)
      pair.holds_second_a =
          k == i + 2 ? !(i + 3 < links_a) : !(i + 1 < links_a && k - (i + 1) >= 2);
    else
      pair.holds_second_a = !(i + 1 < links_a);
    pair.holds_second_b = !(k + 1 < links_b);
    pairs.push_back(pair);
  }
  return pairs;
}

void validateSelfCollisions(const Scene& scene)
{
  const int n = static_cast<int>(scene.masses.size());
  // link lengths between particle pairs, from the scene's links and slack links
  std::map<std::pair<int, int>, double> lengths;
  for (const Constraint& c : scene.constraints)
  {
    if (const auto* link = std::get_if<LinkConstraint>(&c))
      lengths[std::minmax(link->first, link->second)] = link->length;
    else if (const auto* slack = std::get_if<SlackLink>(&c))
      lengths[std::minmax(slack->first, slack->second)] = slack->length;
  }
  for (std::size_t k = 0; k < scene.self_collisions.size(); ++k)
  {
    const SelfCollision& rope = scene.self_collisions[k];
    const std::string field = "self_collisions[" + std::to_string(k) + "]";
    requireInRange(field + ".radius", rope.radius, limits::ROPE_RADIUS);
    if (rope.particles.size() < 2)
      throw InvalidInput(field + ".particles",
                         "has " + std::to_string(rope.particles.size()) +
                             " particles: a rope needs at least 2 (one link)");
    std::vector<char> seen(n, 0);
    for (std::size_t i = 0; i < rope.particles.size(); ++i)
    {
      const int particle = rope.particles[i];
      const std::string at = field + ".particles[" + std::to_string(i) + "]";
      if (particle < 0 || particle >= n)
        throw InvalidInput(at, "= " + std::to_string(particle) + ", must be in [0, " +
                                   std::to_string(n - 1) + "]");
      if (seen[particle]++)
        throw InvalidInput(at, "= " + std::to_string(particle) + " appears twice in the rope");
      if (i == 0)
        continue;
      const auto length = lengths.find(std::minmax(rope.particles[i - 1], particle));
      // a joint's fold is held by one row, the ball after it against the link before: exact
      // where both links are as long (nearLinkPairs)
      const auto first = lengths.find(std::minmax(rope.particles[0], rope.particles[1]));
      if (length != lengths.end() && first != lengths.end() &&
          std::abs(length->second - first->second) > 1e-9 * first->second)
        throw InvalidInput(
            field + ".particles",
            "has links of " + formatValue(first->second) + " m and " + formatValue(length->second) +
                " m (" + std::to_string(rope.particles[i - 1]) + "-" + std::to_string(particle) +
                "): a self-colliding rope's links must be equally long");
      if (length != lengths.end() && !(2.0 * rope.radius < length->second))
        throw InvalidInput(field + ".radius",
                           "= " + formatValue(rope.radius) + " m, must be under half of the link " +
                               std::to_string(rope.particles[i - 1]) + "-" +
                               std::to_string(particle) + " (" + formatValue(length->second) +
                               " m): links one apart would overlap in a straight rope");
    }
  }
  // a pair the scene lists on a rope's links would be the simulator's row twice (or a ball held
  // by two rows): J W J^T singular once both act (its particles' range is checked with the
  // constraints, after this)
  std::vector<int> rope_of(n, -1);
  for (std::size_t k = 0; k < scene.self_collisions.size(); ++k)
    for (std::size_t i = 0; i < scene.self_collisions[k].particles.size(); ++i)
    {
      const int particle = scene.self_collisions[k].particles[i];
      if (rope_of[particle] >= 0)
        throw InvalidInput(
            "self_collisions[" + std::to_string(k) + "].particles[" + std::to_string(i) + "]",
            "= " + std::to_string(particle) + " is in rope self_collisions[" +
                std::to_string(rope_of[particle]) + "] too: a particle is on one rope");
      rope_of[particle] = static_cast<int>(k);
    }
  for (std::size_t k = 0; k < scene.constraints.size(); ++k)
    if (const auto* pair = std::get_if<LinkPairContact>(&scene.constraints[k]);
        pair && !pair->generated && pair->first_a >= 0 && pair->first_a < n && pair->first_b >= 0 &&
        pair->first_b < n && rope_of[pair->first_a] >= 0 && rope_of[pair->first_b] >= 0)
      throw InvalidInput("constraints[" + std::to_string(k) + "]",
                         "a link_pair_contact between links of ropes self_collisions[" +
                             std::to_string(rope_of[pair->first_a]) + "] and [" +
                             std::to_string(rope_of[pair->first_b]) +
                             "], whose pairs the simulator makes as they come near; remove it");
}

double linkPairMargin(const std::vector<SelfCollision>& collisions, const Points& velocities,
                      double dt)
{
  double radius = 0.0;
  for (const SelfCollision& rope : collisions)
    radius = std::max(radius, rope.radius);
  const double fastest = velocities.cols() > 0 ? velocities.colwise().norm().maxCoeff() : 0.0;
  return radius + 4.0 * dt * fastest;
}

}  // namespace constrained_particles
