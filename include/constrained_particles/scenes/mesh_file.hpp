/// @file mesh_file.hpp
/// @brief Triangle meshes from files as obstacles (ShapeType::Mesh): read by assimp (Debian's
/// libassimp-dev: STL, OBJ, DAE and the other formats robots ship their collision meshes in),
/// searched by FCL's bounding-volume tree (libfcl-dev, MoveIt's collision library). Both are
/// well-kept libraries for work that is not this project's trade; the distance itself is the
/// core's (triangle_mesh.hpp). No ROS.
#pragma once

#include "constrained_particles/core/triangle_mesh.hpp"

#include <functional>
#include <memory>
#include <string>

namespace constrained_particles
{
/// Where a mesh's file is: a scene file's `file:` or a URDF's `<mesh filename>`.
struct FileResolver
{
  /// Relative paths are from here (the scene file's directory); empty: refused (a scene given
  /// as text, a ~set_obstacle request: no file to be relative to)
  std::string directory;
  /// A ROS package's directory by name, for `package://<package>/<path>` (the ROS layer gives
  /// roslib's ros::package::getPath); empty, or an empty answer: such paths are refused
  std::function<std::string(const std::string& package)> package_path;

  /// The file `uri` names: an absolute path, `file://<absolute path>`, a path relative to
  /// `directory`, or `package://<package>/<path>`.
  /// @throws InvalidInput naming `field` for a package it cannot find, a relative path with no
  /// `directory`, or another scheme
  std::string resolve(const std::string& uri, const std::string& field) const;
};

/// The closed mesh in the file at `path`, every node's triangles in the file's own frame (its
/// nodes' transforms applied; a DAE's up axis left as written, as URDF reads it, and its <unit>
/// applied; assimp keeps vertices in float), each vertex
/// scaled by `scale` along the local axes (a negative factor mirrors), coincident vertices
/// joined (an STL writes each triangle's own) and triangles two of whose corners coincide
/// dropped, with an FCL search (makeMeshIndex).
/// @throws InvalidInput naming `field`.file or `field`.scale: no such file, one assimp cannot
/// read, a vertex not finite, a scale factor whose size is out of limits::MESH_SCALE, or a mesh
/// makeTriangleMesh refuses (not closed, too many triangles ...)
std::shared_ptr<const TriangleMesh> loadMeshFile(const std::string& path, const Vec3& scale,
                                                 const std::string& field);

/// A search over `mesh`'s triangles on FCL's bounding-volume tree (axis-aligned boxes, FCL's
/// splits), descended nearer child first and pruned by box distance: about O(log F) triangles
/// measured for a mesh of F, where a scan measures every one; exact (the same measure).
std::shared_ptr<const TriangleIndex> makeMeshIndex(const TriangleMesh& mesh);

}  // namespace constrained_particles
