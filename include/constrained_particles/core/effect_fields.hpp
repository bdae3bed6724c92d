/// @file effect_fields.hpp
/// @brief Field descriptors of effect records: each force and constraint kind lists its fields
/// once (name, member, kind, range), and validation, scene files and documentation read them.
#pragma once

#include "constrained_particles/core/limits.hpp"
#include "constrained_particles/core/shapes.hpp"
#include "constrained_particles/core/types.hpp"

#include <array>
#include <cmath>
#include <string>
#include <tuple>
#include <type_traits>
#include <variant>
#include <vector>

namespace constrained_particles
{
/// What values a field takes, and so how it is read and checked.
enum class FieldKind
{
  Number,     ///< a number (double, or int for counts) inside its range
  Particle,   ///< a particle index in [0, n)
  Particles,  ///< a fixed-size list of distinct particle indices
  Surface,    ///< an index into Scene::surfaces (a name in scene files)
  Shape,      ///< an obstacle (shapes.hpp), held by value (a name under `shapes` in scene files)
  Vector,     ///< three doubles, each inside the range
  Direction,  ///< three doubles, each inside the range, not all zero
  Name,       ///< a name: one of a table (an integrator, a stabilisation), a frame, a path
  Flag,       ///< true or false
};

/// One field of an effect record: `record.*member`.
template <typename Record, typename Member>
struct FieldSpec
{
  using RecordType = Record;  ///< the record it belongs to
  using MemberType = Member;  ///< the member's type

  const char* name;         ///< key in scene files and in error messages
  Member Record::*member;   ///< the record's member
  FieldKind kind;           ///< how it is read and validated
  const Range* range;       ///< valid values (Number, Vector, Direction), nullptr for indices
  const char* description;  ///< one line, for documentation
  /// true: may be left unset (NaN) in a scene description; the kind's fillFromStart() then
  /// computes it from the initial state (a pin's anchor: where its particle starts)
  bool from_start = false;
};

/// Builds a FieldSpec, deducing the record and member types.
template <typename Record, typename Member>
constexpr FieldSpec<Record, Member> field(const char* name, Member Record::*member, FieldKind kind,
                                          const Range* range, const char* description,
                                          bool from_start = false)
{
  return FieldSpec<Record, Member>{ name, member, kind, range, description, from_start };
}

/// Calls fn(spec) for every field of a record kind (Record::fields() returns a tuple of specs).
template <typename Record, typename Fn>
void forEachField(Fn&& fn)
{
  std::apply([&](const auto&... spec) { (fn(spec), ...); }, Record::fields());
}

/// True if the field of a from_start spec is still unset (NaN) in a description.
inline bool isUnset(double value)
{
  return std::isnan(value);
}
inline bool isUnset(const Vec3& value)
{
  return value.hasNaN();
}

namespace detail
{
inline void requireIndex(const std::string& name, int value, int count, bool surface)
{
  if (value < 0 || value >= count)
    throw InvalidInput(
        name,
        "= " + std::to_string(value) +
            (surface ? ", must index one of the " + std::to_string(count) + " surfaces"
                     : ", must be a particle index in [0, " + std::to_string(count - 1) + "]"));
}

}  // namespace detail

/// Checks every field of a record against its kind and range.
/// @param prefix field name prefix in messages, e.g. "forces[2]"
/// @param allow_unset accept NaN in from_start fields (a scene description before buildScene)
/// @throws InvalidInput naming the first bad field, its value and valid range
template <typename Record>
void validateFields(const Record& record, int num_particles, int num_surfaces,
                    const std::string& prefix, bool allow_unset = false)
{
  forEachField<Record>(
      [&](const auto& spec)
      {
        const std::string name = prefix.empty() ? spec.name : prefix + "." + spec.name;
        const auto& value = record.*(spec.member);
        using Member = std::decay_t<decltype(value)>;
        if constexpr (std::is_same_v<Member, int>)
        {
          if (spec.kind == FieldKind::Number)
            requireInRange(name, value, *spec.range);
          else
            detail::requireIndex(name, value,
                                 spec.kind == FieldKind::Surface ? num_surfaces : num_particles,
                                 spec.kind == FieldKind::Surface);
        }
        else if constexpr (std::is_same_v<Member, Shape>)
          validateShape(value, name);
        else if constexpr (std::is_same_v<Member, bool> || std::is_same_v<Member, std::string> ||
                           std::is_same_v<Member, std::vector<std::string>>)
        {
          // flags and names: any value reads as valid here; names are resolved by their reader
        }
        else if constexpr (std::is_same_v<Member, double> || std::is_same_v<Member, Vec3>)
        {
          if (spec.from_start && allow_unset && isUnset(value))
            return;
          requireInRange(name, value, *spec.range);
          if constexpr (std::is_same_v<Member, Vec3>)
            if (spec.kind == FieldKind::Direction &&
                !(value.norm() >= limits::MIN_DIRECTION_LENGTH))
              throw InvalidInput(name, "= [" + formatValue(value.x()) + ", " +
                                           formatValue(value.y()) + ", " + formatValue(value.z()) +
                                           "], must be a non-zero direction, of length at least " +
                                           formatValue(limits::MIN_DIRECTION_LENGTH));
        }
        else
        {
          // a list of particle indices, each valid, no two the same
          for (std::size_t k = 0; k < value.size(); ++k)
          {
            detail::requireIndex(name + "[" + std::to_string(k) + "]", value[k], num_particles,
                                 false);
            for (std::size_t earlier = 0; earlier < k; ++earlier)
              if (value[earlier] == value[k])
                throw InvalidInput(name + "[" + std::to_string(k) + "]",
                                   "= " + std::to_string(value[k]) + " appears twice; the " +
                                       std::to_string(value.size()) + " particles must differ");
          }
        }
      });
}

/// Throws InvalidInput naming `prefix.second` when a two-particle record joins a particle to
/// itself.
inline void requireDistinctParticles(int first, int second, const std::string& prefix)
{
  if (first == second)
    throw InvalidInput(prefix + ".second",
                       "= " + std::to_string(second) + ", must differ from first");
}

/// KIND of every alternative of a registry variant, in index order.
template <typename Variant>
struct KindNames;
template <typename... Kinds>
struct KindNames<std::variant<Kinds...>>
{
  static constexpr std::array<const char*, sizeof...(Kinds)> value{ { Kinds::KIND... } };
};

/// The KIND of the alternative a registry variant holds.
template <typename Variant>
const char* kindOf(const Variant& effect)
{
  return KindNames<Variant>::value[effect.index()];
}

}  // namespace constrained_particles
