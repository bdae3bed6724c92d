/// @file scene_edits.cpp
/// @brief Changes to a scene description made at run time (~set_chain, ~set_surface,
/// reconfigure's gravity and damping), checked before they touch it; split from scene_file.cpp,
/// which reads and builds the description.
#include "constrained_particles/scenes/scene_file.hpp"

#include "constrained_particles/core/effect_fields.hpp"
#include "constrained_particles/core/limits.hpp"

#include <algorithm>
#include <string>
#include <type_traits>
#include <vector>

namespace constrained_particles
{
void validateChainChange(const ChainChange& change, int max_particles, const std::string& prefix)
{
  if (change.num_particles < 1 || change.num_particles > max_particles)
    throw InvalidInput(prefix + "num_particles", "= " + std::to_string(change.num_particles) +
                                                     ", must be in [1, " +
                                                     std::to_string(max_particles) + "]");
  requireInRange(prefix + "link_length", change.link_length, limits::LINK_LENGTH);
  requireInRange(prefix + "particle_mass", change.particle_mass, limits::MASS);
}

namespace
{
/// Whether a field is a list of indices (std::array<int, N>, any N).
template <typename T>
struct IsIndexArray : std::false_type
{
};
template <std::size_t N>
struct IsIndexArray<std::array<int, N>> : std::true_type
{
};

// the largest particle index a force or constraint record of the scene names (-1 if none)
template <typename Variant>
int largestParticleIndex(const std::vector<Variant>& records)
{
  int largest = -1;
  for (const Variant& record : records)
    std::visit(
        [&](const auto& r)
        {
          forEachField<std::decay_t<decltype(r)>>(
              [&](const auto& spec)
              {
                using Member = std::decay_t<decltype(r.*(spec.member))>;
                if constexpr (std::is_same_v<Member, int>)
                {
                  if (spec.kind == FieldKind::Particle)
                    largest = std::max(largest, r.*(spec.member));
                }
                else if constexpr (IsIndexArray<Member>::value)
                {
                  if (spec.kind == FieldKind::Particles)
                    for (int index : r.*(spec.member))
                      largest = std::max(largest, index);
                }
              });
        },
        record);
  return largest;
}

}  // namespace

void setChains(SceneDescription& d, const ChainChange& change)
{
  if (d.chains.empty())
    throw InvalidInput("num_particles", "cannot be set: scene '" + d.name + "' has no chain");
  // records naming chain particles by index would silently point elsewhere after renumbering
  const int explicit_particles = static_cast<int>(d.particles.size());
  const bool count_changes =
      std::any_of(d.chains.begin(), d.chains.end(),
                  [&](const ChainSpec& c) { return c.particles != change.num_particles; });
  if (count_changes && std::max(largestParticleIndex(d.forces),
                                largestParticleIndex(d.constraints)) >= explicit_particles)
    throw InvalidInput("num_particles",
                       "= " + std::to_string(change.num_particles) + " cannot be set: scene '" +
                           d.name +
                           "' names chain particles by index in its forces or constraints, so "
                           "its chains keep their counts (link_length and particle_mass may "
                           "change)");
  // the file's region was drawn around its own chains: longer or more chains need theirs
  const bool reach_changes = std::any_of(
      d.chains.begin(), d.chains.end(),
      [&](const ChainSpec& c)
      { return c.particles != change.num_particles || c.link_length != change.link_length; });
  if (reach_changes)
    d.region.reset();
  for (ChainSpec& spec : d.chains)
  {
    spec.particles = static_cast<int>(change.num_particles);
    spec.link_length = change.link_length;
    spec.particle_mass = change.particle_mass;
    if (spec.surface.empty() && change.pin_first)
      spec.pin_first = *change.pin_first;
  }
}

void setFirstSurface(SceneDescription& d, const Surface& surface)
{
  if (d.surfaces.empty())
    throw InvalidInput("type", "cannot be set: scene '" + d.name + "' has no surface");
  d.surfaces.front().surface = surface;
}

Vec3 sceneGravity(const SceneDescription& d)
{
  for (const Force& force : d.forces)
    if (const auto* gravity = std::get_if<GravityForce>(&force))
      return gravity->acceleration;
  return Vec3::Zero();
}

double sceneDamping(const SceneDescription& d)
{
  for (const Force& force : d.forces)
    if (const auto* damping = std::get_if<LinearDampingForce>(&force))
      return damping->coefficient;
  return 0.0;
}

void setGravityAndDamping(SceneDescription& d, const Vec3& gravity, double damping)
{
  std::vector<Force> forces;
  if (!gravity.isZero(0.0))
    forces.push_back(GravityForce{ gravity });
  if (damping > 0.0)
    forces.push_back(LinearDampingForce{ damping });
  for (const Force& force : d.forces)
    if (!std::holds_alternative<GravityForce>(force) &&
        !std::holds_alternative<LinearDampingForce>(force))
      forces.push_back(force);
  d.forces = forces;
}

}  // namespace constrained_particles
