/// @file mesh_builders.hpp
/// @brief Closed triangle meshes built in code, for test_mesh_shapes and bench_mesh: a box's 12
/// triangles, an L prism (non-convex: a reflex edge) and an icosphere.
#pragma once

#include "constrained_particles/core/triangle_mesh.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace constrained_particles
{
namespace testing
{
using Triangles = std::vector<std::array<int, 3>>;

/// The box [-h, h] as 8 vertices and 12 outward triangles.
inline std::pair<std::vector<Vec3>, Triangles> boxTriangles(const Vec3& h)
{
  std::vector<Vec3> v;
  for (int k = 0; k < 8; ++k)
    v.emplace_back((k & 1 ? 1 : -1) * h.x(), (k & 2 ? 1 : -1) * h.y(), (k & 4 ? 1 : -1) * h.z());
  // each face as two triangles, counter-clockwise seen from outside
  const Triangles t = { { 0, 2, 3 }, { 0, 3, 1 }, { 4, 5, 7 }, { 4, 7, 6 },    // z = -h, +h
                        { 0, 1, 5 }, { 0, 5, 4 }, { 2, 6, 7 }, { 2, 7, 3 },    // y = -h, +h
                        { 0, 4, 6 }, { 0, 6, 2 }, { 1, 3, 7 }, { 1, 7, 5 } };  // x = -h, +h
  return { v, t };
}

/// OBJ text of `vertices` moved by `shift` and `triangles` (1-based `f` lines), for loader tests.
inline std::string objText(const std::vector<Vec3>& vertices, const Triangles& triangles,
                           const Vec3& shift = Vec3::Zero())
{
  std::string obj;
  for (const Vec3& v : vertices)
    obj += "v " + std::to_string(v.x() + shift.x()) + " " + std::to_string(v.y() + shift.y()) +
           " " + std::to_string(v.z() + shift.z()) + "\n";
  for (const auto& f : triangles)
    obj += "f " + std::to_string(f[0] + 1) + " " + std::to_string(f[1] + 1) + " " +
           std::to_string(f[2] + 1) + "\n";
  return obj;
}

/// An L-shaped prism: the L (0,0)-(2,0)-(2,1)-(1,1)-(1,2)-(0,2) [m], z in [0, 1]; its edge at
/// (1, 1) is reflex (concave seen from outside).
inline std::shared_ptr<const TriangleMesh> lPrism()
{
  const double xy[6][2] = { { 0, 0 }, { 2, 0 }, { 2, 1 }, { 1, 1 }, { 1, 2 }, { 0, 2 } };
  std::vector<Vec3> v;
  for (int z = 0; z < 2; ++z)
    for (const auto& p : xy)
      v.emplace_back(p[0], p[1], z);
  Triangles t;
  const int fan[4][3] = { { 3, 4, 5 }, { 3, 5, 0 }, { 3, 0, 1 }, { 3, 1, 2 } };  // from the reflex
  for (const auto& f : fan)
  {
    t.push_back({ 6 + f[0], 6 + f[1], 6 + f[2] });  // top, seen from +z
    t.push_back({ f[0], f[2], f[1] });              // bottom, seen from -z
  }
  for (int i = 0; i < 6; ++i)
  {
    const int j = (i + 1) % 6;
    t.push_back({ i, j, 6 + j });
    t.push_back({ i, 6 + j, 6 + i });
  }
  return makeTriangleMesh(v, t, "L prism", "mesh");
}

/// A sphere of `radius` [m] about the origin as an icosphere: the octahedron's 8 faces split in 4
/// `levels` times (8 4^levels triangles), the new vertices pushed onto the sphere.
inline std::pair<std::vector<Vec3>, Triangles> icosphereTriangles(int levels, double radius)
{
  std::vector<Vec3> v = { Vec3::UnitX(),  -Vec3::UnitX(), Vec3::UnitY(),
                          -Vec3::UnitY(), Vec3::UnitZ(),  -Vec3::UnitZ() };
  Triangles t = { { 0, 2, 4 }, { 2, 1, 4 }, { 1, 3, 4 }, { 3, 0, 4 },
                  { 2, 0, 5 }, { 1, 2, 5 }, { 3, 1, 5 }, { 0, 3, 5 } };
  for (int level = 0; level < levels; ++level)
  {
    std::map<std::pair<int, int>, int> middle;
    auto mid = [&](int a, int b)
    {
      const auto key = std::minmax(a, b);
      const auto found = middle.find(key);
      if (found != middle.end())
        return found->second;
      v.push_back((v[a] + v[b]).normalized());
      return middle[key] = static_cast<int>(v.size()) - 1;
    };
    Triangles finer;
    for (const auto& f : t)
    {
      const int ab = mid(f[0], f[1]), bc = mid(f[1], f[2]), ca = mid(f[2], f[0]);
      finer.push_back({ f[0], ab, ca });
      finer.push_back({ ab, f[1], bc });
      finer.push_back({ ca, bc, f[2] });
      finer.push_back({ ab, bc, ca });
    }
    t = finer;
  }
  for (Vec3& x : v)
    x *= radius;
  return { v, t };
}
}  // namespace testing
}  // namespace constrained_particles
