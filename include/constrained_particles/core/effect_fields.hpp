/// @file effect_fields.hpp
/// @brief Field descriptors of effect records: each force and constraint kind lists its fields
/// once (name, member, kind, unit), and validation, scene files and documentation read them.
#pragma once

#include "constrained_particles/core/types.hpp"

#include <array>
#include <string>
#include <tuple>
#include <type_traits>
#include <variant>

namespace constrained_particles
{
/// What values a field takes, and so how it is read and checked.
enum class FieldKind
{
  Real,         ///< a finite number
  NonNegative,  ///< a finite number >= 0
  Positive,     ///< a finite number > 0
  Particle,     ///< a particle index in [0, n)
  Surface,      ///< an index into Scene::surfaces (a name in scene files)
  Vector,       ///< three finite numbers
};

/// One field of an effect record: `record.*member`.
template <typename Record, typename Member>
struct FieldSpec
{
  const char* name;         ///< key in scene files and in error messages
  Member Record::*member;   ///< the record's member
  FieldKind kind;           ///< how it is read and validated
  const char* unit;         ///< SI unit, e.g. "N s/m" ("" for indices)
  const char* description;  ///< one line, for documentation
};

/// Builds a FieldSpec, deducing the record and member types.
template <typename Record, typename Member>
constexpr FieldSpec<Record, Member> field(const char* name, Member Record::*member, FieldKind kind,
                                          const char* unit, const char* description)
{
  return FieldSpec<Record, Member>{ name, member, kind, unit, description };
}

/// Calls fn(spec) for every field of a record kind (Record::fields() returns a tuple of specs).
template <typename Record, typename Fn>
void forEachField(Fn&& fn)
{
  std::apply([&](const auto&... spec) { (fn(spec), ...); }, Record::fields());
}

/// Checks every field of a record against its kind.
/// @param prefix field name prefix in messages, e.g. "forces[2]"
/// @throws InvalidInput naming the first bad field, its value and valid range
template <typename Record>
void validateFields(const Record& record, int num_particles, int num_surfaces,
                    const std::string& prefix)
{
  forEachField<Record>(
      [&](const auto& spec)
      {
        const std::string name = prefix + "." + spec.name;
        const std::string unit = std::string("[") + spec.unit + "]";
        const auto& value = record.*(spec.member);
        if constexpr (std::is_same_v<std::decay_t<decltype(value)>, Vec3>)
        {
          requireFinite(name, value, unit);
        }
        else if constexpr (std::is_same_v<std::decay_t<decltype(value)>, int>)
        {
          const int count = spec.kind == FieldKind::Surface ? num_surfaces : num_particles;
          if (value < 0 || value >= count)
            throw InvalidInput(
                name,
                "= " + std::to_string(value) +
                    (spec.kind == FieldKind::Surface
                         ? ", must index one of the " + std::to_string(count) + " surfaces"
                         : ", must be a particle index in [0, " + std::to_string(count - 1) + "]"));
        }
        else
        {
          if (spec.kind == FieldKind::Positive)
            requirePositive(name, value, unit);
          else if (spec.kind == FieldKind::NonNegative)
            requireNonNegative(name, value, unit);
          else
            requireFinite(name, value, unit);
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
