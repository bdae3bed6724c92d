/// @file robot_shapes.cpp
/// @brief robotLinkShapes: URDF collision elements (urdfdom) to obstacle shapes.
#include "constrained_particles/scenes/robot_shapes.hpp"

#include "constrained_particles/scenes/mesh_file.hpp"

#include "constrained_particles/core/limits.hpp"
#include "constrained_particles/core/types.hpp"

#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>

#include <algorithm>

namespace constrained_particles
{
namespace
{
// urdfdom's pose as the shape's position and rotation (world, here the link's, from local)
void placeAt(const urdf::Pose& pose, Shape& shape)
{
  shape.position = Vec3(pose.position.x, pose.position.y, pose.position.z);
  double x = 0, y = 0, z = 0, w = 1;
  pose.rotation.getQuaternion(x, y, z, w);
  shape.rotation = Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix();
}

// One collision element of link `link` as a shape, or a refusal naming `field`; a mesh's file
// found by `files`
Shape shapeOf(const urdf::Collision& collision, const std::string& link, const std::string& field,
              const FileResolver& files)
{
  if (!collision.geometry)
    throw InvalidInput(field, "= '" + link + "': a collision element has no geometry");
  Shape shape;
  shape.frame = link;
  placeAt(collision.origin, shape);
  switch (collision.geometry->type)
  {
    case urdf::Geometry::SPHERE:
      shape.type = ShapeType::Sphere;
      shape.radius = static_cast<const urdf::Sphere&>(*collision.geometry).radius;
      break;
    case urdf::Geometry::BOX:
    {
      const urdf::Vector3& dim = static_cast<const urdf::Box&>(*collision.geometry).dim;
      shape.type = ShapeType::Box;
      shape.size = Vec3(dim.x, dim.y, dim.z);
      break;
    }
    case urdf::Geometry::CYLINDER:
    {
      const auto& cylinder = static_cast<const urdf::Cylinder&>(*collision.geometry);
      shape.type = ShapeType::Cylinder;
      shape.radius = cylinder.radius;
      shape.length = cylinder.length;
      break;
    }
    case urdf::Geometry::MESH:
    {
      const auto& mesh = static_cast<const urdf::Mesh&>(*collision.geometry);
      shape.type = ShapeType::Mesh;
      try
      {
        shape.mesh = loadMeshFile(files.resolve(mesh.filename, "file"),
                                  Vec3(mesh.scale.x, mesh.scale.y, mesh.scale.z), "");
      }
      catch (const InvalidInput& e)  // the mesh's file or scale, said for this link
      {
        // "file = '...': no such file" -> "its collision <mesh> filename = '...': no such file"
        const std::string message = e.what();
        const bool scale = e.field().find("scale") != std::string::npos;
        throw InvalidInput(field, "= '" + link + "': its collision <mesh> " +
                                      (scale ? "scale " : "filename ") +
                                      message.substr(e.field().size() + 1));
      }
      break;
    }
  }
  return shape;
}
}  // namespace

std::vector<Shape> robotLinkShapes(const std::string& urdf, const std::vector<std::string>& links,
                                   const std::string& field, const FileResolver& files)
{
  if (links.empty())
    return {};
  if (urdf.empty())
    throw InvalidInput(field,
                       "names robot links, but no robot description was given (the "
                       "robot_description parameter: the robot's URDF)");
  // urdfdom logs its parse errors through console_bridge and returns null
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf);
  if (!model)
    throw InvalidInput(field,
                       "names robot links, but the robot description is not a URDF "
                       "urdfdom can parse (its log says why)");
  std::vector<Shape> shapes;
  for (std::size_t i = 0; i < links.size(); ++i)
  {
    const std::string at = field + "[" + std::to_string(i) + "]";
    const std::string& name = links[i];
    if (std::find(links.begin(), links.begin() + static_cast<long>(i), name) !=
        links.begin() + static_cast<long>(i))
      throw InvalidInput(at, "= '" + name + "' is named twice");
    const urdf::LinkConstSharedPtr link = model->getLink(name);
    if (!link)
      throw InvalidInput(at, "= '" + name + "' is not a link of robot '" + model->getName() + "'");
    std::vector<urdf::CollisionSharedPtr> elements = link->collision_array;
    if (elements.empty() && link->collision)
      elements.push_back(link->collision);
    if (elements.empty())
      throw InvalidInput(at, "= '" + name + "' has no collision geometry");
    for (std::size_t k = 0; k < elements.size(); ++k)
    {
      Shape shape = shapeOf(*elements[k], name, at, files);
      shape.name = elements.size() == 1 ? name : name + "_" + std::to_string(k);
      validateShape(shape, at + " (" + shape.name + ")");
      shapes.push_back(shape);
    }
  }
  return shapes;
}

}  // namespace constrained_particles
