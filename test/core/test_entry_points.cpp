// Every numeric setting through the core's entry points (a core call, a scene file): NaN, +-Inf,
// just below and just above its range (limits.hpp) are refused naming the field, and nothing
// changes; values on the edges of the range are accepted exactly as given, never rewritten.
// The ROS entry points (start-up parameters, services, dynamic_reconfigure) are checked the same
// way by test/ros/test_entry_points.cpp.
#include "constrained_particles/core/simulator.hpp"
#include "test_helpers.hpp"

#include "../range_values.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

using namespace constrained_particles;
using constrained_particles::testing::badValues;
using constrained_particles::testing::goodValues;

namespace
{

// a double as YAML writes it, exactly
std::string yaml(double value)
{
  if (std::isnan(value))
    return ".nan";
  if (std::isinf(value))
    return value > 0 ? ".inf" : "-.inf";
  char text[40];
  std::snprintf(text, sizeof(text), "%.17g", value);
  return text;
}

// the InvalidInput fn throws ("" if none)
template <typename Fn>
std::string refusedField(Fn fn, std::string* message = nullptr)
{
  try
  {
    fn();
  }
  catch (const InvalidInput& e)
  {
    if (message)
      *message = e.what();
    return e.field();
  }
  return "";
}

bool endsWith(const std::string& text, const std::string& end)
{
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

// a valid value of a field, for the fields not under test
template <typename Spec>
std::string validYaml(const Spec& spec, int& next_particle)
{
  using Member = typename Spec::MemberType;
  if constexpr (std::is_same_v<Member, int>)
  {
    if (spec.kind == FieldKind::Surface)
      return "ground";
    if (spec.kind == FieldKind::Number)
      return yaml(goodValues(*spec.range)[0]);
    return std::to_string(next_particle++);
  }
  else if constexpr (std::is_same_v<Member, double>)
    return yaml(goodValues(*spec.range)[1] > 2.0 ? 1.0 : goodValues(*spec.range)[1]);
  else if constexpr (std::is_same_v<Member, Vec3>)
    return "[0.5, 0.25, 0.75]";
  else if constexpr (std::is_same_v<Member, bool>)
    return "false";
  else if constexpr (std::is_same_v<Member, Shape>)
    return "ball";  // checkRecordKind's scene defines it, clear of the particles
  else if constexpr (std::is_same_v<Member, std::string>)
    // a frame_anchor names a frame or a topic, not both: the topic is left empty
    return spec.kind == FieldKind::Surface     ? "ground"
           : std::string(spec.name) == "topic" ? "''"
                                               : "x";
  else
  {
    std::string list = "[";
    for (std::size_t k = 0; k < std::tuple_size_v<Member>; ++k)
      list += (k ? ", " : "") + std::to_string(next_particle++);
    return list + "]";
  }
}

// "{type: kind, a: 1, b: [..]}" with `field` (component `axis`, -1 for a scalar) set to `value`
template <typename Kind>
std::string recordYaml(const std::string& field, int axis, double value)
{
  std::string text = std::string("{type: ") + Kind::KIND;
  int next_particle = 0;
  forEachField<Kind>(
      [&](const auto& spec)
      {
        std::string entry = validYaml(spec, next_particle);
        if (field == spec.name)
        {
          if (axis < 0)
            entry = yaml(value);
          else
          {
            Vec3 v(0.5, 0.25, 0.75);
            entry = "[";
            for (int k = 0; k < 3; ++k)
              entry += (k ? ", " : "") + (k == axis ? yaml(value) : yaml(v[k]));
            entry += "]";
          }
        }
        text += std::string(", ") + spec.name + ": " + entry;
      });
  return text + "}";
}

const char* const AXES[] = { "x", "y", "z" };

// the first force or constraint record of a description
template <typename Variant>
const Variant& firstRecord(const SceneDescription& d);
template <>
const Force& firstRecord<Force>(const SceneDescription& d)
{
  return d.forces.at(0);
}
template <>
const Constraint& firstRecord<Constraint>(const SceneDescription& d)
{
  return d.constraints.at(0);
}

// Every number and vector field of a record kind, through a scene file (key `list` of the scene,
// parsed and built): bad values refused naming the field, edge values kept exactly. The core's
// own validate() of each kind is checked field by field in test_registry.cpp.
template <typename Kind, typename Variant>
void checkRecordKind(const std::string& list, int& checked)
{
  const std::string scene_head =
      "surfaces: {ground: {type: bowl}}\n"
      "shapes: {ball: {type: sphere, position: [5, 5, 5], radius: 0.5}}\n"
      "particles: [{position: [0, 0, 0]}, {position: [1, 0, 0]}, {position: [1, 1, 0]},\n"
      "            {position: [0, 1, 1]}]\n";
  forEachField<Kind>(
      [&](const auto& spec)
      {
        using Member = std::decay_t<decltype(std::declval<Kind>().*(spec.member))>;
        if constexpr (std::is_same_v<Member, double> || std::is_same_v<Member, Vec3>)
        {
          const bool vector = std::is_same_v<Member, Vec3>;
          for (int axis = vector ? 0 : -1; axis < (vector ? 3 : 0); ++axis)
          {
            const std::string name = std::string(list) + "[0]." + spec.name +
                                     (axis >= 0 ? std::string(".") + AXES[axis] : "");
            for (double bad : badValues(*spec.range))
            {
              const std::string text =
                  scene_head + list + ":\n  - " + recordYaml<Kind>(spec.name, axis, bad) + "\n";
              std::string message;
              const std::string field =
                  refusedField([&] { buildScene(parseScene(text, "entry.yaml")); }, &message);
              EXPECT_TRUE(endsWith(field, name)) << text << " -> " << message;
              ++checked;
            }
            for (double good : goodValues(*spec.range))
            {
              const std::string text =
                  scene_head + list + ":\n  - " + recordYaml<Kind>(spec.name, axis, good) + "\n";
              std::string message;
              EXPECT_EQ(refusedField([&] { parseScene(text, "entry.yaml"); }, &message), "")
                  << text << " -> " << message;
              const SceneDescription d = parseScene(text, "entry.yaml");
              const Kind& kind = std::get<Kind>(firstRecord<Variant>(d));
              if constexpr (std::is_same_v<Member, Vec3>)
                EXPECT_EQ((kind.*(spec.member))[axis], good) << name;
              else
                EXPECT_EQ(kind.*(spec.member), good) << name;
              ++checked;
            }
          }
        }
      });
}

template <typename Variant, std::size_t... I>
void checkRegistry(const std::string& list, int& checked, std::index_sequence<I...>)
{
  (checkRecordKind<std::variant_alternative_t<I, Variant>, Variant>(list, checked), ...);
}

}  // namespace

// StepSettings through the core (validateStepSettings, Simulator::setStepSettings) and a scene
// file's `solver` section.
TEST(EntryPoints, StepSettingsAreRefusedOutsideTheirRangeAndKeptExactlyInside)
{
  const BuiltScene chain = constrained_particles::testing::shippedScene("chain");
  Simulator simulator(chain.scene, chain.initial_state, StepSettings{});
  simulator.step(10);
  int checked = 0;
  forEachField<StepSettings>(
      [&](const auto& spec)
      {
        using Member = typename std::decay_t<decltype(spec)>::MemberType;
        if constexpr (std::is_same_v<Member, double> || std::is_same_v<Member, int>)
        {
          for (double bad : badValues(*spec.range))
          {
            SCOPED_TRACE(std::string(spec.name) + " = " + yaml(bad));
            StepSettings settings;
            if constexpr (std::is_same_v<Member, int>)
            {
              // an int cannot hold NaN, infinity or a fraction: those are the scene file's to
              // refuse
              if (!std::isfinite(bad) || bad != std::floor(bad))
                continue;
              settings.*(spec.member) = static_cast<int>(bad);
            }
            else
              settings.*(spec.member) = bad;
            // a core call
            EXPECT_EQ(refusedField([&] { validateStepSettings(settings); }), spec.name);
            const State before = simulator.state();
            EXPECT_EQ(refusedField([&] { simulator.setStepSettings(settings); }), spec.name);
            EXPECT_EQ(simulator.stepSettings().*(spec.member), StepSettings{}.*(spec.member));
            EXPECT_EQ(simulator.state().positions, before.positions);
            ++checked;
          }
          for (double bad : badValues(*spec.range))
          {
            // a scene file
            const std::string text = std::string("particles: [{mass: 1}]\nsolver: {") + spec.name +
                                     ": " + yaml(bad) + "}\n";
            std::string message;
            const std::string field =
                refusedField([&] { parseScene(text, "entry.yaml"); }, &message);
            EXPECT_TRUE(endsWith(field, std::string("solver.") + spec.name)) << text << message;
            ++checked;
          }
          for (double good : goodValues(*spec.range))
          {
            SCOPED_TRACE(std::string(spec.name) + " = " + yaml(good));
            StepSettings settings;
            settings.*(spec.member) = static_cast<Member>(good);
            EXPECT_EQ(refusedField([&] { simulator.setStepSettings(settings); }), "");
            EXPECT_EQ(simulator.stepSettings().*(spec.member), good);
            const std::string text = std::string("particles: [{mass: 1}]\nsolver: {") + spec.name +
                                     ": " + yaml(good) + "}\n";
            const SceneDescription d = parseScene(text, "entry.yaml");
            EXPECT_EQ(d.solver.applyTo(StepSettings{}).*(spec.member), good);
            ++checked;
          }
          simulator.setStepSettings(StepSettings{});
        }
      });
  EXPECT_GT(checked, 60);
}

// Every number and vector field of every force and constraint kind, through scene files.
TEST(EntryPoints, EffectFieldsAreRefusedOutsideTheirRangeAndKeptExactlyInside)
{
  int checked = 0;
  checkRegistry<Force>("forces", checked, std::make_index_sequence<NUM_FORCE_KINDS>{});
  checkRegistry<Constraint>("constraints", checked,
                            std::make_index_sequence<NUM_CONSTRAINT_KINDS>{});
  EXPECT_GT(checked, 200);
}

// Particles' and chains' numbers, through scene files.
TEST(EntryPoints, ParticleAndChainFieldsAreRefusedOutsideTheirRangeAndKeptExactlyInside)
{
  int checked = 0;
  auto check = [&](const std::string& list, const auto& record, auto spec, const std::string& other)
  {
    (void)record;
    using Member = std::decay_t<decltype(record.*(spec.member))>;
    if constexpr (std::is_same_v<Member, double> || std::is_same_v<Member, int> ||
                  std::is_same_v<Member, Vec3>)
    {
      if (spec.range == nullptr)
        return;
      const bool vector = std::is_same_v<Member, Vec3>;
      for (int axis = vector ? 0 : -1; axis < (vector ? 3 : 0); ++axis)
      {
        auto entry = [&](double value)
        {
          if (axis < 0)
            return yaml(value);
          std::string text = "[";
          for (int k = 0; k < 3; ++k)
            text += (k ? ", " : "") + (k == axis ? yaml(value) : std::string("1"));
          return text + "]";
        };
        const std::string name =
            list + "[0]." + spec.name + (axis >= 0 ? std::string(".") + AXES[axis] : "");
        for (double bad : badValues(*spec.range))
        {
          const std::string text =
              list + ":\n  - {" + other + spec.name + ": " + entry(bad) + "}\n";
          std::string message;
          const std::string field = refusedField([&] { parseScene(text, "entry.yaml"); }, &message);
          EXPECT_TRUE(endsWith(field, name)) << text << " -> " << message;
          ++checked;
        }
        for (double good : goodValues(*spec.range))
        {
          // a million-particle chain is valid, and parsing it is enough
          const std::string text =
              list + ":\n  - {" + other + spec.name + ": " + entry(good) + "}\n";
          std::string message;
          EXPECT_EQ(refusedField([&] { parseScene(text, "entry.yaml"); }, &message), "")
              << text << " -> " << message;
          ++checked;
        }
      }
    }
  };
  forEachField<ParticleSpec>([&](const auto& spec)
                             { check("particles", ParticleSpec{}, spec, ""); });
  forEachField<ChainSpec>(
      [&](const auto& spec)
      {
        // a chain of 2, unless its count is the field under test
        check("chains", ChainSpec{}, spec,
              std::string(spec.name) == "particles" ? "" : "particles: 2, ");
      });
  EXPECT_GT(checked, 80);
}
