// The surfaces and obstacle shapes of scene files (scene_file.cpp reads the rest), through
// yaml-cpp and the core's field descriptors, so names and ranges are the core's.
#include "yaml_readers.hpp"

#include <Eigen/Geometry>

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
Shape parseShape(const Where& where, const YAML::Node& node, const std::string& name)
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
  try
  {
    requireInRange("rpy", rpy, limits::SHAPE_ANGLE);
    shape.rotation = rotationFromRpy(rpy);
    validateShape(shape, "");
  }
  catch (const InvalidInput& e)
  {
    // the field is ".radius", ".size.x" or "rpy.z": name it at its line
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
}  // namespace constrained_particles
