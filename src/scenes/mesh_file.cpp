/// @file mesh_file.cpp
/// @brief loadMeshFile (assimp) and makeMeshIndex (FCL): mesh_file.hpp.
#include "constrained_particles/scenes/mesh_file.hpp"

#include "constrained_particles/core/limits.hpp"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/AABB.h>

#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <tuple>
#include <vector>

namespace constrained_particles
{
namespace
{
// The nearest triangle by FCL's tree of axis-aligned boxes (FCL builds it: its splits are a
// well-kept library's): down the tree nearer child first, a subtree skipped where its box is no
// nearer than the best triangle so far, each leaf's triangle measured by the core's
// nearestOnTriangle (the scan's measure, exact). FCL's own distance query is not used: its
// sphere-triangle leaf reads an unset distance for a point on a triangle (FCL 0.7,
// sphere_triangle-inl.h), where a particle at rest on a face may lie.
class FclTriangleIndex : public TriangleIndex
{
public:
  explicit FclTriangleIndex(const TriangleMesh& mesh)
    : tree_(std::make_shared<fcl::BVHModel<fcl::AABBd>>())
    , triangles_(static_cast<int>(mesh.triangles.size()))
  {
    std::vector<fcl::Vector3d> vertices(mesh.vertices.begin(), mesh.vertices.end());
    std::vector<fcl::Triangle> triangles;
    triangles.reserve(mesh.triangles.size());
    for (const auto& t : mesh.triangles)
      triangles.emplace_back(t[0], t[1], t[2]);
    // a tree FCL could not build (no triangles, no memory) is none: the scan serves instead
    if (triangles.empty() ||
        tree_->beginModel(static_cast<int>(triangles.size()), static_cast<int>(vertices.size())) !=
            fcl::BVH_OK ||
        tree_->addSubModel(vertices, triangles) != fcl::BVH_OK || tree_->endModel() != fcl::BVH_OK)
      tree_.reset();
  }

  int nearest(const TriangleMesh& mesh, const Vec3& q) const override
  {
    if (!tree_ || static_cast<int>(mesh.triangles.size()) != triangles_)  // none, another's
      return nearestTriangleByScan(mesh, q);
    Nearest best{ 0, std::numeric_limits<double>::infinity() };
    descend(0, mesh, q, best);
    return best.triangle;
  }

private:
  struct Nearest
  {
    int triangle;
    double squared_distance;  // [m^2]
  };

  // the squared distance from q to node's box [m^2]: no triangle under it is nearer
  double boxDistance(int node, const Vec3& q) const
  {
    const fcl::AABBd& box = tree_->getBV(node).bv;
    const Vec3 out = (box.min_ - q).cwiseMax(q - box.max_).cwiseMax(0.0);
    return out.squaredNorm();
  }

  void descend(int node, const TriangleMesh& mesh, const Vec3& q, Nearest& best) const
  {
    const fcl::BVNode<fcl::AABBd>& here = tree_->getBV(node);
    if (here.isLeaf())
    {
      const int t = here.primitiveId();
      const double d = nearestOnTriangle(mesh, t, q).squared_distance;
      if (d < best.squared_distance)
        best = { t, d };
      return;
    }
    int near = here.leftChild(), far = here.rightChild();
    double d_near = boxDistance(near, q), d_far = boxDistance(far, q);
    if (d_far < d_near)
    {
      std::swap(near, far);
      std::swap(d_near, d_far);
    }
    if (d_near < best.squared_distance)
      descend(near, mesh, q, best);
    if (d_far < best.squared_distance)
      descend(far, mesh, q, best);
  }

  std::shared_ptr<fcl::BVHModel<fcl::AABBd>> tree_;
  int triangles_;
};

// Every triangle under `node`, in the file's frame (`to_file`: the node's transform so far),
// coincident vertices joined and a triangle with two of them dropped (it has no area, and the
// surface stays closed without it); a vertex not finite is refused naming `field`
void collect(const aiScene& scene, const aiNode& node, const aiMatrix4x4& to_file,
             const Vec3& scale, std::map<std::tuple<double, double, double>, int>& index_of,
             std::vector<Vec3>& vertices, std::vector<std::array<int, 3>>& triangles,
             const std::string& field)
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
      if (!scaled.allFinite())  // before the map: NaN has no order
        throw InvalidInput(field, "has a vertex that is not finite");
      const auto [at, added] = index_of.emplace(std::make_tuple(scaled.x(), scaled.y(), scaled.z()),
                                                static_cast<int>(vertices.size()));
      if (added)
        vertices.push_back(scaled);
      joined[v] = at->second;
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f)
    {
      if (mesh.mFaces[f].mNumIndices != 3)  // points and lines are no surface
        continue;
      const std::array<int, 3> t = { joined[mesh.mFaces[f].mIndices[0]],
                                     joined[mesh.mFaces[f].mIndices[1]],
                                     joined[mesh.mFaces[f].mIndices[2]] };
      if (t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
        triangles.push_back(t);
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c)
    collect(scene, *node.mChildren[c], transform, scale, index_of, vertices, triangles, field);
}
}  // namespace

std::string FileResolver::resolve(const std::string& uri, const std::string& field) const
{
  static const std::string FILE = "file://", PACKAGE = "package://";
  if (uri.empty())
    throw InvalidInput(field, "is empty: name the mesh file");
  if (uri.rfind(FILE, 0) == 0)
  {
    if (uri.size() == FILE.size() || uri[FILE.size()] != '/')
      throw InvalidInput(field, "= '" + uri + "': a file:// name is absolute (file:///path)");
    return uri.substr(FILE.size());
  }
  if (uri.rfind(PACKAGE, 0) == 0)
  {
    const std::string rest = uri.substr(PACKAGE.size());
    const std::size_t slash = rest.find('/');
    const std::string package = rest.substr(0, slash);
    if (!package_path)
      throw InvalidInput(field, "= '" + uri +
                                    "': package:// names are found through ROS's package path, "
                                    "which is not given here");
    const std::string directory = package_path(package);
    if (directory.empty())
      throw InvalidInput(
          field, "= '" + uri + "': package '" + package + "' is not found on ROS's package path");
    return directory + (slash == std::string::npos ? "" : rest.substr(slash));
  }
  if (uri.find("://") != std::string::npos)
    throw InvalidInput(field, "= '" + uri +
                                  "': only file://, package:// and plain paths name a "
                                  "mesh file");
  if (uri.front() == '/')
    return uri;
  if (directory.empty())
    throw InvalidInput(field, "= '" + uri +
                                  "': a relative path needs a scene file to be relative to; give "
                                  "an absolute path, file:///... or package://...");
  return directory + "/" + uri;
}

std::shared_ptr<const TriangleIndex> makeMeshIndex(const TriangleMesh& mesh)
{
  return std::make_shared<FclTriangleIndex>(mesh);
}

std::shared_ptr<const TriangleMesh> loadMeshFile(const std::string& path, const Vec3& scale,
                                                 const std::string& field)
{
  for (int axis = 0; axis < 3; ++axis)  // a negative factor mirrors: its size is checked
    if (!limits::MESH_SCALE.contains(std::abs(scale[axis])))
      throw InvalidInput(field + ".scale",
                         "= " + formatValue(scale[axis]) + " along " + std::string(1, "xyz"[axis]) +
                             ": its size must be in " + limits::MESH_SCALE.text() +
                             " (a negative factor mirrors)");
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
  collect(*scene, *scene->mRootNode, aiMatrix4x4(), scale, index_of, vertices, triangles,
          field + ".file");
  // a mirroring scale winds every triangle inward: makeTriangleMesh turns each shell out
  std::shared_ptr<const TriangleMesh> mesh =
      makeTriangleMesh(std::move(vertices), std::move(triangles), path, field + ".file");
  return withIndex(*mesh, makeMeshIndex(*mesh));
}

}  // namespace constrained_particles
