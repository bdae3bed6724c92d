#include "constrained_particles/ros/parameters.hpp"

#include "constrained_particles/core/integrators.hpp"

#include <ros/package.h>

#include <algorithm>
#include <cmath>
#include <type_traits>

namespace constrained_particles
{
namespace
{
// The value of ~name into `value` if the parameter is set; true if it was. A value of the wrong
// type is refused, not ignored.
template <typename T>
bool readParameter(const ros::NodeHandle& nh, const std::string& name, T& value)
{
  if (!nh.hasParam(name))
    return false;
  if constexpr (std::is_same_v<T, double>)
  {
    // integers written without a decimal point are numbers too
    int as_int = 0;
    if (nh.getParam(name, value))
      return true;
    if (nh.getParam(name, as_int))
    {
      value = as_int;
      return true;
    }
    throw InvalidInput("~" + name, "has the wrong type, must be a number");
  }
  else if constexpr (std::is_same_v<T, int>)
  {
    // roscpp's getParam rounds a double to an int silently (1.5 -> 2): read the value as it is
    XmlRpc::XmlRpcValue raw;
    nh.getParam(name, raw);
    if (raw.getType() == XmlRpc::XmlRpcValue::TypeInt)
      value = static_cast<int>(raw);
    else if (raw.getType() == XmlRpc::XmlRpcValue::TypeDouble)
    {
      const double number = static_cast<double>(raw);
      if (!(number == std::floor(number) && std::abs(number) < 2e9))
        throw InvalidInput("~" + name, "= " + formatValue(number) + ", must be a whole number");
      value = static_cast<int>(number);
    }
    else
      throw InvalidInput("~" + name, "has the wrong type, must be an integer");
    return true;
  }
  else if constexpr (std::is_same_v<T, Stabilization>)
  {
    std::string text;
    if (!nh.getParam(name, text))
      throw InvalidInput("~" + name, "has the wrong type, must be a string");
    value = parseStabilization(text, "~" + name);
    return true;
  }
  else
  {
    if (!nh.getParam(name, value))
      throw InvalidInput("~" + name, std::string("has the wrong type, must be ") +
                                         (std::is_same_v<T, bool> ? "a boolean" : "a string"));
    return true;
  }
}

// reads `name` into an optional only if it is set
template <typename T>
void readOptional(const ros::NodeHandle& nh, const std::string& name, std::optional<T>& out)
{
  T value{};
  if (readParameter(nh, name, value))
    out = value;
}

// Reads every described field of `record` that is set as ~<name>; returns the names read.
template <typename Record>
std::vector<std::string> readFields(const ros::NodeHandle& nh, Record& record)
{
  std::vector<std::string> read;
  forEachField<Record>(
      [&](const auto& spec)
      {
        if (readParameter(nh, spec.name, record.*(spec.member)))
          read.push_back(spec.name);
      });
  return read;
}

// the core names fields without "~"; parameters are private, so say so
template <typename Fn>
void asParameter(const std::string& prefix, Fn fn)
{
  try
  {
    fn();
  }
  catch (const InvalidInput& e)
  {
    const std::string message = e.what();
    throw InvalidInput("~" + prefix + e.field(), message.substr(e.field().size() + 1));
  }
}

}  // namespace

std::vector<std::string> SceneOverrides::applyTo(SceneDescription& description) const
{
  std::vector<std::string> skipped;
  if (num_particles || link_length || particle_mass || pin_first)
  {
    if (description.chains.empty())
    {
      skipped.push_back("~chain/* ignored: scene '" + description.name + "' has no chain");
    }
    else
    {
      const ChainSpec& first = description.chains.front();
      ChainChange chain;
      chain.num_particles = num_particles.value_or(first.particles);
      chain.link_length = link_length.value_or(first.link_length);
      chain.particle_mass = particle_mass.value_or(first.particle_mass);
      chain.pin_first = pin_first;
      setChains(description, chain);
    }
  }
  if (surface)
  {
    if (description.surfaces.empty())
      skipped.push_back("~surface/* ignored: scene '" + description.name + "' has no surface");
    else
      setFirstSurface(description, *surface);
  }
  if (gravity || damping)
    setGravityAndDamping(description, gravity.value_or(sceneGravity(description)),
                         damping.value_or(sceneDamping(description)));
  return skipped;
}

const Range* settingRange(const std::string& name)
{
  const Range* found = nullptr;
  auto look = [&](const auto& spec)
  {
    if (name == spec.name && spec.kind == FieldKind::Number)
      found = spec.range;
  };
  forEachField<StepSettings>(look);
  forEachField<NodeParameters>(look);
  if (name == "damping")
    return &limits::DAMPING;
  if (name == "gravity" || name == "gravity_x" || name == "gravity_y" || name == "gravity_z")
    return &limits::GRAVITY;
  if (name == "chain/num_particles")
    return &limits::PARTICLES;
  if (name == "chain/link_length")
    return &limits::LINK_LENGTH;
  if (name == "chain/particle_mass")
    return &limits::MASS;
  return found;
}

int tfFrameCount(int particles, int tf_frames)
{
  return tf_frames < 0 ? std::min(particles, limits::DEFAULT_TF_FRAMES)
                       : std::min(particles, tf_frames);
}

NodeParameters readParameters(const ros::NodeHandle& nh)
{
  NodeParameters p;
  p.step_given = readFields(nh, p.step);
  readFields(nh, p);
  if (p.scene_directory.empty())
    p.scene_directory = ros::package::getPath("constrained_particles") + "/config/scenes";

  SceneOverrides& o = p.overrides;
  if (nh.hasParam("gravity"))
  {
    std::vector<double> gravity;
    if (!nh.getParam("gravity", gravity) || gravity.size() != 3)
      throw InvalidInput("~gravity", "must be a list of 3 numbers [m/s^2]");
    o.gravity = Vec3(gravity[0], gravity[1], gravity[2]);
  }
  readOptional(nh, "damping", o.damping);
  readOptional(nh, "chain/num_particles", o.num_particles);
  readOptional(nh, "chain/link_length", o.link_length);
  readOptional(nh, "chain/particle_mass", o.particle_mass);
  readOptional(nh, "chain/pin_first", o.pin_first);
  if (nh.hasParam("surface/type") || nh.hasParam("surface/coefficients") ||
      nh.hasParam("surface/expression"))
  {
    std::string surface_type = "bowl";
    std::vector<double> coefficients;
    readParameter(nh, "surface/type", surface_type);
    if (nh.hasParam("surface/coefficients") && !nh.getParam("surface/coefficients", coefficients))
      throw InvalidInput("~surface/coefficients", "must be a list of numbers");
    std::string formula;
    readParameter(nh, "surface/expression", formula);
    asParameter("",
                [&]
                {
                  const SurfaceType type = parseSurfaceType(surface_type, "surface/type");
                  o.surface = type == SurfaceType::Expression
                                  ? makeExpressionSurface(formula, "surface/expression")
                                  : makeSurface(type, coefficients, "surface/coefficients");
                });
  }
  validateNodeParameters(p);
  return p;
}

void validateNodeParameters(const NodeParameters& p)
{
  if (p.scenario.empty())
    throw InvalidInput("~scenario", "is empty; give a scene name or a scene file path");
  asParameter("", [&] { validateStepSettings(p.step); });
  asParameter("", [&] { validateFields(p, 0, 0, ""); });
  const SceneOverrides& o = p.overrides;
  if (o.gravity)
    requireInRange("~gravity", *o.gravity, limits::GRAVITY);
  if (o.damping)
    requireInRange("~damping", *o.damping, limits::DAMPING);
  // the ~set_chain checks, with valid stand-ins for the fields not set
  ChainChange chain;
  chain.num_particles = o.num_particles.value_or(1);
  chain.link_length = o.link_length.value_or(chain.link_length);
  chain.particle_mass = o.particle_mass.value_or(chain.particle_mass);
  validateChainChange(chain, p.max_particles, "~chain/");
  if (p.fixed_frame.empty() || p.fixed_frame.front() == '/')
    throw InvalidInput("~fixed_frame", "= '" + p.fixed_frame +
                                           "', must be a non-empty frame id without a leading '/'");
  if (p.frame_prefix.empty() || p.frame_prefix.front() == '/')
    throw InvalidInput("~frame_prefix",
                       "= '" + p.frame_prefix + "', must be non-empty without a leading '/'");
  if (p.follow_clock && p.publish_clock)
    throw InvalidInput("~follow_clock",
                       "= true with ~publish_clock = true: a node follows /clock "
                       "or publishes it, not both");
}

SceneInputs sceneInputs(const NodeParameters& parameters)
{
  SceneInputs inputs;
  inputs.robot_description = parameters.robot_description;
  inputs.files.package_path = [](const std::string& package)
  { return ros::package::getPath(package); };
  return inputs;
}

}  // namespace constrained_particles
