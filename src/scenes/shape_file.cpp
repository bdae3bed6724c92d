// The surfaces and obstacle shapes of scene files (scene_file.cpp reads the rest), through
// yaml-cpp and the core's field descriptors, so names and ranges are the core's.
#include "yaml_readers.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <type_traits>
#include <variant>

namespace constrained_particles
{
namespace scene_yaml
{
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

// An obstacle: its type, then the keys that type reads (ShapeSpec's), each in its range
Shape parseShape(const Where& where, const YAML::Node& node, const std::string& name,
                 const FileResolver& files)
{
  requireMap(where, node, "a shape");
  if (!node["type"])
    fail(where / "type", node, "is missing; valid: " + joined(shapeTypeNames()));
  Shape shape;
  shape.name = name;
  shape.type =
      parseShapeType(readString(where / "type", node["type"]), where.at(node["type"]) + ".type");
  std::vector<std::string> keys = { "type", "position", "rpy", "frame", "topic" };
  if (shape.type == ShapeType::Box)
    keys.push_back("size");
  if (shape.type == ShapeType::Sphere || shape.type == ShapeType::Capsule ||
      shape.type == ShapeType::Cylinder)
    keys.push_back("radius");
  if (shape.type == ShapeType::Capsule || shape.type == ShapeType::Cylinder)
    keys.push_back("length");
  if (shape.type == ShapeType::Mesh)
  {
    keys.push_back("file");
    keys.push_back("scale");
  }
  checkKeys(where, node, keys, std::string("a ") + shapeTypeName(shape.type));
  // read first (a wrong type names its key and line itself), then checked against the ranges
  Vec3 rpy = Vec3::Zero();
  if (node["position"])
    shape.position = readVector(where / "position", node["position"]);
  if (node["rpy"])
    rpy = readVector(where / "rpy", node["rpy"]);
  if (node["radius"])
    shape.radius = readDouble(where / "radius", node["radius"]);
  if (node["length"])
    shape.length = readDouble(where / "length", node["length"]);
  if (node["size"])
    shape.size = readVector(where / "size", node["size"]);
  // carried by a tf frame or a PoseStamped topic: position and rpy are then in its frame
  if (node["frame"])
    shape.frame = readString(where / "frame", node["frame"]);
  if (node["topic"])
    shape.topic = readString(where / "topic", node["topic"]);
  if (shape.type == ShapeType::Mesh && !node["file"])
    fail(where / "file", node,
         "is missing: a mesh reads its triangles from a file (STL, OBJ, DAE)");
  std::string file;  // read outside the try: a non-string names its own key and line
  if (shape.type == ShapeType::Mesh)
    file = readString(where / "file", node["file"]);
  Vec3 scale = Vec3::Ones();
  if (node["scale"])
    scale = readVector(where / "scale", node["scale"]);
  try
  {
    if (shape.type == ShapeType::Mesh)  // first, as before the ranges: its file, then its scale
      shape.mesh = loadMeshFile(files.resolve(file, "file"), scale, "");
    requireInRange("rpy", rpy, limits::SHAPE_ANGLE);
    shape.rotation = rotationFromRpy(rpy);
    validateShape(shape, "");
  }
  catch (const InvalidInput& e)
  {
    // the field is ".radius", ".size.x", "rpy.z", "file" or ".scale": name it at its line
    std::string key = e.field();
    if (!key.empty() && key[0] == '.')
      key = key.substr(1);
    const std::size_t dot = key.find('.');
    const std::string top = dot == std::string::npos ? key : key.substr(0, dot);
    const std::string message = e.what();
    fail(where / key, node[top], message.substr(e.field().size() + 1));
  }
  return shape;
}

}  // namespace scene_yaml

namespace
{
// Whether `constraint` names shape `name` (in a Shape field, as shape_contact's and
// segment_contact's `shape`), putting `replacement` there if given.
bool namesShape(Constraint& constraint, const std::string& name, const Shape* replacement)
{
  bool names = false;
  std::visit(
      [&](auto& record)
      {
        forEachField<std::decay_t<decltype(record)>>(
            [&](const auto& spec)
            {
              if constexpr (std::is_same_v<typename std::decay_t<decltype(spec)>::MemberType,
                                           Shape>)
                if (Shape& shape = record.*(spec.member); shape.name == name)
                {
                  names = true;
                  if (replacement)
                    shape = *replacement;
                }
            });
      },
      constraint);
  return names;
}

// The shape ~set_obstacle's `shape` field writes, as a scene file writes one under `shapes`.
Shape parseObstacle(const std::string& yaml, const std::string& name, const FileResolver& files)
{
  static const std::string SOURCE = "shape";
  Shape shape;
  try
  {
    shape = scene_yaml::parseShape(scene_yaml::Where{ SOURCE, "" }, YAML::Load(yaml), name, files);
  }
  catch (const YAML::Exception& e)  // not YAML, or a value yaml-cpp cannot convert
  {
    throw InvalidInput(SOURCE + (e.mark.is_null() ? "" : ":" + std::to_string(e.mark.line + 1)),
                       "is not a valid shape: " + e.msg);
  }
  return shape;
}
}  // namespace

void changeObstacle(SceneDescription& d, ObstacleChange change, const std::string& name,
                    const std::string& shape_yaml, const FileResolver& files)
{
  if (name.empty())
    throw InvalidInput("name", "is empty: name the shape (its key under `shapes`)");
  const auto found = std::find_if(d.shapes.begin(), d.shapes.end(),
                                  [&name](const Shape& shape) { return shape.name == name; });
  if (change == ObstacleChange::Add && found != d.shapes.end())
    throw InvalidInput("name", "= '" + name + "' is a shape of scene '" + d.name +
                                   "' already: replace it (REPLACE), or add another name");
  if (change != ObstacleChange::Add)
  {
    std::string names;
    for (const Shape& shape : d.shapes)
      names += (names.empty() ? "" : ", ") + shape.name;
    if (found == d.shapes.end())
      throw InvalidInput("name", "= '" + name + "' is not a shape of scene '" + d.name +
                                     "'; its shapes: " + (names.empty() ? "none" : names));
  }
  if (change == ObstacleChange::Remove)
  {
    if (!shape_yaml.empty())
      throw InvalidInput("shape", "must be empty to remove a shape (REMOVE)");
    d.shapes.erase(found);
    for (ChainSpec& chain : d.chains)
      chain.obstacles.erase(std::remove(chain.obstacles.begin(), chain.obstacles.end(), name),
                            chain.obstacles.end());
    d.constraints.erase(
        std::remove_if(d.constraints.begin(), d.constraints.end(),
                       [&name](Constraint& c) { return namesShape(c, name, nullptr); }),
        d.constraints.end());
    return;
  }
  const Shape shape = parseObstacle(shape_yaml, name, files);
  // a box's, cylinder's or mesh's sharp edges against a point, and capsule links against a mesh:
  // refused as a scene file's are
  for (std::size_t k = 0; k < d.chains.size(); ++k)
  {
    const ChainSpec& chain = d.chains[k];
    if (change != ObstacleChange::Add &&
        std::find(chain.obstacles.begin(), chain.obstacles.end(), name) == chain.obstacles.end())
      continue;
    requireRoundedEdges(shape, chain.radius, "chains[" + std::to_string(k) + "].radius");
    if (chain.capsules && shape.type == ShapeType::Mesh)
      throw InvalidInput("shape", "is a mesh, and chain " + std::to_string(k) +
                                      " keeps its links out of its obstacles as capsules "
                                      "(capsules: true), which a mesh cannot be (not convex)");
  }
  if (change == ObstacleChange::Replace)
  {
    *found = shape;
    for (Constraint& constraint : d.constraints)
      namesShape(constraint, name, &shape);
    return;
  }
  if (d.chains.empty())
    throw InvalidInput("operation", "= ADD, but scene '" + d.name +
                                        "' has no chain to keep out of it (an added shape is "
                                        "kept out by every chain)");
  if (!limits::SHAPES.contains(static_cast<double>(d.shapes.size() + 1)))
    throw InvalidInput("operation",
                       "= ADD, but scene '" + d.name + "' has " + std::to_string(d.shapes.size()) +
                           " shapes already; shapes must be in " + limits::SHAPES.text());
  d.shapes.push_back(shape);
  for (ChainSpec& chain : d.chains)
    chain.obstacles.push_back(name);
}

}  // namespace constrained_particles
