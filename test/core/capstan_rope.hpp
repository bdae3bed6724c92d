/// @file capstan_rope.hpp
/// @brief The capstan rope, shared by test_shapes (RopeOverACylinderHoldsTheCapstanRatio) and
/// bench_friction: a rope over a fixed horizontal cylinder (radius 0.2 m, the rope's 0.01 m), 41
/// particles on half a turn and 3 hanging straight down at each side, 1 g each, no gravity; the
/// last particle pulled down by 1 N and the first by `load` times the discrete capstan ratio.
/// Each contact on the arc turns the rope by delta = pi / 40 (the end ones by delta / 2) and
/// holds a tension ratio of at most (1 + mu tan(delta / 2)) / (1 - mu tan(delta / 2)) at the
/// slip limit; their product is e^(mu pi) to 6e-4 at mu 0.3.
#pragma once

#include "constrained_particles/core/scene.hpp"
#include "constrained_particles/core/shapes.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <vector>

namespace constrained_particles
{
struct CapstanRope
{
  Scene scene;
  State start;         ///< at rest, on the cylinder and hanging straight
  double ratio;        ///< the discrete capstan ratio (the product of the contacts' limits)
  Shape cylinder;      ///< the obstacle, fixed, its axis along the world y
  double rope_radius;  ///< r [m]: each contact's
};

/// The rope with Coulomb friction `mu` at each arc contact, its first particle pulled by `load`
/// (a fraction of the ratio: < 1 holds, > 1 slips) times `ratio` [N].
inline CapstanRope capstanRope(double mu, double load)
{
  const double radius = 0.2, rope = 0.01, reach = radius + rope;
  const int arc = 40, hanging = 3;
  CapstanRope made;
  made.rope_radius = rope;
  Shape& cylinder = made.cylinder;
  cylinder.type = ShapeType::Cylinder;
  // its axis (its local z) along the world y: roll pi/2
  cylinder.rotation = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix();
  cylinder.radius = radius;
  cylinder.length = 1.0;
  const double delta = M_PI / arc, link = 2.0 * reach * std::sin(delta / 2);
  std::vector<Vec3> points;
  for (int k = hanging; k > 0; --k)
    points.push_back(Vec3(reach, 0.0, -k * link));
  for (int k = 0; k <= arc; ++k)
    points.push_back(Vec3(reach * std::cos(k * delta), 0.0, reach * std::sin(k * delta)));
  for (int k = 1; k <= hanging; ++k)
    points.push_back(Vec3(-reach, 0.0, -k * link));
  const int n = static_cast<int>(points.size());
  auto holds = [mu](double turn)
  { return (1.0 + mu * std::tan(turn / 2)) / (1.0 - mu * std::tan(turn / 2)); };
  made.ratio = std::pow(holds(delta), arc - 1) * std::pow(holds(delta / 2), 2);
  Scene& scene = made.scene;
  scene.masses.assign(n, 1e-3);
  scene.forces = { ExternalForce{ n - 1, Vec3(0.0, 0.0, -1.0) },
                   ExternalForce{ 0, Vec3(0.0, 0.0, -load * made.ratio) } };
  made.start.positions.resize(3, n);
  made.start.velocities.setZero(3, n);
  for (int i = 0; i < n; ++i)
  {
    made.start.positions.col(i) = points[i];
    if (i >= hanging && i <= hanging + arc)
      scene.constraints.push_back(ShapeContact{ i, cylinder, rope, mu, 0.0 });
  }
  for (int i = 0; i + 1 < n; ++i)
    scene.constraints.push_back(LinkConstraint{ i, i + 1, link });
  return made;
}

}  // namespace constrained_particles
