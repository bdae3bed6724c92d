/// @file triangle_mesh.hpp
/// @brief A closed triangle mesh as an obstacle (ShapeType::Mesh, issue 48 item 1): its signed
/// distance, gradient and Hessian at a point, exactly, from the nearest triangle's nearest
/// feature (a face, an edge or a vertex) and the sign of that feature's angle-weighted
/// pseudonormal (Baerentzen and Aanaes 2005, "Signed distance computation using the angle
/// weighted pseudonormal", IEEE TVCG 11(3)). docs/physics.md, "Obstacles".
///
/// Finding the nearest triangle is collision detection's job, not this project's: the search is
/// a TriangleIndex the mesh is given from outside the core (src/scenes/mesh_file.cpp builds
/// one on FCL's bounding-volume tree, as MoveIt does); without one every triangle is tried.
/// The core keeps to Eigen and the standard library.
#pragma once

#include "constrained_particles/core/types.hpp"

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace constrained_particles
{
struct TriangleMesh;

/// A nearest-triangle search over one mesh's triangles (a bounding-volume tree).
class TriangleIndex
{
public:
  virtual ~TriangleIndex() = default;
  /// The index of a triangle of `mesh` nearest `q` [m] (the mesh's local frame). Thread-safe:
  /// called from the physics thread and from studies running beside it.
  virtual int nearest(const TriangleMesh& mesh, const Vec3& q) const = 0;
};

/// A closed, consistently oriented triangle mesh, in its own (the shape's local) frame [m].
/// Made by makeTriangleMesh, which checks it and computes the normals; const afterwards and
/// shared between the scenes, models and studies that hold it.
struct TriangleMesh
{
  std::string source;  ///< where it was read from (a file), for messages and markers
  std::vector<Vec3> vertices;
  /// Vertex indices, counter-clockwise seen from outside (the enclosed volume positive).
  std::vector<std::array<int, 3>> triangles;
  std::vector<Vec3> face_normals;                 ///< unit, outward, per triangle
  std::vector<std::array<Vec3, 3>> edge_normals;  ///< per triangle, edge k from vertex k to k+1:
                                                  ///< the two faces' normals summed (unnormalised)
  std::vector<Vec3> vertex_normals;               ///< angle-weighted sums (unnormalised)
  /// Per triangle and edge: its two faces coplanar (the distance is flat across it)
  std::vector<std::array<bool, 3>> flat_edges;
  /// Per vertex: 1 if every face round it is coplanar (flat there too)
  std::vector<char> flat_vertices;
  Vec3 low = Vec3::Zero(), high = Vec3::Zero();  ///< the vertices' bounding box [m]
  std::shared_ptr<const TriangleIndex> index;    ///< the search; null: every triangle tried
};

/// Checks and completes a mesh: at least 4 triangles and at most limits::MESH_TRIANGLES, finite
/// vertices within limits::COORDINATE, every index a vertex, no triangle of zero area, closed
/// and consistently oriented (each edge shared by exactly two triangles, once in each
/// direction: a watertight surface, so inside and outside are defined), no two triangles back
/// to back. The shells (triangles joined by edges) are turned so that the solid is what their
/// windings enclose: all of them if their total volume is negative (a file wound inward, a
/// mirroring scale); then a shell still wound inward is a cavity if it lies inside a shell wound
/// outward, and is turned outward if it lies inside none. Not checked: shells that cross or
/// overlap, or touch at a vertex (there the sign is each shell's, so a point inside one near
/// another's face may read as outside). Faces count as coplanar (the distance flat across their
/// edge) within 1e-12 of the cosine: a file's slightly bent faces keep their thin edge regions.
/// Vertices no triangle uses are kept.
/// @throws InvalidInput naming `field`, saying which triangle, edge or vertex is at fault
std::shared_ptr<const TriangleMesh> makeTriangleMesh(
    std::vector<Vec3> vertices, std::vector<std::array<int, 3>> triangles,
    const std::string& source, const std::string& field,
    std::shared_ptr<const TriangleIndex> index = nullptr);

/// The same mesh with a search given to it (the mesh's own is replaced).
std::shared_ptr<const TriangleMesh> withIndex(const TriangleMesh& mesh,
                                              std::shared_ptr<const TriangleIndex> index);

/// The nearest point of triangle t to q, and which feature it lies on.
struct TriangleFeature
{
  Vec3 point = Vec3::Zero();  ///< [m]
  int triangle = 0;
  /// 0: the face's interior; 1, 2, 3: edge k - 1 (from vertex k - 1 to k); 4, 5, 6: vertex k - 4
  int feature = 0;
  double squared_distance = 0.0;  ///< |q - point|^2 [m^2]
};

/// Triangle t's point nearest q (Ericson 2005, "Real-Time Collision Detection", 5.1.5, by
/// Voronoi regions). Stateless; no allocation.
TriangleFeature nearestOnTriangle(const TriangleMesh& mesh, int t, const Vec3& q);

/// The nearest triangle by trying every one (the reference a TriangleIndex is tested against).
int nearestTriangleByScan(const TriangleMesh& mesh, const Vec3& q);

}  // namespace constrained_particles
