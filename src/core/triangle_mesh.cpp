#include "constrained_particles/core/triangle_mesh.hpp"

#include "constrained_particles/core/limits.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace constrained_particles
{
namespace
{
// The angle at vertex a of triangle a-b-c [rad]
double cornerAngle(const Vec3& a, const Vec3& b, const Vec3& c)
{
  return std::atan2((b - a).cross(c - a).norm(), (b - a).dot(c - a));
}

// Normals of a checked mesh: each face's, each edge's (its two faces' summed, in one order for
// both so that either triangle gives the same), each vertex's (angle-weighted), and the bounds
void completeNormals(TriangleMesh& mesh, const std::map<std::pair<int, int>, int>& edge_of)
{
  const std::size_t f = mesh.triangles.size();
  mesh.face_normals.resize(f);
  for (std::size_t t = 0; t < f; ++t)
  {
    const auto& v = mesh.triangles[t];
    const Vec3 n = (mesh.vertices[v[1]] - mesh.vertices[v[0]])
                       .cross(mesh.vertices[v[2]] - mesh.vertices[v[0]]);
    mesh.face_normals[t] = n.normalized();
  }
  mesh.edge_normals.resize(f);
  mesh.vertex_normals.assign(mesh.vertices.size(), Vec3::Zero());
  for (std::size_t t = 0; t < f; ++t)
  {
    const auto& v = mesh.triangles[t];
    for (int k = 0; k < 3; ++k)
    {
      const int a = v[k], b = v[(k + 1) % 3];
      const int other = edge_of.at({ b, a });  // the triangle across the edge
      const int first = std::min<int>(static_cast<int>(t), other),
                second = std::max<int>(static_cast<int>(t), other);
      mesh.edge_normals[t][k] = mesh.face_normals[first] + mesh.face_normals[second];
      const Vec3& p = mesh.vertices[v[k]];
      mesh.vertex_normals[v[k]] +=
          cornerAngle(p, mesh.vertices[v[(k + 1) % 3]], mesh.vertices[v[(k + 2) % 3]]) *
          mesh.face_normals[t];
    }
  }
  mesh.low = mesh.high = mesh.vertices[mesh.triangles[0][0]];
  for (const auto& v : mesh.triangles)
    for (int k = 0; k < 3; ++k)
    {
      mesh.low = mesh.low.cwiseMin(mesh.vertices[v[k]]);
      mesh.high = mesh.high.cwiseMax(mesh.vertices[v[k]]);
    }
}
}  // namespace

std::shared_ptr<const TriangleMesh> makeTriangleMesh(std::vector<Vec3> vertices,
                                                     std::vector<std::array<int, 3>> triangles,
                                                     const std::string& source,
                                                     const std::string& field,
                                                     std::shared_ptr<const TriangleIndex> index)
{
  const std::string where = source.empty() ? std::string("the mesh") : "'" + source + "'";
  if (!limits::MESH_TRIANGLES.contains(static_cast<double>(triangles.size())))
    throw InvalidInput(field, where + " has " + std::to_string(triangles.size()) +
                                  " triangles; a mesh obstacle has " +
                                  limits::MESH_TRIANGLES.text());
  for (std::size_t k = 0; k < vertices.size(); ++k)
    if (!limits::COORDINATE.contains(vertices[k].x()) ||
        !limits::COORDINATE.contains(vertices[k].y()) ||
        !limits::COORDINATE.contains(vertices[k].z()))
      throw InvalidInput(field, where + ": vertex " + std::to_string(k) + " is outside " +
                                    limits::COORDINATE.text() + " or not finite");
  const int n = static_cast<int>(vertices.size());
  // each directed edge once: a closed surface, consistently wound
  std::map<std::pair<int, int>, int> edge_of;
  double volume = 0.0;  // six times the enclosed volume (divergence theorem)
  for (std::size_t t = 0; t < triangles.size(); ++t)
  {
    const auto& v = triangles[t];
    for (int k = 0; k < 3; ++k)
      if (v[k] < 0 || v[k] >= n)
        throw InvalidInput(field, where + ": triangle " + std::to_string(t) + " names vertex " +
                                      std::to_string(v[k]) + " of " + std::to_string(n));
    const Vec3 normal = (vertices[v[1]] - vertices[v[0]]).cross(vertices[v[2]] - vertices[v[0]]);
    const double scale = std::max({ (vertices[v[1]] - vertices[v[0]]).squaredNorm(),
                                    (vertices[v[2]] - vertices[v[0]]).squaredNorm(),
                                    (vertices[v[2]] - vertices[v[1]]).squaredNorm() });
    if (!(normal.norm() > 1e-12 * scale))
      throw InvalidInput(field, where + ": triangle " + std::to_string(t) +
                                    " has no area (its vertices are on one line)");
    volume += vertices[v[0]].dot(normal);
    for (int k = 0; k < 3; ++k)
      if (!edge_of.emplace(std::make_pair(v[k], v[(k + 1) % 3]), static_cast<int>(t)).second)
        throw InvalidInput(field, where + ": the edge from vertex " + std::to_string(v[k]) +
                                      " to " + std::to_string(v[(k + 1) % 3]) +
                                      " is wound the same way by two triangles (" +
                                      std::to_string(edge_of.at({ v[k], v[(k + 1) % 3] })) +
                                      " and " + std::to_string(t) +
                                      "): not a consistently oriented, closed surface");
  }
  for (const auto& [edge, t] : edge_of)
    if (!edge_of.count({ edge.second, edge.first }))
      throw InvalidInput(field, where + ": the edge from vertex " + std::to_string(edge.first) +
                                    " to " + std::to_string(edge.second) + " (triangle " +
                                    std::to_string(t) +
                                    ") borders one triangle only: the mesh is not closed, so it "
                                    "has no inside to keep particles out of");
  if (volume < 0.0)  // wound inward: turned outward
  {
    for (auto& v : triangles)
      std::swap(v[1], v[2]);
    std::map<std::pair<int, int>, int> turned;
    for (const auto& [edge, t] : edge_of)
      turned.emplace(std::make_pair(edge.second, edge.first), t);
    edge_of.swap(turned);
  }
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->source = source;
  mesh->vertices = std::move(vertices);
  mesh->triangles = std::move(triangles);
  mesh->index = std::move(index);
  completeNormals(*mesh, edge_of);
  return mesh;
}

std::shared_ptr<const TriangleMesh> withIndex(const TriangleMesh& mesh,
                                              std::shared_ptr<const TriangleIndex> index)
{
  auto copy = std::make_shared<TriangleMesh>(mesh);
  copy->index = std::move(index);
  return copy;
}

TriangleFeature nearestOnTriangle(const TriangleMesh& mesh, int t, const Vec3& q)
{
  const auto& v = mesh.triangles[t];
  const Vec3 &a = mesh.vertices[v[0]], &b = mesh.vertices[v[1]], &c = mesh.vertices[v[2]];
  TriangleFeature out;
  out.triangle = t;
  auto done = [&](const Vec3& point, int feature)
  {
    out.point = point;
    out.feature = feature;
    out.squared_distance = (q - point).squaredNorm();
    return out;
  };
  const Vec3 ab = b - a, ac = c - a, ap = q - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0)
    return done(a, 4);
  const Vec3 bp = q - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3)
    return done(b, 5);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0)
    return done(a + d1 / (d1 - d3) * ab, 1);  // edge a-b
  const Vec3 cp = q - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6)
    return done(c, 6);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0)
    return done(a + d2 / (d2 - d6) * ac, 3);  // edge c-a
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0)
    return done(b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b), 2);  // edge b-c
  // the face: q's foot on the plane (by the normal, the barycentric sum rounds less)
  const Vec3& n = mesh.face_normals[t];
  return done(q - n * n.dot(q - a), 0);
}

int nearestTriangleByScan(const TriangleMesh& mesh, const Vec3& q)
{
  int best = 0;
  double least = std::numeric_limits<double>::infinity();
  for (int t = 0; t < static_cast<int>(mesh.triangles.size()); ++t)
  {
    const double d = nearestOnTriangle(mesh, t, q).squared_distance;
    if (d < least)
    {
      least = d;
      best = t;
    }
  }
  return best;
}

}  // namespace constrained_particles
