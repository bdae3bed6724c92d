/// @file test_mesh_shapes.cpp
/// @brief Mesh obstacles (triangle_mesh.hpp, issue 48 item 1): a box's 12 triangles give the box's
/// own signed distance, gradient and Hessian everywhere (outside at faces, edges and corners, and
/// inside); a non-convex mesh's derivatives are its distance's differences, inside its reflex
/// edge too; FCL's search (mesh_file.hpp) finds a nearest triangle wherever the scan does; a
/// rope draped over a mesh box and a ball rolling off its edge move as over the box itself; files
/// are read (STL, OBJ, scaled) and an open, mis-wound or missing one refused, naming the field.
#include "mesh_builders.hpp"
#include "test_helpers.hpp"

#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/mesh_file.hpp"
#include "constrained_particles/scenes/robot_shapes.hpp"
#include "constrained_particles/scenes/scene_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <random>

using namespace constrained_particles;
using constrained_particles::testing::boxTriangles;
using constrained_particles::testing::icosphereTriangles;
using constrained_particles::testing::lPrism;
using constrained_particles::testing::objText;
using constrained_particles::testing::shapeOf;
using constrained_particles::testing::Triangles;

namespace
{
Shape meshShape(std::shared_ptr<const TriangleMesh> mesh, const Vec3& position = Vec3::Zero(),
                const Vec3& rpy = Vec3::Zero())
{
  Shape shape;
  shape.name = "mesh";
  shape.type = ShapeType::Mesh;
  shape.mesh = std::move(mesh);
  shape.position = position;
  shape.rotation = rotationFromRpy(rpy);
  return shape;
}

StepSettings rk4(double dt)
{
  StepSettings settings;
  settings.dt = dt;
  settings.integrator = "rk4";
  return settings;
}

std::string writeFile(const std::string& name, const std::string& text)
{
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}
}  // namespace

// The box's 12 triangles, turned and moved, against the box shape at 4,000 points from 0.3 m
// inside to 0.6 m outside and 600 over and under its faces' diagonals (where two coplanar
// triangles meet, within 1e-9 m of the line): the same distance and gradient (1e-12) and Hessian
// (1e-9 relative; flat over the diagonals) in every region, but where two faces are equally near
// inside (the gradient's choice is then free). The same with every triangle wound inward (turned
// out), and with the tree's search (FCL's).
TEST(MeshShapes, ABoxsTrianglesAreTheBox)
{
  const Vec3 half(0.2, 0.3, 0.4);
  const auto [vertices, triangles] = boxTriangles(half);
  const Vec3 at(0.1, -0.2, 0.3), rpy(0.3, -0.2, 0.7);
  Triangles inward = triangles;
  for (auto& t : inward)
    std::swap(t[1], t[2]);
  const auto plain = makeTriangleMesh(vertices, triangles, "box", "mesh");
  Shape box = shapeOf(ShapeType::Box, at, rpy);
  box.size = 2.0 * half;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<Vec3> points;
  for (int k = 0; k < 4000; ++k)
    points.emplace_back(0.8 * uniform(random), 0.9 * uniform(random), 1.0 * uniform(random));
  for (int k = 0; k < 100; ++k)  // over the diagonal from (-h, -h, h) to (h, h, h) of each face
    for (int axis = 0; axis < 3; ++axis)
      for (const double side : { -1.0, 1.0 })
      {
        const int u = (axis + 1) % 3, w = (axis + 2) % 3;
        const double s = uniform(random), across = 1e-9 * uniform(random);
        Vec3 q;
        q[u] = s * half[u] + across;
        q[w] = s * half[w] - across;
        q[axis] = side * (half[axis] + 0.3 * uniform(random));
        points.push_back(q);
      }
  for (const auto& made : { plain, makeTriangleMesh(vertices, inward, "inward box", "mesh"),
                            withIndex(*plain, makeMeshIndex(*plain)) })
  {
    const Shape mesh = meshShape(made, at, rpy);
    int compared = 0, inside = 0, edges = 0;
    for (const Vec3& q : points)
    {
      const Vec3 p = at + box.rotation * q;
      const ShapeSample a = evaluateShape(mesh, p), b = evaluateShape(box, p);
      ASSERT_NEAR(a.distance, b.distance, 1e-12) << "at local " << q.transpose();
      // inside, two faces equally near (within 1e-9) may give either normal
      Vec3 depth = half - q.cwiseAbs();
      std::sort(depth.data(), depth.data() + 3);
      if (b.distance < 0.0 && depth[1] - depth[0] < 1e-9)
        continue;
      ++compared;
      inside += b.distance < 0.0;
      edges += b.hessian.norm() > 0.0;
      EXPECT_LE((a.normal - b.normal).norm(), 1e-12) << made->source << " at " << q.transpose();
      EXPECT_LE((a.hessian - b.hessian).norm(), 1e-9 * (1.0 + b.hessian.norm()))
          << made->source << " at local " << q.transpose();
    }
    EXPECT_GT(compared, 4400) << made->source;
    EXPECT_GT(inside, 100) << made->source;
    EXPECT_GT(edges, 1000) << made->source;  // outside an edge or a corner: curved
  }
}

// Two boxes as one file's two shells, one wound inward: each is turned out, and the distance is
// the nearer box's; a box with a cavity (an inner shell wound inward) keeps it: inside the cavity
// is outside the solid; two squares back to back (closed, but no inside) are refused.
TEST(MeshShapes, EachShellIsTurnedOutAndASheetRefused)
{
  auto [vertices, triangles] = boxTriangles(Vec3(0.1, 0.1, 0.1));
  const auto [second, second_triangles] = boxTriangles(Vec3(0.2, 0.1, 0.1));
  for (auto t : second_triangles)
  {
    std::swap(t[1], t[2]);  // inward
    for (int& v : t)
      v += 8;
    triangles.push_back(t);
  }
  for (const Vec3& v : second)
    vertices.push_back(v + Vec3(1.0, 0.0, 0.0));
  const Shape both = meshShape(makeTriangleMesh(vertices, triangles, "two boxes", "mesh"));
  Shape near_box = shapeOf(ShapeType::Box), far_box = shapeOf(ShapeType::Box, Vec3(1, 0, 0));
  near_box.size = Vec3(0.2, 0.2, 0.2);
  far_box.size = Vec3(0.4, 0.2, 0.2);
  for (const Vec3& p : { Vec3(0.0, 0.0, 0.05), Vec3(0.3, 0.05, 0.0), Vec3(0.95, 0.0, 0.02),
                         Vec3(1.5, 0.3, -0.2), Vec3(0.6, 0.0, 0.0) })
    EXPECT_NEAR(evaluateShape(both, p).distance,
                std::min(evaluateShape(near_box, p).distance, evaluateShape(far_box, p).distance),
                1e-12)
        << p.transpose();
  // a hollow box: walls 0.1 m thick round a cavity of half-side 0.2 m
  auto [hollow, hollow_triangles] = boxTriangles(Vec3(0.3, 0.3, 0.3));
  const auto [cavity, cavity_triangles] = boxTriangles(Vec3(0.2, 0.2, 0.2));
  for (auto t : cavity_triangles)
  {
    std::swap(t[1], t[2]);  // inward: the cavity's wall faces into it
    for (int& v : t)
      v += 8;
    hollow_triangles.push_back(t);
  }
  hollow.insert(hollow.end(), cavity.begin(), cavity.end());
  const Shape shell = meshShape(makeTriangleMesh(hollow, hollow_triangles, "hollow", "mesh"));
  EXPECT_NEAR(evaluateShape(shell, Vec3(0.0, 0.0, 0.0)).distance, 0.2, 1e-12);     // in the cavity
  EXPECT_NEAR(evaluateShape(shell, Vec3(0.25, 0.0, 0.0)).distance, -0.05, 1e-12);  // in the wall
  EXPECT_NEAR(evaluateShape(shell, Vec3(0.4, 0.0, 0.0)).distance, 0.1, 1e-12);     // outside
  const std::vector<Vec3> square = { Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0) };
  // the front split along one diagonal, the back (wound the other way) along the other: every
  // edge wound once each way
  const Triangles sheet = { { 0, 1, 2 }, { 0, 2, 3 }, { 0, 3, 1 }, { 1, 3, 2 } };
  try
  {
    makeTriangleMesh(square, sheet, "sheet", "shapes.sheet.file");
    ADD_FAILURE() << "a sheet of no thickness accepted";
  }
  catch (const InvalidInput& e)
  {
    EXPECT_NE(std::string(e.what()).find("shapes.sheet.file"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("back to back"), std::string::npos) << e.what();
  }
}

// A non-convex closed mesh (an L prism): at a face, a convex edge and corner outside, the reflex
// edge from inside and a face inside, the gradient and Hessian are central differences of the
// distance and the gradient, and the sign is the side.
TEST(MeshShapes, DerivativesMatchFiniteDifferencesOnANonConvexMesh)
{
  const Shape shape = meshShape(lPrism(), Vec3(0.1, 0.2, -0.3), Vec3(0.4, 0.1, -0.6));
  struct Case
  {
    Vec3 local;
    double distance;
    const char* what;
  };
  const Case cases[] = {
    { Vec3(1.5, 0.5, 1.3), 0.3, "above the top face" },
    { Vec3(2.3, -0.2, 0.5), std::hypot(0.3, 0.2), "outside a convex edge" },
    { Vec3(2.3, 1.2, 1.4), std::sqrt(0.09 + 0.04 + 0.16), "outside a corner" },
    { Vec3(0.8, 0.8, 0.5), -std::hypot(0.2, 0.2), "inside, the reflex edge nearest" },
    { Vec3(0.5, 1.5, 0.9), -0.1, "inside, the top face nearest" },
  };
  for (const Case& c : cases)
  {
    const Vec3 p = shape.position + shape.rotation * c.local;
    const ShapeSample s = evaluateShape(shape, p);
    EXPECT_NEAR(s.distance, c.distance, 1e-12) << c.what;
    EXPECT_NEAR(s.normal.norm(), 1.0, 1e-12) << c.what;
    const double h = 1e-6;
    for (int axis = 0; axis < 3; ++axis)
    {
      const Vec3 e = h * Vec3::Unit(axis);
      const ShapeSample plus = evaluateShape(shape, p + e), minus = evaluateShape(shape, p - e);
      EXPECT_NEAR(s.normal[axis], (plus.distance - minus.distance) / (2 * h), 1e-8)
          << c.what << " gradient " << axis;
      const Vec3 column = (plus.normal - minus.normal) / (2 * h);
      for (int row = 0; row < 3; ++row)
        EXPECT_NEAR(s.hessian(row, axis), column[row], 1e-5)
            << c.what << " hessian " << row << axis;
    }
  }
  // the reflex edge from inside curves the other way: its Hessian is negative across it
  const ShapeSample reflex = evaluateShape(shape, shape.position + shape.rotation * cases[3].local);
  EXPECT_LT(reflex.hessian.trace(), -1.0);
}

// FCL's tree (mesh_file.hpp) against the scan on a 2,048-triangle sphere and the L prism: at
// random points inside, outside and on the surface (vertices, face centres), the triangle it
// names is as near as the scan's (1e-12 m).
TEST(MeshShapes, FclFindsANearestTriangleWhereverTheScanDoes)
{
  const auto [v, t] = icosphereTriangles(4, 1.0);
  ASSERT_EQ(t.size(), 2048u);
  std::mt19937 random(11);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  for (const auto& mesh : { makeTriangleMesh(v, t, "icosphere", "mesh"), lPrism() })
  {
    const std::shared_ptr<const TriangleIndex> index = makeMeshIndex(*mesh);
    std::vector<Vec3> points;
    for (int k = 0; k < 3000; ++k)
      points.emplace_back(uniform(random), uniform(random), uniform(random));
    for (std::size_t f = 0; f < mesh->triangles.size(); f += 7)
    {
      const auto& tri = mesh->triangles[f];
      points.push_back(mesh->vertices[tri[0]]);
      points.push_back((mesh->vertices[tri[0]] + mesh->vertices[tri[1]] + mesh->vertices[tri[2]]) /
                       3.0);
    }
    for (const Vec3& q : points)
    {
      const int by_tree = index->nearest(*mesh, q), by_scan = nearestTriangleByScan(*mesh, q);
      ASSERT_NEAR(std::sqrt(nearestOnTriangle(*mesh, by_tree, q).squared_distance),
                  std::sqrt(nearestOnTriangle(*mesh, by_scan, q).squared_distance), 1e-12)
          << mesh->source << " at " << q.transpose();
    }
  }
}

// A rope (12 particles, radius 1 cm, mu 0.3) dropped across a box's top edge and one across its
// 12 triangles (searched by the tree, as a file's are): the same motion over 0.6 s (1e-9 m),
// sliding, sticking and draped over the edge; a ball rolling off the box's edge likewise, its
// contact let go there.
TEST(MeshShapes, ARopeAndABallMoveOverAMeshBoxAsOverTheBox)
{
  const Vec3 half(0.2, 0.2, 0.2);
  const auto [vertices, triangles] = boxTriangles(half);
  Shape box = shapeOf(ShapeType::Box, Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 0.2));
  box.size = 2.0 * half;
  const auto triangulated = makeTriangleMesh(vertices, triangles, "box", "mesh");
  const Shape mesh = meshShape(withIndex(*triangulated, makeMeshIndex(*triangulated)), box.position,
                               Vec3(0.0, 0.0, 0.2));
  auto rope = [](const Shape& obstacle)
  {
    const int n = 12;
    Scene scene;
    scene.masses.assign(n, 0.01);
    scene.forces = { GravityForce{} };
    for (int i = 0; i + 1 < n; ++i)
      scene.constraints.push_back(LinkConstraint{ i, i + 1, 0.05 });
    for (int i = 0; i < n; ++i)
      scene.constraints.push_back(ShapeContact{ i, obstacle, 0.01, 0.3, 0.0 });
    State start;
    start.positions.setZero(3, n);
    start.velocities.setZero(3, n);
    for (int i = 0; i < n; ++i)
      start.positions.col(i) = Vec3(-0.05 + 0.05 * i, 0.03, 0.25);
    return Simulator(scene, start, rk4(1e-3));
  };
  Simulator over_box = rope(box), over_mesh = rope(mesh);
  for (int k = 0; k < 600; ++k)
  {
    ASSERT_EQ(over_box.step().failed_check, StepCheck::None) << "box, step " << k;
    ASSERT_EQ(over_mesh.step().failed_check, StepCheck::None) << "mesh, step " << k;
  }
  const double apart =
      (over_mesh.state().positions - over_box.state().positions).colwise().norm().maxCoeff();
  std::cout << "rope over the box and over its triangles, 0.6 s: " << apart << " m apart\n";
  EXPECT_LE(apart, 1e-9);
  // it lies on the box's top and hangs over its edge, outside it
  const Points& p = over_mesh.state().positions;
  EXPECT_LT(p.row(2).minCoeff(), 0.1);
  for (int i = 0; i < p.cols(); ++i)
    EXPECT_GE(evaluateShape(mesh, p.col(i)).distance, 0.01 - 1e-9) << "particle " << i;

  auto ball = [](const Shape& obstacle)
  {
    Scene scene;
    scene.masses = { 1.0 };
    scene.forces = { GravityForce{} };
    scene.constraints = { ShapeContact{ 0, obstacle, 0.01, 0.0, 0.0 } };
    State start;
    start.positions = obstacle.position + obstacle.rotation * Vec3(0.21, 0.0, 0.1);
    start.velocities = Vec3::Zero();
    return Simulator(scene, start, rk4(1e-3));
  };
  Simulator by_box = ball(box), by_mesh = ball(mesh);
  by_box.step(400);
  by_mesh.step(400);
  EXPECT_LE((by_mesh.state().positions - by_box.state().positions).norm(), 1e-9);
  EXPECT_LT(by_mesh.state().positions(2, 0), -0.5);  // past the edge, falling
}

// Files: an ASCII STL box (each triangle's own vertices, joined), scaled from mm, and an OBJ are
// read as the box; a scene file's mesh shape is found relative to the scene file; an open mesh, a
// mis-wound one, a missing file, a bad scale, a relative file with no scene file, capsule links
// against a mesh (in a scene file and by ~set_obstacle) and a point against one are refused, each
// naming its field and saying why.
TEST(MeshShapes, FilesAreReadAndBadOnesRefusedNamingTheField)
{
  const Vec3 half(100.0, 150.0, 200.0);  // mm
  const auto [vertices, triangles] = boxTriangles(half);
  std::string stl = "solid box\n";
  for (const auto& f : triangles)
  {
    stl += " facet normal 0 0 0\n  outer loop\n";
    for (const int k : f)
      stl += "   vertex " + std::to_string(vertices[k].x()) + " " +
             std::to_string(vertices[k].y()) + " " + std::to_string(vertices[k].z()) + "\n";
    stl += "  endloop\n endfacet\n";
  }
  stl += "endsolid box\n";
  const std::string stl_path = writeFile("cp_box.stl", stl);
  const auto from_stl = loadMeshFile(stl_path, Vec3::Constant(0.001), "shape");
  EXPECT_EQ(from_stl->vertices.size(), 8u);
  EXPECT_EQ(from_stl->triangles.size(), 12u);
  ASSERT_TRUE(from_stl->index != nullptr);
  Shape box = shapeOf(ShapeType::Box);
  box.size = 2e-3 * half;
  for (const Vec3& p : { Vec3(0.3, 0.05, 0.02), Vec3(0.25, 0.2, -0.3), Vec3(0.01, 0.02, 0.03) })
    EXPECT_NEAR(evaluateShape(meshShape(from_stl), p).distance, evaluateShape(box, p).distance,
                1e-12);
  const std::string obj = objText(vertices, triangles);
  const std::string open_obj =  // one triangle short: open
      objText(vertices, Triangles(triangles.begin() + 1, triangles.end()));
  EXPECT_EQ(loadMeshFile(writeFile("cp_box.obj", obj), Vec3::Ones(), "shape")->triangles.size(),
            12u);
  auto refusal = [](auto&& call)
  {
    try
    {
      call();
    }
    catch (const InvalidInput& e)
    {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  const std::string open = refusal(
      [&] { loadMeshFile(writeFile("cp_open.obj", open_obj), Vec3::Ones(), "shapes.lid"); });
  EXPECT_NE(open.find("shapes.lid.file"), std::string::npos) << open;
  EXPECT_NE(open.find("borders one triangle only"), std::string::npos) << open;
  Triangles wound = triangles;
  std::swap(wound[3][1], wound[3][2]);
  const std::string mis = refusal([&] { makeTriangleMesh(vertices, wound, "box", "mesh"); });
  EXPECT_NE(mis.find("wound the same way"), std::string::npos) << mis;
  const std::string missing =
      refusal([&] { loadMeshFile("/nonexistent/x.stl", Vec3::Ones(), "shapes.m"); });
  EXPECT_NE(missing.find("shapes.m.file"), std::string::npos) << missing;
  const std::string scale = refusal([&] { loadMeshFile(stl_path, Vec3(1, 0, 1), "shapes.m"); });
  EXPECT_NE(scale.find("shapes.m.scale"), std::string::npos) << scale;
  EXPECT_NE(scale.find(limits::MESH_SCALE.text()), std::string::npos) << scale;
  // a mirroring scale winds the triangles inward: turned out, the box mirrored (one off centre
  // by 0.5 m along x lands 0.5 m the other way)
  const std::string shifted = objText(vertices, triangles, Vec3(500.0, 0.0, 0.0));
  const Shape mirrored = meshShape(
      loadMeshFile(writeFile("cp_shifted.obj", shifted), Vec3(-0.001, 0.001, 0.001), "shape"));
  Shape there = shapeOf(ShapeType::Box, Vec3(-0.5, 0.0, 0.0));
  there.size = box.size;
  for (const Vec3& p : { Vec3(-0.5, 0.05, 0.02), Vec3(-0.2, 0.2, -0.3), Vec3(0.5, 0.0, 0.0) })
    EXPECT_NEAR(evaluateShape(mirrored, p).distance, evaluateShape(there, p).distance, 1e-12)
        << p.transpose();

  // a scene file names the mesh relative to itself
  const std::string scene_path = writeFile(
      "cp_mesh_scene.yaml",
      "shapes:\n"
      "  block: {type: mesh, file: cp_box.stl, scale: [0.001, 0.001, 0.001], position: [0, 0, 0]}\n"
      "chains:\n"
      "  - {particles: 4, link_length: 0.05, particle_mass: 0.01, start: [-0.05, 0, 0.3],\n"
      "     direction: [1, 0, 0], obstacles: [block], radius: 0.01}\n");
  const SceneDescription d = loadSceneFile(scene_path);
  ASSERT_EQ(d.shapes.size(), 1u);
  EXPECT_EQ(d.shapes[0].type, ShapeType::Mesh);
  ASSERT_TRUE(d.shapes[0].mesh != nullptr);
  const BuiltScene built = buildScene(d);
  Simulator sim(built.scene, built.initial_state, rk4(1e-3));
  sim.step(300);
  for (int i = 0; i < sim.model().numParticles(); ++i)
    EXPECT_GE(evaluateShape(d.shapes[0], sim.state().positions.col(i)).distance, 0.01 - 1e-9);
  const std::string capsules = refusal(
      [&]
      {
        parseScene("shapes:\n  block: {type: mesh, file: " + stl_path +
                       "}\nchains:\n  - {particles: 3, link_length: 0.05, particle_mass: "
                       "0.01, start: [0, 0, 0.5], obstacles: [block], radius: 0.01, "
                       "capsules: true}\n",
                   "inline.yaml");
      });
  EXPECT_NE(capsules.find("capsules"), std::string::npos) << capsules;
  EXPECT_NE(capsules.find("not one"), std::string::npos) << capsules;
  const std::string point = refusal(
      [&]
      {
        parseScene("shapes:\n  block: {type: mesh, file: " + stl_path +
                       "}\nchains:\n  - {particles: 3, link_length: 0.05, particle_mass: "
                       "0.01, start: [0, 0, 0.5], obstacles: [block]}\n",
                   "inline.yaml");
      });
  EXPECT_NE(point.find("radius"), std::string::npos) << point;
  const std::string no_file =
      refusal([&] { parseScene("shapes:\n  block: {type: mesh}\n", "inline.yaml"); });
  EXPECT_NE(no_file.find("shapes.block.file"), std::string::npos) << no_file;
  // a file that is not a string: named once, at its key, as every key's wrong type is
  const std::string not_string =
      refusal([&] { parseScene("shapes:\n  block: {type: mesh, file: [1, 2]}\n", "in.yaml"); });
  EXPECT_NE(not_string.find("shapes.block.file"), std::string::npos) << not_string;
  EXPECT_EQ(not_string.find("shapes.block.file", not_string.find("shapes.block.file") + 1),
            std::string::npos)
      << not_string;
  // a scene given as text has no directory for a relative file
  const std::string relative = refusal(
      [&] { parseScene("shapes:\n  block: {type: mesh, file: cp_box.stl}\n", "inline.yaml"); });
  EXPECT_NE(relative.find("shapes.block.file"), std::string::npos) << relative;
  EXPECT_NE(relative.find("relative path"), std::string::npos) << relative;
  // ~set_obstacle's mesh against a chain whose links are capsules: refused, the scene unchanged
  SceneDescription with_capsules = parseScene(
      "shapes:\n  post: {type: sphere, radius: 0.05, position: [0, 0, 0]}\nchains:\n  - "
      "{particles: 3, link_length: 0.05, particle_mass: 0.01, start: [0, 0, 0.5], "
      "obstacles: [post], radius: 0.01, capsules: true}\n",
      "inline.yaml");
  const std::string added = refusal(
      [&]
      {
        changeObstacle(with_capsules, ObstacleChange::Add, "block",
                       "{type: mesh, file: " + stl_path + ", scale: [0.001, 0.001, 0.001]}");
      });
  EXPECT_NE(added.find("capsules"), std::string::npos) << added;
  EXPECT_EQ(with_capsules.shapes.size(), 1u);
}

// A DAE (COLLADA) file is read as URDF reads it: its vertices as written, its Z_UP not turned to
// assimp's Y up, its <unit> applied (a file in mm at meter = 0.001 is in m); a box of half-sides
// (0.1, 0.2, 0.3) keeps them on its own axes.
TEST(MeshShapes, ADaeFileKeepsItsAxesAndUnit)
{
  const auto [vertices, triangles] = boxTriangles(Vec3(100.0, 200.0, 300.0));  // mm
  std::string positions, indices;
  for (const Vec3& x : vertices)
    positions +=
        std::to_string(x.x()) + " " + std::to_string(x.y()) + " " + std::to_string(x.z()) + " ";
  for (const auto& f : triangles)
    indices += std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + " ";
  const std::string dae =
      "<?xml version='1.0' encoding='utf-8'?>\n"
      "<COLLADA xmlns='http://www.collada.org/2005/11/COLLADASchema' version='1.4.1'>\n"
      "<asset><unit name='millimeter' meter='0.001'/><up_axis>Z_UP</up_axis></asset>\n"
      "<library_geometries><geometry id='box' name='box'><mesh>\n"
      "<source id='box-positions'><float_array id='box-array' count='24'>" +
      positions +
      "</float_array><technique_common><accessor source='#box-array' count='8' stride='3'>"
      "<param name='X' type='float'/><param name='Y' type='float'/><param name='Z' type='float'/>"
      "</accessor></technique_common></source>\n"
      "<vertices id='box-vertices'><input semantic='POSITION' "
      "source='#box-positions'/></vertices>\n"
      "<triangles count='12'><input semantic='VERTEX' source='#box-vertices' offset='0'/><p>" +
      indices +
      "</p></triangles>\n"
      "</mesh></geometry></library_geometries>\n"
      "<library_visual_scenes><visual_scene id='scene'><node id='node'>"
      "<instance_geometry url='#box'/></node></visual_scene></library_visual_scenes>\n"
      "<scene><instance_visual_scene url='#scene'/></scene>\n"
      "</COLLADA>\n";
  const auto mesh = loadMeshFile(writeFile("cp_box.dae", dae), Vec3::Ones(), "shape");
  EXPECT_EQ(mesh->triangles.size(), 12u);
  // assimp keeps vertices in float: 0.3 m to 1.2e-8 m
  EXPECT_LE((mesh->high - Vec3(0.1, 0.2, 0.3)).norm(), 1e-7) << mesh->high.transpose();
  EXPECT_LE((mesh->low + Vec3(0.1, 0.2, 0.3)).norm(), 1e-7) << mesh->low.transpose();
}

// A URDF link's <mesh> collision is a mesh shape carried by the link's frame, scaled as the URDF
// says; package:// names are found by the resolver the ROS layer gives, and refused without it.
TEST(MeshShapes, AUrdfMeshIsAShapeOnItsLink)
{
  const auto [vertices, triangles] = boxTriangles(Vec3(1.0, 1.0, 1.0));
  writeFile("cp_unit_box.obj", objText(vertices, triangles));
  const std::string urdf =
      "<robot name='r'><link name='arm'><collision><origin xyz='0 0 0.5'/><geometry>"
      "<mesh filename='package://cp_test/cp_unit_box.obj' scale='0.1 0.2 0.3'/></geometry>"
      "</collision></link></robot>";
  FileResolver files;
  files.package_path = [](const std::string& package)
  { return package == "cp_test" ? ::testing::TempDir() : std::string(); };
  const std::vector<Shape> shapes = robotLinkShapes(urdf, { "arm" }, "robot_links", files);
  ASSERT_EQ(shapes.size(), 1u);
  EXPECT_EQ(shapes[0].type, ShapeType::Mesh);
  EXPECT_EQ(shapes[0].frame, "arm");
  EXPECT_NEAR(shapes[0].position.z(), 0.5, 1e-15);
  ASSERT_TRUE(shapes[0].mesh != nullptr);
  EXPECT_NEAR(shapes[0].mesh->high.z(), 0.3, 1e-12);
  EXPECT_NEAR(shapes[0].mesh->low.y(), -0.2, 1e-12);
  // no package path given, and a package not on it: refused, naming the link and saying why
  FileResolver elsewhere;
  elsewhere.package_path = [](const std::string&) { return std::string(); };
  for (const auto& [resolver, words] :
       { std::make_pair(FileResolver{}, "ROS's package path, which is not given here"),
         std::make_pair(elsewhere, "package 'cp_test' is not found on ROS's package path") })
    try
    {
      robotLinkShapes(urdf, { "arm" }, "robot_links", resolver);
      ADD_FAILURE() << "a package:// mesh found without its package";
    }
    catch (const InvalidInput& e)
    {
      EXPECT_NE(std::string(e.what()).find("robot_links[0] = 'arm'"), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
}
