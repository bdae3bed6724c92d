#include "constrained_particles/ros/parameters.hpp"

#include "constrained_particles/ros/markers.hpp"

#include <ros/package.h>

#include <cmath>
#include <type_traits>

namespace constrained_particles
{
namespace
{
// reads `name` if set; a value of the wrong type is refused rather than ignored
template <typename T>
void readOptional(const ros::NodeHandle& nh, const std::string& name, const std::string& type,
                  T& value)
{
  if (!nh.hasParam(name))
    return;
  if (!nh.getParam(name, value))
    throw InvalidInput("~" + name, "has the wrong type, must be " + type);
}

void readDouble(const ros::NodeHandle& nh, const std::string& name, double& value);

// reads `name` into an optional only if it is set
template <typename T>
void readOptionalValue(const ros::NodeHandle& nh, const std::string& name, std::optional<T>& out)
{
  if (!nh.hasParam(name))
    return;
  T value{};
  if constexpr (std::is_same_v<T, double>)
    readDouble(nh, name, value);
  else
    readOptional(nh, name, std::is_same_v<T, bool> ? "a boolean" : "an integer", value);
  out = value;
}

void readDouble(const ros::NodeHandle& nh, const std::string& name, double& value)
{
  if (!nh.hasParam(name))
    return;
  // accept integers written without a decimal point
  int as_int = 0;
  if (nh.getParam(name, value))
    return;
  if (nh.getParam(name, as_int))
  {
    value = as_int;
    return;
  }
  throw InvalidInput("~" + name, "has the wrong type, must be a number");
}

void requireRange(const std::string& field, double value, double low, bool low_open, double high,
                  const std::string& unit)
{
  const bool below = low_open ? !(value > low) : !(value >= low);
  if (!std::isfinite(value) || below || value > high)
  {
    throw InvalidInput(field, "= " + formatValue(value) + ", must be in " + (low_open ? "(" : "[") +
                                  formatValue(low) + ", " + formatValue(high) + "] " + unit);
  }
}

// the core names fields without "~"; parameters are private, so say so
template <typename Fn>
void asParameter(Fn fn)
{
  try
  {
    fn();
  }
  catch (const InvalidInput& e)
  {
    std::string message = e.what();
    throw InvalidInput("~" + e.field(), message.substr(e.field().size() + 1));
  }
}

}  // namespace

void validateChain(const ChainParameters& chain, int max_particles, const std::string& prefix)
{
  if (chain.num_particles < 1 || chain.num_particles > max_particles)
  {
    throw InvalidInput(prefix + "num_particles", "= " + std::to_string(chain.num_particles) +
                                                     ", must be in [1, " +
                                                     std::to_string(max_particles) + "]");
  }
  requireRange(prefix + "link_length", chain.link_length, 0.0, true, 1e3, "[m]");
  requireRange(prefix + "particle_mass", chain.particle_mass, 0.0, true, 1e6, "[kg]");
}

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
      ChainParameters chain;
      chain.num_particles = num_particles.value_or(first.particles);
      chain.link_length = link_length.value_or(first.link_length);
      chain.particle_mass = particle_mass.value_or(first.particle_mass);
      chain.pin_first = pin_first.value_or(first.pin_first);
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

NodeParameters readParameters(const ros::NodeHandle& nh)
{
  NodeParameters p;
  readOptional(nh, "scenario", "a string", p.scenario);
  readDouble(nh, "dt", p.step.dt);
  p.step_set.dt = nh.hasParam("dt");
  p.step_set.integrator = nh.hasParam("integrator");
  p.step_set.stabilization = nh.hasParam("stabilization");
  readDouble(nh, "real_time_factor", p.real_time_factor);
  readDouble(nh, "publish_rate", p.publish_rate);
  readDouble(nh, "status_period", p.status_period);

  std::string name = integratorName(p.step.integrator);
  readOptional(nh, "integrator", "a string", name);
  asParameter([&] { p.step.integrator = parseIntegrator(name); });
  name = stabilizationName(p.step.stabilization);
  readOptional(nh, "stabilization", "a string", name);
  asParameter([&] { p.step.stabilization = parseStabilization(name); });
  readDouble(nh, "baumgarte_frequency", p.step.baumgarte_frequency);
  readDouble(nh, "baumgarte_damping_ratio", p.step.baumgarte_damping_ratio);
  readDouble(nh, "projection_tolerance", p.step.projection_tolerance);
  readOptional(nh, "projection_max_iterations", "an integer", p.step.projection_max_iterations);
  readDouble(nh, "adaptive_tolerance", p.step.adaptive_tolerance);

  readOptional(nh, "scene_directory", "a string", p.scene_directory);
  if (p.scene_directory.empty())
    p.scene_directory = ros::package::getPath("constrained_particles") + "/config/scenes";

  SceneOverrides& o = p.overrides;
  if (nh.hasParam("gravity"))
  {
    std::vector<double> gravity;
    if (!nh.getParam("gravity", gravity) || gravity.size() != 3)
      throw InvalidInput("~gravity", "must be a list of 3 numbers [m/s^2]");
    o.gravity = Vec3(gravity[0], gravity[1], gravity[2]);
    requireFinite("~gravity", *o.gravity, "[m/s^2]");
  }
  readOptionalValue(nh, "damping", o.damping);
  readOptionalValue(nh, "chain/num_particles", o.num_particles);
  readOptionalValue(nh, "chain/link_length", o.link_length);
  readOptionalValue(nh, "chain/particle_mass", o.particle_mass);
  readOptionalValue(nh, "chain/pin_first", o.pin_first);
  if (nh.hasParam("surface/type") || nh.hasParam("surface/coefficients") ||
      nh.hasParam("surface/expression"))
  {
    std::string surface_type = "bowl";
    std::vector<double> coefficients;
    readOptional(nh, "surface/type", "a string", surface_type);
    if (nh.hasParam("surface/coefficients") && !nh.getParam("surface/coefficients", coefficients))
      throw InvalidInput("~surface/coefficients", "must be a list of numbers");
    std::string formula;
    readOptional(nh, "surface/expression", "a string", formula);
    asParameter(
        [&]
        {
          const SurfaceType type = parseSurfaceType(surface_type, "surface/type");
          o.surface = type == SurfaceType::Expression
                          ? makeExpressionSurface(formula, "surface/expression")
                          : makeSurface(type, coefficients, "surface/coefficients");
        });
  }

  readOptional(nh, "max_particles", "an integer", p.max_particles);
  readOptional(nh, "fixed_frame", "a string", p.fixed_frame);
  readOptional(nh, "frame_prefix", "a string", p.frame_prefix);
  readDouble(nh, "force_scale", p.force_scale);
  readDouble(nh, "max_constraint_error", p.max_constraint_error);
  readOptional(nh, "mesh_cells", "an integer", p.mesh_cells);
  readOptional(nh, "publish_clock", "a boolean", p.publish_clock);
  validateNodeParameters(p);
  return p;
}

void validateNodeParameters(const NodeParameters& p)
{
  if (p.scenario.empty())
    throw InvalidInput("~scenario", "is empty; give a scene name or a scene file path");
  requireRange("~dt", p.step.dt, 0.0, true, MAX_NODE_DT, "[s]");
  asParameter([&] { validateStepSettings(p.step); });
  requireRange("~real_time_factor", p.real_time_factor, 0.0, true, 100.0, "[1]");
  requireRange("~publish_rate", p.publish_rate, 0.1, false, 1000.0, "[Hz]");
  requireRange("~status_period", p.status_period, 0.0, false, 3600.0, "[s]");
  requireRange("~max_particles", p.max_particles, 1.0, false, MAX_PARTICLES, "[1]");
  requireRange("~force_scale", p.force_scale, 0.0, true, 1e3, "[m/N]");
  requireRange("~max_constraint_error", p.max_constraint_error, 0.0, true, 1e3, "[m]");
  requireRange("~mesh_cells", p.mesh_cells, 2.0, false, MAX_MESH_CELLS, "[1]");
  const SceneOverrides& o = p.overrides;
  if (o.damping)
    requireRange("~damping", *o.damping, 0.0, false, 1e3, "[N s/m]");
  // the ~set_chain checks, with valid stand-ins for the fields not set
  ChainParameters chain;
  chain.num_particles = o.num_particles.value_or(1);
  chain.link_length = o.link_length.value_or(chain.link_length);
  chain.particle_mass = o.particle_mass.value_or(chain.particle_mass);
  validateChain(chain, p.max_particles, "~chain/");
  if (p.fixed_frame.empty() || p.fixed_frame.front() == '/')
    throw InvalidInput("~fixed_frame", "= '" + p.fixed_frame +
                                           "', must be a non-empty frame id without a leading '/'");
  if (p.frame_prefix.empty() || p.frame_prefix.front() == '/')
    throw InvalidInput("~frame_prefix",
                       "= '" + p.frame_prefix + "', must be non-empty without a leading '/'");
}

}  // namespace constrained_particles
