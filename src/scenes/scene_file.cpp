#include "constrained_particles/scenes/scene_file.hpp"

#include <Eigen/Geometry>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <dirent.h>
#include <fstream>
#include <sstream>
#include <sys/stat.h>

namespace constrained_particles
{
namespace
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

[[noreturn]] void fail(const Where& where, const YAML::Node& node, const std::string& reason)
{
  throw InvalidInput(where.at(node), reason);
}

std::string joined(const std::vector<std::string>& names)
{
  std::string text;
  for (const auto& name : names)
    text += (text.empty() ? "" : ", ") + name;
  return text;
}

void requireMap(const Where& where, const YAML::Node& node, const std::string& what)
{
  if (!node.IsMap())
    fail(where, node, "must be a map (key: value) describing " + what);
}

void requireSequence(const Where& where, const YAML::Node& node, const std::string& what)
{
  if (!node.IsSequence())
    fail(where, node, "must be a list of " + what);
}

// every key of a map must be one of `known`
void checkKeys(const Where& where, const YAML::Node& map, const std::vector<std::string>& known,
               const std::string& what)
{
  for (const auto& entry : map)
  {
    const std::string key = entry.first.as<std::string>();
    if (std::find(known.begin(), known.end(), key) == known.end())
      fail(where / key, entry.first, "is not a key of " + what + "; valid keys: " + joined(known));
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

double readDouble(const Where& where, const YAML::Node& node)
{
  return readScalar<double>(where, node, "must be a number");
}

int readInt(const Where& where, const YAML::Node& node)
{
  return readScalar<int>(where, node, "must be an integer");
}

bool readBool(const Where& where, const YAML::Node& node)
{
  return readScalar<bool>(where, node, "must be true or false");
}

std::string readString(const Where& where, const YAML::Node& node)
{
  if (!node.IsScalar())
    fail(where, node, "must be a string");
  return node.as<std::string>();
}

Vec3 readVector(const Where& where, const YAML::Node& node)
{
  if (!node.IsSequence() || node.size() != 3)
    fail(where, node, "must be a list of 3 numbers [x, y, z]");
  return Vec3(readDouble(where[0], node[0]), readDouble(where[1], node[1]),
              readDouble(where[2], node[2]));
}

void requireRange(const Where& where, const YAML::Node& node, double value, double low,
                  bool low_open, double high, const std::string& unit)
{
  const bool below = low_open ? !(value > low) : !(value >= low);
  if (!std::isfinite(value) || below || value > high)
    fail(where, node,
         "= " + formatValue(value) + ", must be in " + (low_open ? "(" : "[") + formatValue(low) +
             ", " + formatValue(high) + "] " + unit);
}

int surfaceIndex(const Where& where, const YAML::Node& node,
                 const std::vector<NamedSurface>& surfaces)
{
  if (node.IsScalar())
  {
    const std::string name = node.as<std::string>();
    for (std::size_t k = 0; k < surfaces.size(); ++k)
      if (surfaces[k].name == name)
        return static_cast<int>(k);
  }
  std::vector<std::string> names;
  for (const auto& s : surfaces)
    names.push_back(s.name);
  fail(where, node,
       "must name a surface of this scene" +
           (names.empty() ? std::string(" (it defines none under 'surfaces')")
                          : "; defined: " + joined(names)));
}

Surface parseSurface(const Where& where, const YAML::Node& node)
{
  requireMap(where, node, "a surface");
  checkKeys(where, node, { "type", "coefficients", "expression" }, "a surface");
  if (!node["type"])
    fail(where / "type", node, "is missing; valid: " + joined(surfaceTypeNames()));
  const SurfaceType type =
      parseSurfaceType(readString(where / "type", node["type"]), where.at(node["type"]) + ".type");
  if (type == SurfaceType::Expression)
  {
    if (!node["expression"])
      fail(where / "expression", node, "is missing: type expression needs Z(x, y)");
    if (node["coefficients"])
      fail(where / "coefficients", node["coefficients"], "is not used by type expression");
    return makeExpressionSurface(readString(where / "expression", node["expression"]),
                                 (where / "expression").at(node["expression"]));
  }
  if (node["expression"])
    fail(where / "expression", node["expression"], "is only for type expression");
  std::vector<double> coefficients;
  if (node["coefficients"])
  {
    requireSequence(where / "coefficients", node["coefficients"], "numbers");
    for (std::size_t k = 0; k < node["coefficients"].size(); ++k)
      coefficients.push_back(readDouble((where / "coefficients")[k], node["coefficients"][k]));
  }
  return makeSurface(type, coefficients, (where / "coefficients").at(node));
}

// Reads one record of a registry variant from a map with a `type` key, field by field.
template <typename Variant>
struct RecordReader
{
  const std::vector<NamedSurface>& surfaces;

  // records of `kind`; a record with a `particle` field may list `particles` instead
  template <typename Kind>
  bool tryKind(const std::string& kind, const Where& where, const YAML::Node& node,
               std::vector<Variant>& out, bool& anchor_given)
  {
    if (kind != Kind::KIND)
      return false;
    std::vector<std::string> known{ "type" };
    bool has_particle = false;
    forEachField<Kind>(
        [&](const auto& spec)
        {
          known.push_back(spec.name);
          has_particle = has_particle || std::string(spec.name) == "particle";
        });
    if (has_particle)
      known.push_back("particles");
    checkKeys(where, node, known, std::string("a ") + Kind::KIND + " record");
    Kind record;
    forEachField<Kind>(
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
          else
            member = readDouble(at, value);
        });
    anchor_given = static_cast<bool>(node["anchor"]);
    if (has_particle && node["particles"])
    {
      if (node["particle"])
        fail(where / "particles", node["particles"], "and particle are exclusive: give one");
      requireSequence(where / "particles", node["particles"], "particle indices");
      for (std::size_t k = 0; k < node["particles"].size(); ++k)
      {
        Kind copy = record;
        forEachField<Kind>(
            [&](const auto& spec)
            {
              if constexpr (std::is_same_v<std::decay_t<decltype(copy.*(spec.member))>, int>)
                if (std::string(spec.name) == "particle")
                  copy.*(spec.member) = readInt((where / "particles")[k], node["particles"][k]);
            });
        out.push_back(copy);
      }
      return true;
    }
    out.push_back(record);
    return true;
  }

  template <std::size_t... I>
  void read(const std::string& kind, const Where& where, const YAML::Node& node,
            std::vector<Variant>& out, bool& anchor_given, std::index_sequence<I...>)
  {
    const bool found =
        (tryKind<std::variant_alternative_t<I, Variant>>(kind, where, node, out, anchor_given) ||
         ...);
    if (!found)
    {
      std::vector<std::string> kinds;
      for (const char* name : KindNames<Variant>::value)
        kinds.push_back(name);
      fail(where / "type", node["type"], "= '" + kind + "' is unknown; valid: " + joined(kinds));
    }
  }
};

// Reads a list of records (forces or constraints); `where_of` records each one's key for
// validation messages.
template <typename Variant>
void readRecords(const Where& where, const YAML::Node& list,
                 const std::vector<NamedSurface>& surfaces, std::vector<Variant>& out,
                 std::vector<std::string>& where_of, std::vector<bool>* anchor_given)
{
  requireSequence(where, list, "records, each a map with a type");
  RecordReader<Variant> reader{ surfaces };
  for (std::size_t k = 0; k < list.size(); ++k)
  {
    const YAML::Node node = list[k];
    const Where at = where[k];
    requireMap(at, node, "one record with a type");
    if (!node["type"])
      fail(at / "type", node, "is missing");
    const std::size_t before = out.size();
    bool given = true;
    reader.read(readString(at / "type", node["type"]), at, node, out, given,
                std::make_index_sequence<std::variant_size_v<Variant>>{});
    for (std::size_t added = before; added < out.size(); ++added)
    {
      where_of.push_back(at.at(node));
      if (anchor_given)
        anchor_given->push_back(given);
    }
  }
}

ChainSpec parseChain(const Where& where, const YAML::Node& node,
                     const std::vector<NamedSurface>& surfaces)
{
  requireMap(where, node, "a chain");
  checkKeys(where, node,
            { "particles", "link_length", "particle_mass", "start", "direction", "velocity",
              "angular_velocity", "pin_first", "pin_last", "surface" },
            "a chain");
  ChainSpec chain;
  if (node["particles"])
  {
    chain.particles = readInt(where / "particles", node["particles"]);
    requireRange(where / "particles", node["particles"], chain.particles, 1, false, MAX_PARTICLES,
                 "[1]");
  }
  if (node["link_length"])
  {
    chain.link_length = readDouble(where / "link_length", node["link_length"]);
    requireRange(where / "link_length", node["link_length"], chain.link_length, 0, true, 1e3,
                 "[m]");
  }
  if (node["particle_mass"])
  {
    chain.particle_mass = readDouble(where / "particle_mass", node["particle_mass"]);
    requireRange(where / "particle_mass", node["particle_mass"], chain.particle_mass, 0, true, 1e6,
                 "[kg]");
  }
  if (node["start"])
    chain.start = readVector(where / "start", node["start"]);
  if (node["direction"])
  {
    chain.direction = readVector(where / "direction", node["direction"]);
    if (!(chain.direction.norm() > 0.0))
      fail(where / "direction", node["direction"], "must be a non-zero vector");
  }
  if (node["velocity"])
    chain.velocity = readVector(where / "velocity", node["velocity"]);
  if (node["angular_velocity"])
    chain.angular_velocity = readVector(where / "angular_velocity", node["angular_velocity"]);
  if (node["pin_first"])
    chain.pin_first = readBool(where / "pin_first", node["pin_first"]);
  if (node["pin_last"])
    chain.pin_last = readBool(where / "pin_last", node["pin_last"]);
  if (node["surface"])
  {
    surfaceIndex(where / "surface", node["surface"], surfaces);
    chain.surface = node["surface"].as<std::string>();
    if (chain.pin_first)
      fail(where / "pin_first", node["pin_first"],
           "cannot be true for a chain whose first particle slides on a surface");
  }
  return chain;
}

// z = Z(x, y) and the velocity lifted into the tangent plane (vz = Zx vx + Zy vy)
void placeOnSurface(const Surface& surface, Vec3& position, Vec3& velocity)
{
  const SurfaceSample s = evaluateSurface(surface, position.x(), position.y());
  position.z() = s.z;
  velocity.z() = s.zx * velocity.x() + s.zy * velocity.y();
}

}  // namespace

namespace
{
SceneDescription parseSceneNodes(const std::string& yaml, const std::string& source);
}

StepSettings SolverSpec::applyTo(StepSettings settings) const
{
  if (dt)
    settings.dt = *dt;
  if (integrator)
    settings.integrator = *integrator;
  if (stabilization)
    settings.stabilization = *stabilization;
  return settings;
}

long SceneDescription::numParticles() const
{
  long n = static_cast<long>(particles.size());
  for (const ChainSpec& chain : chains)
    n += chain.particles;
  return n;
}

SceneDescription parseScene(const std::string& yaml, const std::string& source)
{
  // anything yaml-cpp throws past the checks above (odd keys, deep nesting) is still bad input
  try
  {
    return parseSceneNodes(yaml, source);
  }
  catch (const YAML::Exception& e)
  {
    throw InvalidInput(source + (e.mark.is_null() ? "" : ":" + std::to_string(e.mark.line + 1)),
                       "is not a valid scene: " + e.msg);
  }
}

namespace
{
SceneDescription parseSceneNodes(const std::string& yaml, const std::string& source)
{
  YAML::Node root;
  try
  {
    root = YAML::Load(yaml);
  }
  catch (const YAML::ParserException& e)
  {
    throw InvalidInput(source + ":" + std::to_string(e.mark.line + 1),
                       "is not valid YAML: " + e.msg);
  }
  const Where top{ source, "" };
  if (!root.IsMap())
    throw InvalidInput(source, "must hold a map with the keys of a scene (see README)");
  checkKeys(top, root,
            { "name", "description", "surfaces", "particles", "chains", "forces", "constraints",
              "solver" },
            "a scene");
  SceneDescription d;
  d.source = source;
  if (root["name"])
    d.name = readString(top / "name", root["name"]);
  if (root["description"])
    d.description = readString(top / "description", root["description"]);

  if (const YAML::Node surfaces = root["surfaces"])
  {
    requireMap(top / "surfaces", surfaces, "named surfaces (name: {type, coefficients})");
    for (const auto& entry : surfaces)
    {
      const std::string name = entry.first.as<std::string>();
      d.surfaces.push_back(
          NamedSurface{ name, parseSurface(top / "surfaces" / name, entry.second) });
    }
  }

  if (const YAML::Node particles = root["particles"])
  {
    requireSequence(top / "particles", particles, "particles, each {mass, position, velocity}");
    for (std::size_t k = 0; k < particles.size(); ++k)
    {
      const Where at = (top / "particles")[k];
      const YAML::Node node = particles[k];
      requireMap(at, node, "a particle");
      checkKeys(at, node, { "mass", "position", "velocity" }, "a particle");
      ParticleSpec particle;
      if (node["mass"])
      {
        particle.mass = readDouble(at / "mass", node["mass"]);
        requireRange(at / "mass", node["mass"], particle.mass, 0, true, 1e6, "[kg]");
      }
      if (node["position"])
        particle.position = readVector(at / "position", node["position"]);
      if (node["velocity"])
        particle.velocity = readVector(at / "velocity", node["velocity"]);
      d.particles.push_back(particle);
    }
  }
  if (const YAML::Node chains = root["chains"])
  {
    requireSequence(top / "chains", chains, "chains");
    for (std::size_t k = 0; k < chains.size(); ++k)
      d.chains.push_back(parseChain((top / "chains")[k], chains[k], d.surfaces));
  }
  if (d.numParticles() == 0)
    throw InvalidInput(source + ": particles",
                       "are missing: a scene needs 'particles' or 'chains' (at least 1 particle)");
  if (d.numParticles() > MAX_PARTICLES)
    throw InvalidInput(source + ": particles", "= " + std::to_string(d.numParticles()) +
                                                   " in all, must be at most " +
                                                   std::to_string(MAX_PARTICLES));

  const int n = static_cast<int>(d.numParticles());
  const int num_surfaces = static_cast<int>(d.surfaces.size());
  std::vector<std::string> where_of;
  if (const YAML::Node forces = root["forces"])
  {
    readRecords(top / "forces", forces, d.surfaces, d.forces, where_of, nullptr);
    for (std::size_t k = 0; k < d.forces.size(); ++k)
      validateForce(d.forces[k], n, where_of[k]);
  }
  where_of.clear();
  if (const YAML::Node constraints = root["constraints"])
  {
    std::vector<bool> anchor_given;
    readRecords(top / "constraints", constraints, d.surfaces, d.constraints, where_of,
                &anchor_given);
    for (std::size_t k = 0; k < d.constraints.size(); ++k)
    {
      validateConstraint(d.constraints[k], n, num_surfaces, where_of[k]);
      d.pin_at_start.push_back(std::holds_alternative<PinConstraint>(d.constraints[k]) &&
                               !anchor_given[k]);
    }
  }
  if (const YAML::Node solver = root["solver"])
  {
    const Where at = top / "solver";
    requireMap(at, solver, "solver settings");
    checkKeys(at, solver, { "dt", "integrator", "stabilization", "solve_method" },
              "solver settings");
    if (solver["dt"])
    {
      d.solver.dt = readDouble(at / "dt", solver["dt"]);
      requireRange(at / "dt", solver["dt"], *d.solver.dt, 0, true, 1.0, "[s]");
    }
    if (solver["integrator"])
      d.solver.integrator = parseIntegrator(readString(at / "integrator", solver["integrator"]),
                                            (at / "integrator").at(solver["integrator"]));
    if (solver["stabilization"])
      d.solver.stabilization =
          parseStabilization(readString(at / "stabilization", solver["stabilization"]),
                             (at / "stabilization").at(solver["stabilization"]));
    if (solver["solve_method"])
    {
      const std::string name = readString(at / "solve_method", solver["solve_method"]);
      bool known = false;
      for (SolveMethod method : { SolveMethod::Automatic, SolveMethod::Tridiagonal,
                                  SolveMethod::Tree, SolveMethod::Sparse, SolveMethod::Dense })
        if (name == solveMethodName(method))
        {
          d.solver.solve_method = method;
          known = true;
        }
      if (!known)
        fail(at / "solve_method", solver["solve_method"],
             "= '" + name + "' is unknown; valid: automatic, tridiagonal, tree, sparse, dense");
    }
  }
  return d;
}

}  // namespace

SceneDescription loadSceneFile(const std::string& path)
{
  std::ifstream file(path, std::ios::binary | std::ios::ate);
  if (!file)
    throw InvalidInput(path, "cannot be read");
  const std::streamoff size = file.tellg();
  if (size < 0 || size > MAX_SCENE_FILE_BYTES)
    throw InvalidInput(path, "is " + std::to_string(static_cast<long long>(size)) +
                                 " bytes, over the limit of " +
                                 std::to_string(MAX_SCENE_FILE_BYTES) + " bytes");
  file.seekg(0);
  std::stringstream text;
  text << file.rdbuf();
  SceneDescription d = parseScene(text.str(), path);
  if (d.name.empty())
  {
    const std::size_t slash = path.find_last_of('/');
    std::string stem = slash == std::string::npos ? path : path.substr(slash + 1);
    if (stem.size() > 5 && stem.compare(stem.size() - 5, 5, ".yaml") == 0)
      stem.resize(stem.size() - 5);
    d.name = stem;
  }
  return d;
}

Scenario buildScene(const SceneDescription& d)
{
  Scenario scenario;
  Scene& scene = scenario.scene;
  State& state = scenario.initial_state;
  const int n = static_cast<int>(d.numParticles());
  scene.name = d.name;
  for (const NamedSurface& named : d.surfaces)
    scene.surfaces.push_back(named.surface);
  scene.masses.reserve(n);
  state.positions.resize(3, n);
  state.velocities.resize(3, n);
  int next = 0;
  for (const ParticleSpec& particle : d.particles)
  {
    scene.masses.push_back(particle.mass);
    state.positions.col(next) = particle.position;
    state.velocities.col(next) = particle.velocity;
    ++next;
  }
  for (const ChainSpec& chain : d.chains)
  {
    const int first = next;
    Vec3 start = chain.start, velocity = chain.velocity;
    int surface = -1;
    for (std::size_t k = 0; k < d.surfaces.size(); ++k)
      if (!chain.surface.empty() && d.surfaces[k].name == chain.surface)
        surface = static_cast<int>(k);
    if (surface >= 0)
      placeOnSurface(d.surfaces[surface].surface, start, velocity);
    const Vec3 step = chain.link_length * chain.direction.normalized();
    const Vec3 centre = start + 0.5 * (chain.particles - 1) * step;
    const bool pinned = chain.pin_first || chain.pin_last;
    for (int i = 0; i < chain.particles; ++i)
    {
      const Vec3 p = start + i * step;
      scene.masses.push_back(chain.particle_mass);
      state.positions.col(next) = p;
      // a pinned chain cannot spin about its centre: the spin is for free chains
      state.velocities.col(next) =
          velocity + (pinned ? Vec3::Zero() : Vec3(chain.angular_velocity.cross(p - centre)));
      ++next;
    }
    // surface row first, then links in order: J W J^T stays tridiagonal
    if (surface >= 0)
      scene.constraints.push_back(SurfaceConstraint{ first, surface });
    for (int i = first; i + 1 < next; ++i)
      scene.constraints.push_back(LinkConstraint{ i, i + 1, chain.link_length });
    if (chain.pin_first)
      scene.constraints.push_back(PinConstraint{ first, start });
    if (chain.pin_last)
      scene.constraints.push_back(
          PinConstraint{ next - 1, Vec3(start + (chain.particles - 1) * step) });
  }
  for (std::size_t k = 0; k < d.constraints.size(); ++k)
  {
    Constraint c = d.constraints[k];
    if (auto* on_surface = std::get_if<SurfaceConstraint>(&c))
    {
      Vec3 p = state.positions.col(on_surface->particle);
      Vec3 v = state.velocities.col(on_surface->particle);
      placeOnSurface(d.surfaces[on_surface->surface].surface, p, v);
      state.positions.col(on_surface->particle) = p;
      state.velocities.col(on_surface->particle) = v;
    }
    if (auto* pin = std::get_if<PinConstraint>(&c); pin && d.pin_at_start[k])
      pin->anchor = state.positions.col(pin->particle);
    scene.constraints.push_back(c);
  }
  scene.forces = d.forces;
  return scenario;
}

std::vector<std::string> listScenes(const std::string& directory)
{
  std::vector<std::string> names;
  DIR* dir = opendir(directory.c_str());
  if (!dir)
    return names;
  while (const dirent* entry = readdir(dir))
  {
    const std::string file = entry->d_name;
    if (file.size() > 5 && file.compare(file.size() - 5, 5, ".yaml") == 0)
      names.push_back(file.substr(0, file.size() - 5));
  }
  closedir(dir);
  std::sort(names.begin(), names.end());
  return names;
}

std::string resolveScene(const std::string& name_or_path, const std::string& directory,
                         const std::string& field)
{
  const bool is_path =
      name_or_path.find('/') != std::string::npos ||
      (name_or_path.size() > 5 && name_or_path.compare(name_or_path.size() - 5, 5, ".yaml") == 0);
  const std::string path = is_path ? name_or_path : directory + "/" + name_or_path + ".yaml";
  struct stat info;
  if (!name_or_path.empty() && stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode))
    return path;
  const std::string shown =
      name_or_path.size() > 200 ? name_or_path.substr(0, 200) + "..." : name_or_path;
  if (is_path)
    throw InvalidInput(field, "= '" + shown + "': no such scene file");
  throw InvalidInput(field, "= '" + shown + "' is unknown; valid: " +
                                joined(listScenes(directory)) + ", or a path to a scene file");
}

namespace
{
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
                if constexpr (std::is_same_v<std::decay_t<decltype(r.*(spec.member))>, int>)
                  if (spec.kind == FieldKind::Particle)
                    largest = std::max(largest, r.*(spec.member));
              });
        },
        record);
  return largest;
}

}  // namespace

void setChains(SceneDescription& d, const ChainParameters& chain)
{
  if (d.chains.empty())
    throw InvalidInput("num_particles", "cannot be set: scene '" + d.name + "' has no chain");
  // records naming chain particles by index would silently point elsewhere after renumbering
  const int explicit_particles = static_cast<int>(d.particles.size());
  const bool count_changes =
      std::any_of(d.chains.begin(), d.chains.end(),
                  [&](const ChainSpec& c) { return c.particles != chain.num_particles; });
  if (count_changes && std::max(largestParticleIndex(d.forces),
                                largestParticleIndex(d.constraints)) >= explicit_particles)
    throw InvalidInput("num_particles",
                       "= " + std::to_string(chain.num_particles) + " cannot be set: scene '" +
                           d.name +
                           "' names chain particles by index in its forces or constraints, so "
                           "its chains keep their counts (link_length and particle_mass may "
                           "change)");
  for (ChainSpec& spec : d.chains)
  {
    spec.particles = chain.num_particles;
    spec.link_length = chain.link_length;
    spec.particle_mass = chain.particle_mass;
    if (spec.surface.empty())
      spec.pin_first = chain.pin_first;
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
