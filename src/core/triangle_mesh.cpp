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

using EdgeMap = std::map<std::pair<int, int>, int>;  // directed edge -> its triangle

// A vertex's place, for messages: its index and coordinates
std::string vertexText(const std::vector<Vec3>& vertices, int v)
{
  const Vec3& p = vertices[v];
  return "vertex " + std::to_string(v) + " (" + formatValue(p.x()) + ", " + formatValue(p.y()) +
         ", " + formatValue(p.z()) + ")";
}

// Each directed edge's triangle; refused (naming `field`) unless every edge is wound once each
// way: a closed, consistently wound surface
EdgeMap edgesOf(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles,
                const std::string& where, const std::string& field)
{
  EdgeMap edge_of;
  for (std::size_t t = 0; t < triangles.size(); ++t)
  {
    const auto& v = triangles[t];
    for (int k = 0; k < 3; ++k)
    {
      const auto edge = std::make_pair(v[k], v[(k + 1) % 3]);
      if (!edge_of.emplace(edge, static_cast<int>(t)).second)
        throw InvalidInput(
            field, where + ": the edge from " + vertexText(vertices, edge.first) + " to " +
                       vertexText(vertices, edge.second) + " is wound the same way by triangles " +
                       std::to_string(edge_of.at(edge)) + " and " + std::to_string(t) +
                       " (or borders more than two): not a consistently "
                       "oriented, closed surface");
    }
  }
  for (const auto& [edge, t] : edge_of)
    if (!edge_of.count({ edge.second, edge.first }))
      throw InvalidInput(field, where + ": the edge from " + vertexText(vertices, edge.first) +
                                    " to " + vertexText(vertices, edge.second) + " (triangle " +
                                    std::to_string(t) +
                                    ") borders one triangle only: the mesh is not closed, so it "
                                    "has no inside to keep particles out of");
  return edge_of;
}

// The winding number of the closed shell `members` about point p: the solid angles its triangles
// subtend, summed over 4 pi (Van Oosterom and Strackee 1983): 1 inside an outward shell, 0
// outside, -1 inside an inward one
double windingNumber(const std::vector<Vec3>& vertices,
                     const std::vector<std::array<int, 3>>& triangles,
                     const std::vector<int>& members, const Vec3& p)
{
  double sum = 0.0;
  for (const int t : members)
  {
    const Vec3 a = vertices[triangles[t][0]] - p, b = vertices[triangles[t][1]] - p,
               c = vertices[triangles[t][2]] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    sum += 2.0 * std::atan2(a.dot(b.cross(c)),
                            la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la);
  }
  return sum / (4.0 * M_PI);
}

// Each shell (triangles joined by edges) turned so that the solid is what its windings enclose:
// all turned if their total volume is negative (a file wound inward, a mirroring scale); then a
// shell still wound inward is a cavity where it lies inside an outward shell, and is turned
// outward where it lies inside none (a shell wound against the others)
void turnShellsOut(const std::vector<Vec3>& vertices, std::vector<std::array<int, 3>>& triangles,
                   const EdgeMap& edge_of)
{
  std::vector<int> shell_of(triangles.size(), -1);
  std::vector<std::vector<int>> shells;
  std::vector<double> volumes;  // six times each shell's enclosed volume (divergence theorem)
  double total = 0.0;
  for (std::size_t seed = 0; seed < triangles.size(); ++seed)
  {
    if (shell_of[seed] >= 0)
      continue;
    const int id = static_cast<int>(shells.size());
    std::vector<int> members{ static_cast<int>(seed) };
    shell_of[seed] = id;
    double volume = 0.0;
    for (std::size_t m = 0; m < members.size(); ++m)
    {
      const auto& v = triangles[members[m]];
      volume += vertices[v[0]].dot(
          (vertices[v[1]] - vertices[v[0]]).cross(vertices[v[2]] - vertices[v[0]]));
      for (int k = 0; k < 3; ++k)
      {
        const int across = edge_of.at({ v[(k + 1) % 3], v[k] });
        if (shell_of[across] < 0)
        {
          shell_of[across] = id;
          members.push_back(across);
        }
      }
    }
    shells.push_back(std::move(members));
    volumes.push_back(volume);
    total += volume;
  }
  auto turn = [&](int id)
  {
    for (const int t : shells[id])
      std::swap(triangles[t][1], triangles[t][2]);
    volumes[id] = -volumes[id];
  };
  if (total < 0.0)
    for (std::size_t id = 0; id < shells.size(); ++id)
      turn(static_cast<int>(id));
  for (std::size_t id = 0; id < shells.size(); ++id)
  {
    if (!(volumes[id] < 0.0))
      continue;
    const Vec3& probe = vertices[triangles[shells[id].front()][0]];
    bool cavity = false;
    for (std::size_t other = 0; other < shells.size() && !cavity; ++other)
      cavity = other != id && volumes[other] > 0.0 &&
               windingNumber(vertices, triangles, shells[other], probe) > 0.5;
    if (!cavity)
      turn(static_cast<int>(id));
  }
}

// Normals of a checked mesh: each face's, each edge's (its two faces' summed, in one order for
// both so that either triangle gives the same), each vertex's (angle-weighted), the edges and
// vertices between coplanar faces, and the bounds; two faces back to back (a sheet of no
// thickness, no inside) refused naming `field`
void completeNormals(TriangleMesh& mesh, const EdgeMap& edge_of, const std::string& where,
                     const std::string& field)
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
  constexpr double COPLANAR = 1.0 - 1e-12;  // cosine between two faces' normals
  mesh.edge_normals.resize(f);
  mesh.flat_edges.resize(f);
  mesh.vertex_normals.assign(mesh.vertices.size(), Vec3::Zero());
  mesh.flat_vertices.assign(mesh.vertices.size(), 1);
  std::vector<int> first_face(mesh.vertices.size(), -1);
  for (std::size_t t = 0; t < f; ++t)
  {
    const auto& v = mesh.triangles[t];
    const Vec3& n = mesh.face_normals[t];
    for (int k = 0; k < 3; ++k)
    {
      const int a = v[k], b = v[(k + 1) % 3];
      const int other = edge_of.at({ b, a });  // the triangle across the edge
      const int first = std::min<int>(static_cast<int>(t), other),
                second = std::max<int>(static_cast<int>(t), other);
      const Vec3 sum = mesh.face_normals[first] + mesh.face_normals[second];
      if (!(sum.norm() > 1e-9))
        throw InvalidInput(
            field, where + ": triangles " + std::to_string(first) + " and " +
                       std::to_string(second) + " lie back to back along the edge from " +
                       vertexText(mesh.vertices, a) + " to " + vertexText(mesh.vertices, b) +
                       ": a sheet of no thickness has no inside");
      mesh.edge_normals[t][k] = sum;
      mesh.flat_edges[t][k] = n.dot(mesh.face_normals[other]) > COPLANAR;
      mesh.vertex_normals[a] +=
          cornerAngle(mesh.vertices[a], mesh.vertices[b], mesh.vertices[v[(k + 2) % 3]]) * n;
      if (first_face[a] < 0)
        first_face[a] = static_cast<int>(t);
      else if (!(n.dot(mesh.face_normals[first_face[a]]) > COPLANAR))
        mesh.flat_vertices[a] = 0;
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
      throw InvalidInput(field, where + ": triangle " + std::to_string(t) + " (" +
                                    vertexText(vertices, v[0]) + ", " + vertexText(vertices, v[1]) +
                                    ", " + vertexText(vertices, v[2]) +
                                    ") has no area: its corners are on one line");
  }
  turnShellsOut(vertices, triangles, edgesOf(vertices, triangles, where, field));
  const EdgeMap edge_of = edgesOf(vertices, triangles, where, field);  // as turned
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->source = source;
  mesh->vertices = std::move(vertices);
  mesh->triangles = std::move(triangles);
  mesh->index = std::move(index);
  completeNormals(*mesh, edge_of, where, field);
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
