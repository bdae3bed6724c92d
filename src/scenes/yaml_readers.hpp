/// @file yaml_readers.hpp
/// @brief The scene files' YAML readers, shared by scene_file.cpp and shape_file.cpp: where a
/// value sits ("file:line: key.path") for every message, the checked scalar, vector and name
/// readers, and the record fields read through the core's field descriptors. yaml-cpp parses (a
/// well-kept YAML parser). Private to the scenes library.
#pragma once

#include "constrained_particles/scenes/scene_file.hpp"

#include "constrained_particles/core/integrators.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <string>
#include <type_traits>
#include <vector>

namespace constrained_particles
{
namespace scene_yaml
{
// Where a value sits: "file:line: key.path", for every message.
struct Where
{
  const std::string& source;
  std::string key;

  std::string at(const YAML::Node& node) const
  {
    const int line = node.Mark().line;
    return source + (line >= 0 ? ":" + std::to_string(line + 1) : "") + ": " + key;
  }
  Where operator/(const std::string& child) const
  {
    return Where{ source, key.empty() ? child : key + "." + child };
  }
  Where operator[](std::size_t index) const
  {
    return Where{ source, key + "[" + std::to_string(index) + "]" };
  }
};

[[noreturn]] inline void fail(const Where& where, const YAML::Node& node, const std::string& reason)
{
  throw InvalidInput(where.at(node), reason);
}

// A core refusal ("dt = 0, must be ...") rethrown at the place in the file it came from
[[noreturn]] inline void failAt(const Where& where, const YAML::Node& node,
                                const InvalidInput& error)
{
  const std::string message = error.what();
  fail(where / error.field(), node, message.substr(error.field().size() + 1));
}

inline std::string joined(const std::vector<std::string>& names)
{
  std::string text;
  for (const auto& name : names)
    text += (text.empty() ? "" : ", ") + name;
  return text;
}

inline void requireMap(const Where& where, const YAML::Node& node, const std::string& what)
{
  if (!node.IsMap())
    fail(where, node, "must be a map (key: value) describing " + what);
}

inline void requireSequence(const Where& where, const YAML::Node& node, const std::string& what)
{
  if (!node.IsSequence())
    fail(where, node, "must be a list of " + what);
}

// every key of a map must be one of `known`
inline void checkKeys(const Where& where, const YAML::Node& map,
                      const std::vector<std::string>& known, const std::string& what)
{
  std::vector<std::string> seen;
  for (const auto& entry : map)
  {
    const std::string key = entry.first.as<std::string>();
    if (std::find(known.begin(), known.end(), key) == known.end())
      fail(where / key, entry.first, "is not a key of " + what + "; valid keys: " + joined(known));
    // YAML forbids it and yaml-cpp would keep one value silently: refuse it
    if (std::find(seen.begin(), seen.end(), key) != seen.end())
      fail(where / key, entry.first, "appears twice in " + what);
    seen.push_back(key);
  }
}

// a scalar as T; anything yaml-cpp cannot convert is refused with `expected`
template <typename T>
T readScalar(const Where& where, const YAML::Node& node, const char* expected)
{
  try
  {
    if (node.IsScalar())
      return node.as<T>();
  }
  catch (const YAML::Exception&)
  {
  }
  fail(where, node, expected);
}

inline double readDouble(const Where& where, const YAML::Node& node)
{
  return readScalar<double>(where, node, "must be a number");
}

inline int readInt(const Where& where, const YAML::Node& node)
{
  return readScalar<int>(where, node, "must be an integer");
}

inline bool readBool(const Where& where, const YAML::Node& node)
{
  return readScalar<bool>(where, node, "must be true or false");
}

inline std::string readString(const Where& where, const YAML::Node& node)
{
  if (!node.IsScalar())
    fail(where, node, "must be a string");
  return node.as<std::string>();
}

inline Vec3 readVector(const Where& where, const YAML::Node& node)
{
  if (!node.IsSequence() || node.size() != 3)
    fail(where, node, "must be a list of 3 numbers [x, y, z]");
  return Vec3(readDouble(where[0], node[0]), readDouble(where[1], node[1]),
              readDouble(where[2], node[2]));
}

// The index of the entry `node` names among `entries` (each with a `name`), which the scene
// defines under `key` as `what`s
template <typename Named>
int nameIndex(const Where& where, const YAML::Node& node, const std::vector<Named>& entries,
              const std::string& what, const std::string& key)
{
  if (node.IsScalar())
  {
    const std::string name = node.as<std::string>();
    for (std::size_t k = 0; k < entries.size(); ++k)
      if (entries[k].name == name)
        return static_cast<int>(k);
  }
  std::vector<std::string> names;
  for (const Named& entry : entries)
    names.push_back(entry.name);
  fail(where, node,
       "must name a " + what + " of this scene" +
           (names.empty() ? " (it defines none under '" + key + "')"
                          : "; defined: " + joined(names)));
}

inline int surfaceIndex(const Where& where, const YAML::Node& node,
                        const std::vector<NamedSurface>& surfaces)
{
  return nameIndex(where, node, surfaces, "surface", "surfaces");
}

inline int shapeIndex(const Where& where, const YAML::Node& node, const std::vector<Shape>& shapes)
{
  return nameIndex(where, node, shapes, "shape", "shapes");
}

// The keys of a record kind, in the order its fields() lists them.
template <typename Record>
std::vector<std::string> fieldNames()
{
  std::vector<std::string> names;
  forEachField<Record>([&](const auto& spec) { names.push_back(spec.name); });
  return names;
}

// Reads every field of `record` the map gives, by its member's type; validation is the
// descriptors' (validateFields) and comes after.
template <typename Record>
void readFields(const Where& where, const YAML::Node& node, Record& record,
                const SceneDescription& scene)
{
  const std::vector<NamedSurface>& surfaces = scene.surfaces;
  forEachField<Record>(
      [&](const auto& spec)
      {
        const YAML::Node value = node[spec.name];
        if (!value)
          return;
        auto& member = record.*(spec.member);
        using Member = std::decay_t<decltype(member)>;
        const Where at = where / spec.name;
        if constexpr (std::is_same_v<Member, Vec3>)
          member = readVector(at, value);
        else if constexpr (std::is_same_v<Member, int>)
          member = spec.kind == FieldKind::Surface ? surfaceIndex(at, value, surfaces)
                                                   : readInt(at, value);
        else if constexpr (std::is_same_v<Member, double>)
          member = readDouble(at, value);
        else if constexpr (std::is_same_v<Member, bool>)
          member = readBool(at, value);
        else if constexpr (std::is_same_v<Member, std::string>)
          member = readString(at, value);
        else if constexpr (std::is_same_v<Member, Shape>)
          member = scene.shapes[shapeIndex(at, value, scene.shapes)];
        else if constexpr (std::is_same_v<Member, std::vector<std::string>>)
        {
          // a list of names (a chain's obstacles), each resolved where it is used
          if (!value.IsSequence())
            fail(at, value, "must be a list of names");
          member.clear();
          for (std::size_t k = 0; k < value.size(); ++k)
            member.push_back(readString(at[k], value[k]));
        }
        else if constexpr (std::is_same_v<Member, Stabilization>)
          member = parseStabilization(readString(at, value), at.at(value));
        else
        {
          // a fixed-size list of particle indices
          if (!value.IsSequence() || value.size() != member.size())
            fail(at, value,
                 "must be a list of " + std::to_string(member.size()) + " particle indices");
          for (std::size_t k = 0; k < member.size(); ++k)
            member[k] = readInt(at[k], value[k]);
        }
      });
}

/// A surface under `surfaces`: its type and the keys that type reads.
/// @throws InvalidInput at `where`, naming the key and what is valid
Surface parseSurface(const Where& where, const YAML::Node& node);

/// An obstacle under `shapes` named `name`: its type, then the keys that type reads, each in its
/// range; a mesh's `file` found by `files` and read (mesh_file.hpp). @throws InvalidInput at
/// `where`, naming the key and its valid range
Shape parseShape(const Where& where, const YAML::Node& node, const std::string& name,
                 const FileResolver& files = {});

}  // namespace scene_yaml
}  // namespace constrained_particles
