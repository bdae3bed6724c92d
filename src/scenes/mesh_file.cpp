/// @file mesh_file.cpp
/// @brief loadMeshFile (assimp) and makeMeshIndex (FCL): mesh_file.hpp.
#include "constrained_particles/scenes/mesh_file.hpp"

#include "constrained_particles/core/limits.hpp"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/distance.h>

#include <array>
#include <fstream>
#include <map>
#include <tuple>
#include <vector>

namespace constrained_particles
{
namespace
{
// FCL's nearest triangle: the distance from a sphere of radius 0 at q to the tree's triangles
// (exact: rel_err = abs_err = 0); on a triangle FCL says -1 with that triangle
class FclTriangleIndex : public TriangleIndex
{
public:
  explicit FclTriangleIndex(const TriangleMesh& mesh)
    : tree_(std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>())
    , point_(std::make_shared<fcl::Sphered>(0.0))
    , triangles_(static_cast<int>(mesh.triangles.size()))
  {
    std::vector<fcl::Vector3d> vertices(mesh.vertices.begin(), mesh.vertices.end());
    std::vector<fcl::Triangle> triangles;
    triangles.reserve(mesh.triangles.size());
    for (const auto& t : mesh.triangles)
      triangles.emplace_back(t[0], t[1], t[2]);
    tree_->beginModel(static_cast<int>(triangles.size()), static_cast<int>(vertices.size()));
    tree_->addSubModel(vertices, triangles);
    tree_->endModel();
  }

  int nearest(const TriangleMesh& mesh, const Vec3& q) const override
  {
    fcl::DistanceRequestd request;
    request.gjk_solver_type = fcl::GST_INDEP;  // its sphere-triangle distance is closed-form
    fcl::DistanceResultd result;
    fcl::distance(tree_.get(), fcl::Transform3d::Identity(), point_.get(),
                  fcl::Transform3d(Eigen::Translation3d(q)), request, result);
    // a triangle FCL did not name (an empty result) falls back to the scan
    return result.b1 >= 0 && result.b1 < triangles_ ? result.b1 : nearestTriangleByScan(mesh, q);
  }

private:
  std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> tree_;
  std::shared_ptr<fcl::Sphered> point_;
  int triangles_;
};

// Every triangle under `node`, in the file's frame (`to_file`: the node's transform so far)
void collect(const aiScene& scene, const aiNode& node, const aiMatrix4x4& to_file,
             const Vec3& scale, std::map<std::tuple<double, double, double>, int>& index_of,
             std::vector<Vec3>& vertices, std::vector<std::array<int, 3>>& triangles)
{
  const aiMatrix4x4 transform = to_file * node.mTransformation;
  for (unsigned m = 0; m < node.mNumMeshes; ++m)
  {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[m]];
    std::vector<int> joined(mesh.mNumVertices);
    for (unsigned v = 0; v < mesh.mNumVertices; ++v)
    {
      const aiVector3D p = transform * mesh.mVertices[v];
      const Vec3 scaled = scale.cwiseProduct(Vec3(p.x, p.y, p.z));
      const auto [at, added] = index_of.emplace(std::make_tuple(scaled.x(), scaled.y(), scaled.z()),
                                                static_cast<int>(vertices.size()));
      if (added)
        vertices.push_back(scaled);
      joined[v] = at->second;
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f)
      if (mesh.mFaces[f].mNumIndices == 3)  // points and lines are no surface
        triangles.push_back({ joined[mesh.mFaces[f].mIndices[0]],
                              joined[mesh.mFaces[f].mIndices[1]],
                              joined[mesh.mFaces[f].mIndices[2]] });
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c)
    collect(scene, *node.mChildren[c], transform, scale, index_of, vertices, triangles);
}
}  // namespace

std::string FileResolver::resolve(const std::string& uri, const std::string& field) const
{
  static const std::string FILE = "file://", PACKAGE = "package://";
  if (uri.rfind(FILE, 0) == 0)
    return uri.substr(FILE.size());
  if (uri.rfind(PACKAGE, 0) == 0)
  {
    const std::string rest = uri.substr(PACKAGE.size());
    const std::size_t slash = rest.find('/');
    const std::string package = rest.substr(0, slash);
    const std::string directory = package_path ? package_path(package) : std::string();
    if (directory.empty())
      throw InvalidInput(field, "= '" + uri + "': package '" + package +
                                    "' is not found (no ROS package path here)");
    return directory + (slash == std::string::npos ? "" : rest.substr(slash));
  }
  if (uri.find("://") != std::string::npos)
    throw InvalidInput(field, "= '" + uri +
                                  "': only file://, package:// and plain paths name a "
                                  "mesh file");
  if (uri.empty() || uri.front() == '/' || directory.empty())
    return uri;
  return directory + "/" + uri;
}

std::shared_ptr<const TriangleIndex> makeMeshIndex(const TriangleMesh& mesh)
{
  return std::make_shared<FclTriangleIndex>(mesh);
}

std::shared_ptr<const TriangleMesh> loadMeshFile(const std::string& path, const Vec3& scale,
                                                 const std::string& field)
{
  for (int axis = 0; axis < 3; ++axis)
    if (!limits::MESH_SCALE.contains(scale[axis]))
      throw InvalidInput(field + ".scale", "= " + formatValue(scale[axis]) + " along " +
                                               std::string(1, "xyz"[axis]) + ", must be in " +
                                               limits::MESH_SCALE.text());
  if (!std::ifstream(path).good())
    throw InvalidInput(field + ".file", "= '" + path + "': no such file (or not readable)");
  Assimp::Importer importer;
  // URDF reads a DAE's vertices as written, in the link's frame (no Y-up turn)
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate);
  if (!scene || !scene->mRootNode)
    throw InvalidInput(field + ".file", "= '" + path + "': assimp cannot read it (" +
                                            importer.GetErrorString() + ")");
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 3>> triangles;
  std::map<std::tuple<double, double, double>, int> index_of;
  collect(*scene, *scene->mRootNode, aiMatrix4x4(), scale, index_of, vertices, triangles);
  // a mirroring scale (an odd number of negative factors) is refused by the range: no winding flip
  std::shared_ptr<const TriangleMesh> mesh =
      makeTriangleMesh(std::move(vertices), std::move(triangles), path, field + ".file");
  return withIndex(*mesh, makeMeshIndex(*mesh));
}

}  // namespace constrained_particles
