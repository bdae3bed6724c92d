// What a mesh obstacle costs (issue 48, item 1): a rope of 30 particles (radius 1 cm, mu 0.5)
// dropped across a ball of radius 10 cm, stepped 2 s at dt 1 ms (rk4), the ball as the closed-form
// sphere and as geodesic spheres (an octahedron split) of 128, 2,048 and 32,768 triangles whose
// nearest triangle is found by the tree on FCL's boxes (mesh_file.hpp) or by trying every one (a
// scan: what the tree saves). CPU time of this thread a step (the steps only), the median of 3
// runs, and the rope's largest depth inside the ball (never over the projection tolerance).
// Usage: bench_mesh   (about 1 minute on 2 cores)
#include "bench_common.hpp"
#include "mesh_builders.hpp"

#include "constrained_particles/core/simulator.hpp"
#include "constrained_particles/scenes/mesh_file.hpp"

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

using namespace constrained_particles;

namespace
{
struct Run
{
  double step_us;  // CPU time a step [us]
  double deepest;  // the deepest a particle's ball went into the obstacle [m]
};

Run ropeOver(const Shape& ball, long steps)
{
  const int n = 30;
  const double radius = 0.01;
  Scene scene;
  scene.masses.assign(n, 0.02);
  scene.forces = { GravityForce{} };
  for (int i = 0; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, 0.02 });
  for (int i = 0; i < n; ++i)
    scene.constraints.push_back(ShapeContact{ i, ball, radius, 0.5, 0.0 });
  State start;
  start.positions.setZero(3, n);
  start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
    start.positions.col(i) = Vec3(-0.29 + 0.02 * i, 0.003, 0.12);
  StepSettings settings;
  settings.dt = 1e-3;
  settings.integrator = "rk4";
  Simulator sim(scene, start, settings);
  Run run{ 0.0, 0.0 };
  double stepping = 0.0;  // the steps' CPU time only, not the depths' measuring
  for (long k = 0; k < steps; ++k)
  {
    const double t0 = bench::threadCpuSeconds();
    sim.step();
    stepping += bench::threadCpuSeconds() - t0;
    for (int i = 0; i < n; ++i)
      run.deepest = std::max(run.deepest,
                             radius - evaluateShape(ball, sim.state().positions.col(i)).distance);
  }
  run.step_us = 1e6 * stepping / static_cast<double>(steps);
  return run;
}

Run medianOf(const Shape& ball, long steps)
{
  std::vector<double> times;
  Run run{};
  for (int k = 0; k < 3; ++k)
  {
    run = ropeOver(ball, steps);
    times.push_back(run.step_us);
  }
  run.step_us = bench::median(times);
  return run;
}
}  // namespace

int main()
{
  const long steps = 2000;
  Shape sphere;
  sphere.name = "ball";
  sphere.type = ShapeType::Sphere;
  sphere.radius = 0.1;
  std::printf("%-34s %12s %16s\n", "the ball as", "us a step", "deepest in [m]");
  const Run closed = medianOf(sphere, steps);
  std::printf("%-34s %12.1f %16.2e\n", "sphere (closed form)", closed.step_us, closed.deepest);
  for (const int levels : { 2, 4, 6 })
    for (const bool tree : { true, false })
    {
      if (!tree && levels == 6)
        continue;  // 32,768 triangles tried per evaluation: minutes
      const auto [vertices, triangles] = testing::icosphereTriangles(levels, 0.1);
      const auto mesh = makeTriangleMesh(vertices, triangles, "icosphere", "ball");
      Shape ball = sphere;
      ball.type = ShapeType::Mesh;
      ball.mesh = tree ? withIndex(*mesh, makeMeshIndex(*mesh)) : mesh;
      const Run run = medianOf(ball, steps);
      const std::string name = "mesh of " + std::to_string(triangles.size()) + " triangles, " +
                               (tree ? "the tree" : "a scan");
      std::printf("%-34s %12.1f %16.2e\n", name.c_str(), run.step_us, run.deepest);
    }
  return 0;
}
