// yaml-cpp reads the files (a well-kept YAML parser: ours would be worse); every key is read and
// checked through the field descriptors of the core, so its names and ranges are the core's.
#include "constrained_particles/scenes/scene_file.hpp"

#include "yaml_readers.hpp"

#include "constrained_particles/scenes/robot_shapes.hpp"

#include "constrained_particles/core/integrators.hpp"

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
using namespace scene_yaml;  // the readers shared with shape_file.cpp

namespace
{

// Reads one record of a registry variant from a map with a `type` key, field by field.
template <typename Variant>
struct RecordReader
{
  const SceneDescription& scene;
  int num_particles;  ///< the scene's, for `particles: all`

  // records of `kind`; a record with a `particle` field may list `particles` instead, or give
  // `particles: all`
  template <typename Kind>
  bool tryKind(const std::string& kind, const Where& where, const YAML::Node& node,
               std::vector<Variant>& out)
  {
    if (kind != Kind::KIND)
      return false;
    std::vector<std::string> known = fieldNames<Kind>();
    const bool has_particle = std::find(known.begin(), known.end(), "particle") != known.end();
    known.insert(known.begin(), "type");
    if (has_particle)
      known.push_back("particles");
    checkKeys(where, node, known, std::string("a ") + Kind::KIND + " record");
    Kind record;
    // an obstacle has no default: a record must name one
    forEachField<Kind>(
        [&](const auto& spec)
        {
          if constexpr (std::is_same_v<typename std::decay_t<decltype(spec)>::MemberType, Shape>)
            if (!node[spec.name])
              fail(where / spec.name, node, "is missing: name a shape defined under 'shapes'");
        });
    readFields(where, node, record, scene);
    // a field that may be left out (from_start) must be a valid value when it is given: NaN
    // written in the file is refused, not taken as "unset"
    forEachField<Kind>(
        [&](const auto& spec)
        {
          if constexpr (std::is_same_v<typename std::decay_t<decltype(spec)>::MemberType, double> ||
                        std::is_same_v<typename std::decay_t<decltype(spec)>::MemberType, Vec3>)
            if (spec.from_start && node[spec.name])
            {
              try
              {
                requireInRange(spec.name, record.*(spec.member), *spec.range);
              }
              catch (const InvalidInput& e)
              {
                failAt(where, node[spec.name], e);
              }
            }
        });
    if (has_particle && node["particles"])
    {
      if (node["particle"])
        fail(where / "particles", node["particles"], "and particle are exclusive: give one");
      const bool all = node["particles"].IsScalar() && node["particles"].as<std::string>() == "all";
      if (!all)
        requireSequence(where / "particles", node["particles"], "particle indices, or all");
      const std::size_t count =
          all ? static_cast<std::size_t>(num_particles) : node["particles"].size();
      for (std::size_t k = 0; k < count; ++k)
      {
        Kind copy = record;
        forEachField<Kind>(
            [&](const auto& spec)
            {
              if constexpr (std::is_same_v<std::decay_t<decltype(copy.*(spec.member))>, int>)
                if (std::string(spec.name) == "particle")
                  copy.*(spec.member) =
                      all ? static_cast<int>(k)
                          : readInt((where / "particles")[k], node["particles"][k]);
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
            std::vector<Variant>& out, std::index_sequence<I...>)
  {
    const bool found =
        (tryKind<std::variant_alternative_t<I, Variant>>(kind, where, node, out) || ...);
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
void readRecords(const Where& where, const YAML::Node& list, const SceneDescription& scene,
                 int num_particles, std::vector<Variant>& out, std::vector<std::string>& where_of)
{
  requireSequence(where, list, "records, each a map with a type");
  RecordReader<Variant> reader{ scene, num_particles };
  for (std::size_t k = 0; k < list.size(); ++k)
  {
    const YAML::Node node = list[k];
    const Where at = where[k];
    requireMap(at, node, "one record with a type");
    if (!node["type"])
    {
      const auto& names = KindNames<Variant>::value;
      fail(at / "type", node,
           "is missing; valid: " + joined(std::vector<std::string>(names.begin(), names.end())));
    }
    const std::size_t before = out.size();
    reader.read(readString(at / "type", node["type"]), at, node, out,
                std::make_index_sequence<std::variant_size_v<Variant>>{});
    for (std::size_t added = before; added < out.size(); ++added)
      where_of.push_back(at.at(node));
  }
}

// A map read into a described record (a particle, a chain) and checked against its ranges.
template <typename Record>
Record parseDescribed(const Where& where, const YAML::Node& node, const std::string& what,
                      const SceneDescription& scene)
{
  requireMap(where, node, what);
  checkKeys(where, node, fieldNames<Record>(), what);
  Record record;
  readFields(where, node, record, scene);
  try
  {
    validateFields(record, 0, 0, "");
  }
  catch (const InvalidInput& e)
  {
    // the field is "name" or "name.x" (prefix ""): name it at its line
    const std::string key = e.field();
    const std::size_t dot = key.find('.');
    const std::string top = dot == std::string::npos ? key : key.substr(0, dot);
    const std::string message = e.what();
    fail(where / key, node[top], message.substr(e.field().size() + 1));
  }
  return record;
}

// the particle's position z and velocity lifted onto a surface (vz = Zx vx + Zy vy)
void placeOnSurface(const Surface& surface, Vec3& position, Vec3& velocity)
{
  const SurfaceSample s = evaluateSurface(surface, position.x(), position.y());
  position.z() = s.z;
  velocity.z() = s.zx * velocity.x() + s.zy * velocity.y();
}

SceneDescription parseSceneNodes(const std::string& yaml, const std::string& source,
                                 const SceneInputs& inputs)
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
    throw InvalidInput(source, "must hold a map with the keys of a scene (see docs/scenes.md)");
  checkKeys(top, root,
            { "name", "description", "surfaces", "shapes", "robot_links", "particles", "chains",
              "forces", "constraints", "solver", "region" },
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
      for (const NamedSurface& earlier : d.surfaces)
        if (earlier.name == name)
          fail(top / "surfaces" / name, entry.first, "appears twice among the surfaces");
      d.surfaces.push_back(
          NamedSurface{ name, parseSurface(top / "surfaces" / name, entry.second) });
    }
  }

  if (const YAML::Node shapes = root["shapes"])
  {
    requireMap(top / "shapes", shapes, "named obstacles (name: {type, position, rpy, ...})");
    for (const auto& entry : shapes)
    {
      if (!entry.first.IsScalar() || entry.first.as<std::string>().empty())
        fail(top / "shapes", entry.first, "must be named by a non-empty string");
      const std::string name = entry.first.as<std::string>();
      for (const Shape& earlier : d.shapes)
        if (earlier.name == name)
          fail(top / "shapes" / name, entry.first, "appears twice among the shapes");
      d.shapes.push_back(parseShape(top / "shapes" / name, entry.second, name, inputs.files));
    }
    if (!limits::SHAPES.contains(static_cast<double>(d.shapes.size())))
      fail(top / "shapes", shapes,
           "has " + std::to_string(d.shapes.size()) + " shapes, must be in " +
               limits::SHAPES.text());
  }
  // the robot's own links (URDF collision geometry), each carried by its link's tf frame
  if (const YAML::Node links = root["robot_links"])
  {
    const Where where = top / "robot_links";
    requireSequence(where, links, "names of links of the robot in robot_description");
    std::vector<std::string> names;
    for (std::size_t k = 0; k < links.size(); ++k)
      names.push_back(readString(where[k], links[k]));
    std::vector<Shape> robot;
    try
    {
      robot = robotLinkShapes(inputs.robot_description, names, "robot_links", inputs.files);
    }
    catch (const InvalidInput& e)
    {
      const std::string message = e.what();
      fail(where, links, message.substr(e.field().size() + 1));
    }
    for (Shape& shape : robot)
    {
      for (const Shape& earlier : d.shapes)
        if (earlier.name == shape.name)
          fail(where, links, "makes shape '" + shape.name + "', a name under shapes already");
      d.shapes.push_back(std::move(shape));
    }
    if (!limits::SHAPES.contains(static_cast<double>(d.shapes.size())))
      fail(where, links,
           "makes " + std::to_string(d.shapes.size()) +
               " shapes with those under shapes, must "
               "be in " +
               limits::SHAPES.text());
  }

  if (const YAML::Node particles = root["particles"])
  {
    requireSequence(top / "particles", particles, "particles, each {mass, position, velocity}");
    for (std::size_t k = 0; k < particles.size(); ++k)
      d.particles.push_back(
          parseDescribed<ParticleSpec>((top / "particles")[k], particles[k], "a particle", d));
  }
  if (const YAML::Node chains = root["chains"])
  {
    requireSequence(top / "chains", chains, "chains");
    for (std::size_t k = 0; k < chains.size(); ++k)
    {
      const Where at = (top / "chains")[k];
      d.chains.push_back(parseDescribed<ChainSpec>(at, chains[k], "a chain", d));
      if (!d.chains.back().surface.empty())
        surfaceIndex(at / "surface", chains[k]["surface"], d.surfaces);
      if (!d.chains.back().contact.empty())
        surfaceIndex(at / "contact", chains[k]["contact"], d.surfaces);
      const ChainSpec& chain = d.chains.back();
      if (chain.self_collision && !(chain.radius > 0.0 && 2.0 * chain.radius < chain.link_length))
        fail(at / "radius", chains[k]["radius"] ? chains[k]["radius"] : chains[k],
             "= " + formatValue(chain.radius) +
                 " m with self_collision: true, must be over 0 and under half of link_length (" +
                 formatValue(chain.link_length) + " m)");
      if (chain.capsules && chain.obstacles.empty())
        fail(at / "capsules", chains[k]["capsules"],
             "= true with no obstacles: name the shapes its links keep out of under obstacles");
      for (std::size_t o = 0; o < chain.obstacles.size(); ++o)
      {
        const Shape& shape =
            d.shapes[shapeIndex((at / "obstacles")[o], chains[k]["obstacles"][o], d.shapes)];
        try
        {
          requireRoundedEdges(shape, chain.radius, "radius");
        }
        catch (const InvalidInput& e)
        {
          failAt(at, chains[k]["radius"] ? chains[k]["radius"] : chains[k], e);
        }
        if (chain.capsules && shape.type == ShapeType::Mesh)
          fail(at / "capsules", chains[k]["capsules"],
               "= true with mesh '" + shape.name +
                   "' among its obstacles: a link's nearest point is found on a convex shape "
                   "(one minimum along it), and a mesh is not one; its particles keep out of it "
                   "with capsules: false");
        if (std::find(chain.obstacles.begin(), chain.obstacles.begin() + o, chain.obstacles[o]) !=
            chain.obstacles.begin() + o)
          fail((at / "obstacles")[o], chains[k]["obstacles"][o],
               "= " + chain.obstacles[o] + " appears twice (one contact per particle and shape)");
      }
    }
  }
  if (d.numParticles() == 0)
    throw InvalidInput(source + ": particles",
                       "are missing: a scene needs 'particles' or 'chains' (at least 1 particle)");
  if (!limits::PARTICLES.contains(static_cast<double>(d.numParticles())))
    throw InvalidInput(source + ": particles", "= " + std::to_string(d.numParticles()) +
                                                   " in all, must be in " +
                                                   limits::PARTICLES.text());

  const int n = static_cast<int>(d.numParticles());
  const int num_surfaces = static_cast<int>(d.surfaces.size());
  std::vector<std::string> where_of;
  if (const YAML::Node forces = root["forces"])
  {
    readRecords(top / "forces", forces, d, n, d.forces, where_of);
    for (std::size_t k = 0; k < d.forces.size(); ++k)
      validateForce(d.forces[k], n, where_of[k]);
  }
  where_of.clear();
  if (const YAML::Node constraints = root["constraints"])
  {
    readRecords(top / "constraints", constraints, d, n, d.constraints, where_of);
    for (std::size_t k = 0; k < d.constraints.size(); ++k)
      validateConstraint(d.constraints[k], n, num_surfaces, where_of[k], true);
  }
  if (const YAML::Node region = root["region"])
  {
    const Where at = top / "region";
    const RegionSpec r = parseDescribed<RegionSpec>(at, region, "a region {low, high}", d);
    for (int axis = 0; axis < 3; ++axis)
      if (!(r.low[axis] <= r.high[axis]))
      {
        const std::string name = std::string("high.") + "xyz"[axis];
        fail(at / name, region["high"],
             "= " + formatValue(r.high[axis]) + ", must be >= low." + "xyz"[axis] + " (" +
                 formatValue(r.low[axis]) + ")");
      }
    d.region = r;
  }
  if (const YAML::Node solver = root["solver"])
  {
    const Where at = top / "solver";
    requireMap(at, solver, "solver settings");
    std::vector<std::string> known = fieldNames<StepSettings>();
    known.push_back("solve_method");
    checkKeys(at, solver, known, "solver settings");
    readFields(at, solver, d.solver.values, d);
    for (const std::string& name : fieldNames<StepSettings>())
      if (solver[name])
        d.solver.given.push_back(name);
    try
    {
      validateStepSettings(d.solver.values);
    }
    catch (const InvalidInput& e)
    {
      failAt(at, solver[e.field()], e);
    }
    if (solver["solve_method"])
      d.solver.solve_method =
          parseSolveMethod(readString(at / "solve_method", solver["solve_method"]),
                           (at / "solve_method").at(solver["solve_method"]));
  }
  return d;
}

}  // namespace

StepSettings SolverSpec::applyTo(StepSettings settings) const
{
  forEachField<StepSettings>(
      [&](const auto& spec)
      {
        if (std::find(given.begin(), given.end(), spec.name) != given.end())
          settings.*(spec.member) = values.*(spec.member);
      });
  return settings;
}

RegionSpec sceneRegion(const SceneDescription& description, const State& initial)
{
  const Points& p = initial.positions;
  const Vec3 margin = Vec3::Constant(REGION_MARGIN);
  RegionSpec region;
  region.low = (p.cols() > 0 ? Vec3(p.rowwise().minCoeff()) : Vec3::Zero()) - margin;
  region.high = (p.cols() > 0 ? Vec3(p.rowwise().maxCoeff()) : Vec3::Zero()) + margin;
  const RegionSpec particles = region;
  auto include = [&region](const Vec3& low, const Vec3& high)
  {
    region.low = region.low.cwiseMin(low);
    region.high = region.high.cwiseMax(high);
  };
  // spheres the motion stays in: a chain can swing its whole length about where it starts
  std::vector<std::pair<Vec3, double>> reaches;
  if (description.region)
    include(description.region->low, description.region->high);
  else
  {
    int particle = static_cast<int>(description.particles.size());
    for (const ChainSpec& chain : description.chains)
    {
      const Vec3 start = particle < p.cols() ? Vec3(p.col(particle)) : chain.start;
      const double reach = (chain.particles - 1) * chain.link_length + REGION_MARGIN;
      include(start - Vec3::Constant(reach), start + Vec3::Constant(reach));
      reaches.emplace_back(start, reach);
      particle += chain.particles;
    }
  }
  // the surfaces as they are meshed over the region's x-y extent: all of the mesh in the box
  constexpr int SAMPLES = 16;
  std::vector<Vec3> mesh;
  for (const NamedSurface& named : description.surfaces)
    for (int i = 0; i <= SAMPLES; ++i)
      for (int j = 0; j <= SAMPLES; ++j)
      {
        const double x = region.low.x() + (region.high.x() - region.low.x()) * i / SAMPLES;
        const double y = region.low.y() + (region.high.y() - region.low.y()) * j / SAMPLES;
        const double z = evaluateSurface(named.surface, x, y).z;
        if (std::isfinite(z) && limits::COORDINATE.contains(z))
          mesh.emplace_back(x, y, z);
      }
  for (const Vec3& point : mesh)
    include(point, point);
  if (description.region)
    return region;  // the file's box: its own half-diagonal
  // what must be seen, about the centre: the particles' box, the reaches, the mesh
  const Vec3 center = region.center();
  double radius = 0.0;
  for (int corner = 0; corner < 8; ++corner)
  {
    const Vec3 c((corner & 1) ? particles.high.x() : particles.low.x(),
                 (corner & 2) ? particles.high.y() : particles.low.y(),
                 (corner & 4) ? particles.high.z() : particles.low.z());
    radius = std::max(radius, (c - center).norm());
  }
  for (const auto& [start, reach] : reaches)
    radius = std::max(radius, (start - center).norm() + reach);
  for (const Vec3& point : mesh)
    radius = std::max(radius, (point - center).norm());
  region.reach = std::min(radius, 0.5 * (region.high - region.low).norm());
  return region;
}

long SceneDescription::numParticles() const
{
  long n = static_cast<long>(particles.size());
  for (const ChainSpec& chain : chains)
    n += chain.particles;
  return n;
}

SceneDescription parseScene(const std::string& yaml, const std::string& source,
                            const SceneInputs& inputs)
{
  // anything yaml-cpp throws past the checks above (odd keys, deep nesting) is still bad input
  try
  {
    return parseSceneNodes(yaml, source, inputs);
  }
  catch (const YAML::Exception& e)
  {
    throw InvalidInput(source + (e.mark.is_null() ? "" : ":" + std::to_string(e.mark.line + 1)),
                       "is not a valid scene: " + e.msg);
  }
}

SceneDescription loadSceneFile(const std::string& path, const SceneInputs& inputs)
{
  std::ifstream file(path, std::ios::binary | std::ios::ate);
  if (!file)
    throw InvalidInput(path, "cannot be read");
  const std::streamoff size = file.tellg();
  if (size < 0 || size > limits::SCENE_FILE_BYTES)
    throw InvalidInput(path, "is " + std::to_string(static_cast<long long>(size)) +
                                 " bytes, over the limit of " +
                                 std::to_string(limits::SCENE_FILE_BYTES) + " bytes");
  file.seekg(0);
  std::stringstream text;
  text << file.rdbuf();
  // a mesh's relative `file` is from the scene file's directory
  SceneInputs here = inputs;
  if (here.files.directory.empty())
  {
    const std::size_t slash = path.find_last_of('/');
    here.files.directory = slash == std::string::npos ? "."
                           : slash == 0               ? "/"
                                                      : path.substr(0, slash);
  }
  SceneDescription d = parseScene(text.str(), path, here);
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

BuiltScene buildScene(const SceneDescription& d, bool refuse_start_inside)
{
  BuiltScene built;
  Scene& scene = built.scene;
  State& state = built.initial_state;
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
  // chains are expanded here (their bends in sceneForces, numbered the same way)
  for (const ChainSpec& chain : d.chains)
  {
    const int first = next;
    Vec3 start = chain.start, velocity = chain.velocity;
    auto indexOf = [&d](const std::string& name)
    {
      for (std::size_t k = 0; k < d.surfaces.size(); ++k)
        if (!name.empty() && d.surfaces[k].name == name)
          return static_cast<int>(k);
      return -1;
    };
    const int surface = indexOf(chain.surface), contact = indexOf(chain.contact);
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
      if (chain.slack)
        scene.constraints.push_back(SlackLink{ i, i + 1, chain.link_length });
      else
        scene.constraints.push_back(LinkConstraint{ i, i + 1, chain.link_length });
    // a particle sliding on the surface already (a row both ways), or pinned, takes no contact
    if (contact >= 0)
      for (int i = first; i < next; ++i)
        if (!((i == first && (contact == surface || chain.pin_first)) ||
              (i == next - 1 && chain.pin_last)))
          scene.constraints.push_back(
              SurfaceContact{ i, contact, chain.friction, chain.restitution });
    // each obstacle keeps every particle out, as a contact keeps them above its surface
    for (const std::string& name : chain.obstacles)
      for (const Shape& shape : d.shapes)
        if (shape.name == name)
          for (int i = first; i < next; ++i)
            if (!((i == first && chain.pin_first) || (i == next - 1 && chain.pin_last)))
              scene.constraints.push_back(
                  ShapeContact{ i, shape, chain.radius, chain.friction, chain.restitution });
    // and each link, as a capsule (a plane's nearest point on a link is always an end)
    if (chain.capsules)
      for (const std::string& name : chain.obstacles)
        for (const Shape& shape : d.shapes)
          if (shape.name == name && shape.type != ShapeType::Plane)
            for (int i = first; i + 1 < next; ++i)
              if (!(i == first && chain.pin_first && i + 1 == next - 1 && chain.pin_last))
                scene.constraints.push_back(
                    SegmentContact{ i, i + 1, shape, chain.radius, chain.restitution });
    // its links as capsules against each other: the Simulator makes the pairs' rows as they near
    if (chain.self_collision)
    {
      SelfCollision rope;
      rope.radius = chain.radius;
      for (int i = first; i < next; ++i)
        rope.particles.push_back(i);
      scene.self_collisions.push_back(std::move(rope));
    }
    if (chain.pin_first)
      scene.constraints.push_back(PinConstraint{ first, start });
    if (chain.pin_last)
      scene.constraints.push_back(
          PinConstraint{ next - 1, Vec3(start + (chain.particles - 1) * step) });
  }
  // each kind completes itself from the start: places particles on surfaces, anchors pins
  const std::size_t first_own = scene.constraints.size();
  for (const Constraint& written : d.constraints)
  {
    Constraint constraint = written;
    fillFromStart(constraint, scene.surfaces, state.positions, state.velocities);
    scene.constraints.push_back(constraint);
  }
  // placing particles (on a surface, along a chain) can take them out of range, or to NaN where a
  // surface is undefined: refused here, with why, before anything runs or is checked against them
  static const char* const AXES[] = { "x", "y", "z" };
  for (int i = 0; i < n; ++i)
    for (int axis = 0; axis < 3; ++axis)
      for (const bool velocity : { false, true })
      {
        const double value = velocity ? state.velocities(axis, i) : state.positions(axis, i);
        const Range& range = velocity ? limits::VELOCITY : limits::COORDINATE;
        if (!range.contains(value))
          throw InvalidInput("particle " + std::to_string(i) +
                                 (velocity ? " velocity." : " position.") + AXES[axis],
                             "= " + formatValue(value) +
                                 " where the scene places it (on its surface, along its chain), "
                                 "must be in " +
                                 range.text() +
                                 "; a surface must be defined, and its height and slope in "
                                 "range, where its particles start");
      }
  // a contact's particle starts on or above its surface: below it, the first step would have to
  // lift it out (an impact as deep as the start is wrong), so the file is refused, saying where
  // (the deepest one)
  if (const BelowSurface below =
          refuse_start_inside
              ? deepestBelowSurface(scene.constraints, EffectContext{ scene.surfaces, 0.0 },
                                    state.positions)
              : BelowSurface{};
      below.contact)
  {
    std::vector<std::string> surface_names;
    for (const NamedSurface& named : d.surfaces)
      surface_names.push_back(named.name);
    const bool surface = std::holds_alternative<SurfaceContact>(*below.contact);
    throw InvalidInput(
        "particle " + std::to_string(below.particle) + (surface ? " position.z" : " position"),
        "= [" + formatValue(state.positions(0, below.particle)) + ", " +
            formatValue(state.positions(1, below.particle)) + ", " +
            formatValue(state.positions(2, below.particle)) + "] where the scene places it, " +
            formatValue(below.depth) + " m " + contactTargetText(*below.contact, surface_names) +
            ", which its contact keeps it out of; start it " +
            (surface ? "on or above the surface" : "outside the obstacle"));
  }
  // a value taken from the start (an angle) is checked like one written in the file
  for (std::size_t k = 0; k < d.constraints.size(); ++k)
    validateConstraint(scene.constraints[first_own + k], n, static_cast<int>(scene.surfaces.size()),
                       "constraints[" + std::to_string(k) + "]");
  scene.forces = sceneForces(d);
  return built;
}

std::vector<Force> sceneForces(const SceneDescription& d)
{
  // the file's forces first, so forces[k] in a message is the file's k-th; the chains' after
  std::vector<Force> forces = d.forces;
  int next = static_cast<int>(d.particles.size());  // chains are numbered after the particles
  for (const ChainSpec& chain : d.chains)
  {
    // bending stiffness at each inner particle, spread over a link's length either side
    if (chain.bend_stiffness > 0.0)
      for (int i = next + 1; i + 1 < next + chain.particles; ++i)
        forces.push_back(BendingForce{ i - 1, i, i + 1, chain.bend_stiffness, chain.link_length });
    next += chain.particles;
  }
  return forces;
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

}  // namespace constrained_particles
