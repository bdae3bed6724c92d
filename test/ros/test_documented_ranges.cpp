// Every range is written once (limits.hpp) and every other place that shows it agrees:
// cfg/Simulator.cfg (dynamic_reconfigure's min, max, default and enums, read from the generated
// SimulatorConfig), docs/node.md's parameter table, config/default.yaml's comments and the service
// definitions in srv/. No ROS master: these read the generated code and the files.
#include "constrained_particles/SimulatorConfig.h"
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/core/surface.hpp"
#include "constrained_particles/core/limits.hpp"
#include "constrained_particles/ros/parameters.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <regex>
#include <sstream>

using namespace constrained_particles;

namespace
{
std::string readFile(const std::string& path)
{
  std::ifstream file(path);
  EXPECT_TRUE(file.good()) << path;
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

// a setting's default as the structs hold it (NaN if it has none there)
double structDefault(const std::string& name)
{
  double value = NAN;
  auto look = [&](const auto& defaults)
  {
    return [&](const auto& spec)
    {
      using Member = typename std::decay_t<decltype(spec)>::MemberType;
      if constexpr (std::is_same_v<Member, double> || std::is_same_v<Member, int>)
        if (name == spec.name)
          value = defaults.*(spec.member);
    };
  };
  forEachField<StepSettings>(look(StepSettings{}));
  forEachField<NodeParameters>(look(NodeParameters{}));
  return value;
}

// the `value`s of a dynamic_reconfigure enum (its edit_method, a Python dict as text)
std::vector<std::string> enumValues(const std::string& edit_method)
{
  std::vector<std::string> values;
  const std::regex value("'value': '([^']*)'");
  for (auto it = std::sregex_iterator(edit_method.begin(), edit_method.end(), value);
       it != std::sregex_iterator(); ++it)
    values.push_back((*it)[1]);
  return values;
}

}  // namespace

TEST(DocumentedRanges, ReconfigureRangesAreTheLimits)
{
  const dynamic_reconfigure::ConfigDescription description =
      SimulatorConfig::__getDescriptionMessage__();
  std::map<std::string, double> min, max, defaults;
  for (const auto& p : description.min.doubles)
    min[p.name] = p.value;
  for (const auto& p : description.max.doubles)
    max[p.name] = p.value;
  for (const auto& p : description.dflt.doubles)
    defaults[p.name] = p.value;
  ASSERT_FALSE(min.empty());
  for (const auto& [name, low] : min)
  {
    SCOPED_TRACE(name);
    const Range* range = settingRange(name);
    ASSERT_NE(range, nullptr) << "a reconfigurable number with no range in limits.hpp";
    // dynamic_reconfigure has closed ranges only: an open end could not be shown there
    EXPECT_FALSE(range->low_open);
    EXPECT_EQ(low, range->low);
    EXPECT_EQ(max[name], range->high);
    EXPECT_TRUE(range->contains(defaults[name]));
    if (!std::isnan(structDefault(name)))
    {
      EXPECT_EQ(defaults[name], structDefault(name));
    }
  }
  int enums = 0;
  for (const auto& group : description.groups)
    for (const auto& parameter : group.parameters)
    {
      if (parameter.name == "integrator")
      {
        EXPECT_EQ(enumValues(parameter.edit_method), integratorNames());
        ++enums;
      }
      if (parameter.name == "stabilization")
      {
        EXPECT_EQ(enumValues(parameter.edit_method), stabilizationNames());
        ++enums;
      }
    }
  EXPECT_EQ(enums, 2);
}

TEST(DocumentedRanges, NodeDocParameterTableShowsTheLimits)
{
  const std::string doc = readFile(NODE_DOC_PATH);
  const std::size_t start = doc.find("### Parameters");
  ASSERT_NE(start, std::string::npos);
  const std::string section = doc.substr(start, doc.find("\n## ", start) - start);
  // | `name` | type | unit | default | range | R/S |
  const std::regex row(R"(\| `([a-z_/]+)` \|[^|]*\| *([^|]*?) *\|[^|]*\| *([^|]*?) *\|)");
  std::map<std::string, std::pair<std::string, std::string>> rows;
  for (auto it = std::sregex_iterator(section.begin(), section.end(), row);
       it != std::sregex_iterator(); ++it)
    rows[(*it)[1]] = { (*it)[2], (*it)[3] };
  int checked = 0;
  auto check = [&](const std::string& name)
  {
    SCOPED_TRACE(name);
    ASSERT_EQ(rows.count(name), 1u) << "docs/node.md's parameter table has no row for ~" << name;
    const Range* range = settingRange(name);
    if (range == nullptr)
      return;
    const auto& [unit, text] = rows[name];
    EXPECT_EQ(text.rfind(range->interval(), 0), 0u)
        << "docs/node.md says '" << text << "', limits.hpp " << range->interval();
    EXPECT_TRUE(unit == range->unit || (std::string(range->unit) == "1" && unit.empty()))
        << "docs/node.md's unit '" << unit << "', limits.hpp " << range->unit;
    ++checked;
  };
  forEachField<StepSettings>([&](const auto& spec) { check(spec.name); });
  forEachField<NodeParameters>([&](const auto& spec) { check(spec.name); });
  for (const char* name : { "damping", "gravity", "chain/link_length", "chain/particle_mass" })
    check(name);
  EXPECT_GT(checked, 15);
  // the integrator row lists the table
  for (const std::string& name : integratorNames())
    EXPECT_NE(rows["integrator"].second.find("`" + name + "`"), std::string::npos) << name;
}

TEST(DocumentedRanges, DefaultYamlCommentsShowTheLimits)
{
  const std::string yaml = readFile(DEFAULT_YAML_PATH);
  int checked = 0;
  auto check = [&](const std::string& key, const std::string& name)
  {
    SCOPED_TRACE(name);
    const Range* range = settingRange(name);
    if (range == nullptr)
      return;
    // "key: value   # ... [interval] ..." (commented out or not)
    const std::regex line("(^|\\n)#? *" + key + ": [^\\n#]*#([^\\n]*)");
    std::smatch match;
    ASSERT_TRUE(std::regex_search(yaml, match, line)) << "config/default.yaml has no " << key;
    EXPECT_NE(std::string(match[2]).find(range->interval()), std::string::npos)
        << "default.yaml says '" << match[2] << "', limits.hpp " << range->interval();
    ++checked;
  };
  forEachField<StepSettings>([&](const auto& spec) { check(spec.name, spec.name); });
  forEachField<NodeParameters>([&](const auto& spec) { check(spec.name, spec.name); });
  check("damping", "damping");
  check("gravity", "gravity");
  check("link_length", "chain/link_length");
  check("particle_mass", "chain/particle_mass");
  EXPECT_GT(checked, 15);
}

TEST(DocumentedRanges, ServiceDefinitionsShowTheLimits)
{
  const std::string chain = readFile(std::string(SRV_DIR) + "/SetChain.srv");
  EXPECT_NE(chain.find("link_length    # " + limits::LINK_LENGTH.text()), std::string::npos);
  EXPECT_NE(chain.find("particle_mass  # " + limits::MASS.text()), std::string::npos);
  const std::string step = readFile(std::string(SRV_DIR) + "/Step.srv");
  EXPECT_NE(step.find("steps     # " + limits::STEPS_PER_CALL.interval()), std::string::npos);
  const std::string force = readFile(std::string(SRV_DIR) + "/ApplyForce.srv");
  EXPECT_NE(force.find("force  # F, each component in " + limits::FORCE.interval() + " [N]"),
            std::string::npos);
  EXPECT_NE(force.find("duration             # " + limits::APPLIED_FORCE_DURATION.text()),
            std::string::npos);
  const std::string state = readFile(std::string(SRV_DIR) + "/SetState.srv");
  EXPECT_NE(state.find(limits::COORDINATE.interval()), std::string::npos);
  EXPECT_NE(state.find(limits::VELOCITY.interval()), std::string::npos);
  // every coefficient of every surface type, under its type's line
  const std::string surface = readFile(std::string(SRV_DIR) + "/SetSurface.srv");
  int coefficients = 0;
  for (const std::string& type : surfaceTypeNames())
  {
    const std::size_t at = surface.find("#   " + type + ":");
    ASSERT_NE(at, std::string::npos) << type;
    std::size_t next = std::string::npos;  // the next type's line
    for (const std::string& other : surfaceTypeNames())
    {
      const std::size_t other_at = surface.find("#   " + other + ":");
      if (other_at != std::string::npos && other_at > at)
        next = std::min(next, other_at);
    }
    const std::string section = surface.substr(at, next == std::string::npos ? next : next - at);
    for (const CoefficientSpec& spec : surfaceCoefficientSpecs(parseSurfaceType(type)))
    {
      // the section may wrap a coefficient's line: compare with the comment marks removed
      std::string flat;
      for (std::size_t k = 0; k < section.size(); ++k)
        if (section[k] == '\n')
        {
          while (k + 1 < section.size() && (section[k + 1] == '#' || section[k + 1] == ' '))
            ++k;
          flat += ' ';
        }
        else
          flat += section[k];
      EXPECT_NE(flat.find(std::string(spec.name) + " " + spec.range.text()), std::string::npos)
          << type << "." << spec.name << " should read " << spec.range.text();
      ++coefficients;
    }
  }
  EXPECT_GT(coefficients, 10);
}
