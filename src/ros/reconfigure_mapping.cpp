#include "constrained_particles/ros/reconfigure_mapping.hpp"

#include "constrained_particles/core/integrators.hpp"

#include <dynamic_reconfigure/config_tools.h>

#include <algorithm>
#include <map>
#include <type_traits>

namespace constrained_particles
{
namespace
{
// The cfg's parameters by name, as dynamic_reconfigure's message carries them.
struct ConfigValues
{
  std::map<std::string, double> doubles;
  std::map<std::string, int> ints;
  std::map<std::string, bool> bools;
  std::map<std::string, std::string> strs;
};

ConfigValues valuesOf(const SimulatorConfig& config)
{
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  ConfigValues values;
  for (const auto& p : msg.doubles)
    values.doubles[p.name] = p.value;
  for (const auto& p : msg.ints)
    values.ints[p.name] = p.value;
  for (const auto& p : msg.bools)
    values.bools[p.name] = p.value;
  for (const auto& p : msg.strs)
    values.strs[p.name] = p.value;
  return values;
}

bool isParameter(const std::string& name)
{
  const auto& descriptions = SimulatorConfig::__getParamDescriptions__();
  return std::any_of(descriptions.begin(), descriptions.end(),
                     [&](const auto& description) { return description->name == name; });
}

// Calls fn(spec, owner) for every field of StepSettings (owner: parameters.step) and of
// NodeParameters (owner: parameters) that the cfg has a parameter for.
template <typename Parameters, typename Fn>
void forEachReconfigurable(Parameters& parameters, Fn&& fn)
{
  forEachField<StepSettings>(
      [&](const auto& spec)
      {
        if (isParameter(spec.name))
          fn(spec, parameters.step);
      });
  forEachField<NodeParameters>(
      [&](const auto& spec)
      {
        if (isParameter(spec.name))
          fn(spec, parameters);
      });
}

// A member as the cfg carries it: doubles, ints, bools, strings; a stabilisation by its name.
template <typename Member>
void append(dynamic_reconfigure::Config& msg, const std::string& name, const Member& value)
{
  if constexpr (std::is_same_v<Member, Stabilization>)
    dynamic_reconfigure::ConfigTools::appendParameter(msg, name,
                                                      std::string(stabilizationName(value)));
  else
    dynamic_reconfigure::ConfigTools::appendParameter(msg, name, value);
}

// The request's value of `name` into `member` if it differs from the shown one.
template <typename Member>
void takeChanged(const ConfigValues& shown, const ConfigValues& requested, const std::string& name,
                 Member& member)
{
  auto changed = [](const auto& a, const auto& b) { return !(a == b); };
  if constexpr (std::is_same_v<Member, double>)
  {
    if (changed(requested.doubles.at(name), shown.doubles.at(name)))
      member = requested.doubles.at(name);
  }
  else if constexpr (std::is_same_v<Member, int>)
  {
    if (changed(requested.ints.at(name), shown.ints.at(name)))
      member = requested.ints.at(name);
  }
  else if constexpr (std::is_same_v<Member, bool>)
  {
    if (changed(requested.bools.at(name), shown.bools.at(name)))
      member = requested.bools.at(name);
  }
  else if constexpr (std::is_same_v<Member, Stabilization>)
  {
    if (changed(requested.strs.at(name), shown.strs.at(name)))
      member = parseStabilization(requested.strs.at(name), name);
  }
  else
  {
    static_assert(std::is_same_v<Member, std::string>, "a cfg parameter of another type");
    if (changed(requested.strs.at(name), shown.strs.at(name)))
      // the one string field the cfg sets: parsed as ~integrator is, to the table's name
      member = name == "integrator" ? std::string(findIntegrator(requested.strs.at(name)).name)
                                    : requested.strs.at(name);
  }
}
}  // namespace

SimulatorConfig configFrom(const NodeParameters& parameters, const SceneDescription& scene)
{
  dynamic_reconfigure::Config msg;
  forEachReconfigurable(parameters, [&](const auto& spec, const auto& owner)
                        { append(msg, spec.name, owner.*spec.member); });
  const Vec3 gravity = sceneGravity(scene);
  append(msg, "gravity_x", gravity.x());
  append(msg, "gravity_y", gravity.y());
  append(msg, "gravity_z", gravity.z());
  append(msg, "damping", sceneDamping(scene));
  // value-initialised: the generated group copy (c.groups) has fields, bool ones included, that
  // no constructor sets, and copying an unset bool is undefined (UBSan stops the node on it)
  SimulatorConfig config{};
  config.__fromMessage__(msg);
  return config;
}

void applyChangedFields(const SimulatorConfig& shown, const SimulatorConfig& requested,
                        const SceneDescription& scene, NodeParameters& candidate)
{
  const ConfigValues was = valuesOf(shown), asked = valuesOf(requested);
  forEachReconfigurable(candidate, [&](const auto& spec, auto& owner)
                        { takeChanged(was, asked, spec.name, owner.*spec.member); });
  auto changed = [](const auto& a, const auto& b) { return !(a == b); };
  if (changed(requested.damping, shown.damping))
    candidate.overrides.damping = requested.damping;
  Vec3 gravity = candidate.overrides.gravity.value_or(sceneGravity(scene));
  const Vec3 wanted(requested.gravity_x, requested.gravity_y, requested.gravity_z);
  const Vec3 seen(shown.gravity_x, shown.gravity_y, shown.gravity_z);
  for (int k = 0; k < 3; ++k)
    if (changed(wanted[k], seen[k]))
      gravity[k] = wanted[k];
  if (changed(gravity, sceneGravity(scene)))
    candidate.overrides.gravity = gravity;
}

std::vector<std::string> reconfigurableFields()
{
  std::vector<std::string> names;
  NodeParameters parameters;
  forEachReconfigurable(parameters,
                        [&](const auto& spec, const auto&) { names.push_back(spec.name); });
  return names;
}

}  // namespace constrained_particles
