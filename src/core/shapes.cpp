#include "constrained_particles/core/shapes.hpp"

#include "constrained_particles/core/limits.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace constrained_particles
{
namespace
{
const char* const SHAPE_NAMES[] = { "plane", "sphere", "box", "capsule", "cylinder", "mesh" };
constexpr int NUM_SHAPE_TYPES = 6;

using Mat3 = Eigen::Matrix3d;

// Distance r from a point set at offset w (its nearest point at w's foot) whose level sets curve
// only in the directions of `projector`: d = |w| - radius, n = w / |w|, H = (P - n n^T) / |w|
// (a sphere's P = I; a cylinder's side and a capsule's, P = I - z z^T: they do not vary along z)
ShapeSample roundDistance(const Vec3& w, double radius, const Mat3& projector)
{
  ShapeSample s;
  const double r = w.norm();
  s.distance = r - radius;
  if (!(r > 0.0))
    return s;  // on the centre or the axis: no gradient, the local +z (shapes.hpp)
  s.normal = w / r;
  // a box's edge or corner, a cylinder's rim: curvature 1 / r, unbounded on them for a particle
  // of radius 0; taken as rounded by MIN_CURVATURE_RADIUS there (Jdot v stays finite)
  s.hessian = (projector - s.normal * s.normal.transpose()) / std::max(r, MIN_CURVATURE_RADIUS);
  return s;
}

ShapeSample cylinderDistance(const Vec3& q, double radius, double half_length)
{
  const Vec3 xy(q.x(), q.y(), 0.0);
  const double rho = xy.norm();
  const Vec3 radial = rho > 0.0 ? Vec3(xy / rho) : Vec3::UnitX();
  const Vec3 around = Vec3::UnitZ().cross(radial);  // e_phi
  const Vec3 axial = q.z() < 0.0 ? Vec3(-Vec3::UnitZ()) : Vec3::UnitZ();
  const double dr = rho - radius, h = std::abs(q.z()) - half_length;
  ShapeSample s;
  if (dr > 0.0 && h > 0.0)
  {
    // nearest the rim circle: in the meridian plane (radial, axial) the distance to a point,
    // (I - n n^T) / d there; around the axis, its radial rate over rho (cylindrical coordinates)
    const double d = std::hypot(dr, h);
    const double nr = dr / d, nz = h / d;
    s.distance = d;
    s.normal = nr * radial + nz * axial;
    const double m00 = (1.0 - nr * nr) / d, m01 = -nr * nz / d, m11 = (1.0 - nz * nz) / d;
    const double bend = std::max(d, MIN_CURVATURE_RADIUS) / d;  // as roundDistance's
    s.hessian = (m00 * radial * radial.transpose() +
                 m01 * (radial * axial.transpose() + axial * radial.transpose()) +
                 m11 * axial * axial.transpose()) /
                    bend +
                (nr / rho) * around * around.transpose();
    return s;
  }
  if (dr >= h)  // the side nearest (outside, or inside and nearer than the ends)
  {
    s.distance = dr;
    s.normal = radial;
    if (rho > 0.0)
      s.hessian = around * around.transpose() / rho;
    return s;
  }
  s.distance = h;  // an end face nearest
  s.normal = axial;
  return s;
}

ShapeSample boxDistance(const Vec3& q, const Vec3& half)
{
  ShapeSample s;
  Vec3 w = Vec3::Zero();
  Mat3 projector = Mat3::Zero();
  bool outside = false;
  int nearest = 0;
  double deepest = -std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis)
  {
    const double excess = std::abs(q[axis]) - half[axis];
    const double sign = q[axis] < 0.0 ? -1.0 : 1.0;
    if (excess > 0.0)
    {
      outside = true;
      w[axis] = sign * excess;
      projector(axis, axis) = 1.0;
    }
    if (excess > deepest)
    {
      deepest = excess;
      nearest = axis;
    }
  }
  if (outside)  // nearest a face (one axis out), an edge (two) or a corner (three)
    return roundDistance(w, 0.0, projector);
  s.distance = deepest;  // inside: the nearest face's plane
  s.normal = Vec3::Zero();
  s.normal[nearest] = q[nearest] < 0.0 ? -1.0 : 1.0;
  return s;
}

// A closed mesh's signed distance at q (local): the nearest triangle's nearest feature, signed by
// its pseudonormal (triangle_mesh.hpp). A face is flat (H = 0); an edge curves across it only,
// a vertex every way, as a box's edges and corners (roundDistance's forms, signed)
ShapeSample meshDistance(const TriangleMesh& mesh, const Vec3& q)
{
  const int t = mesh.index ? mesh.index->nearest(mesh, q) : nearestTriangleByScan(mesh, q);
  const TriangleFeature near = nearestOnTriangle(mesh, t, q);
  const auto& v = mesh.triangles[t];
  const Vec3 w = q - near.point;
  ShapeSample s;
  // over a face; or over an edge or a vertex between coplanar faces (the distance is flat across
  // them), or along the face's normal (on the face's region too)
  const bool flat = near.feature == 0 ||
                    (near.feature <= 3 ? mesh.flat_edges[t][near.feature - 1]
                                       : mesh.flat_vertices[v[near.feature - 4]] != 0) ||
                    w.cross(mesh.face_normals[t]).norm() <= 1e-9 * w.norm();
  if (flat)
  {
    s.normal = mesh.face_normals[t];
    s.distance = s.normal.dot(w);
    return s;
  }
  const Vec3 pseudonormal = near.feature <= 3 ? mesh.edge_normals[t][near.feature - 1]
                                              : mesh.vertex_normals[v[near.feature - 4]];
  const double r = w.norm();  // > 0: w = 0 is flat above
  const double sign = w.dot(pseudonormal) < 0.0 ? -1.0 : 1.0;
  s.distance = sign * r;
  s.normal = sign * w / r;
  Mat3 projector = Mat3::Identity();
  if (near.feature <= 3)  // no curvature along the edge
  {
    const int k = near.feature - 1;
    const Vec3 e = (mesh.vertices[v[(k + 1) % 3]] - mesh.vertices[v[k]]).normalized();
    projector -= e * e.transpose();
  }
  s.hessian =
      sign * (projector - s.normal * s.normal.transpose()) / std::max(r, MIN_CURVATURE_RADIUS);
  return s;
}

}  // namespace

ShapePose fixedPose(const Shape& shape)
{
  ShapePose pose;
  pose.origin = shape.position;
  pose.rotation = shape.rotation;
  return pose;
}

ShapeSample evaluateShape(const Shape& shape, const Vec3& p)
{
  return evaluateShape(shape, fixedPose(shape), p);
}

ShapeSample evaluateShape(const Shape& shape, const ShapePose& pose, const Vec3& p)
{
  const Vec3 q = pose.rotation.transpose() * (p - pose.origin);  // local
  ShapeSample local;
  switch (shape.type)
  {
    case ShapeType::Plane:
      local.distance = q.z();
      break;
    case ShapeType::Sphere:
      local = roundDistance(q, shape.radius, Mat3::Identity());
      break;
    case ShapeType::Box:
      local = boxDistance(q, 0.5 * shape.size);
      break;
    case ShapeType::Capsule:
    {
      const double half = 0.5 * shape.length;
      const double foot = std::clamp(q.z(), -half, half);
      Mat3 projector = Mat3::Identity();
      if (std::abs(q.z()) <= half)
        projector(2, 2) = 0.0;  // beside the segment: no curvature along it
      local = roundDistance(q - foot * Vec3::UnitZ(), shape.radius, projector);
      break;
    }
    case ShapeType::Cylinder:
      local = cylinderDistance(q, shape.radius, 0.5 * shape.length);
      break;
    case ShapeType::Mesh:
      local = meshDistance(*shape.mesh, q);
      break;
  }
  ShapeSample world;
  world.distance = local.distance;
  world.normal = pose.rotation * local.normal;
  world.hessian = pose.rotation * local.hessian * pose.rotation.transpose();
  return world;
}

SegmentSample nearestOnSegment(const Shape& shape, const ShapePose& pose, const Vec3& a,
                               const Vec3& b, double low, double high)
{
  const Vec3 e = b - a;
  const double length = e.norm();
  auto at = [&](double s)
  {
    SegmentSample x;
    x.fraction = s;
    x.sample = evaluateShape(shape, pose, Vec3(a + s * e));
    return x;
  };
  // d/ds at either bound pointing inwards (or flat): the minimum is at that bound
  SegmentSample lower = at(low);
  double slope_low = lower.sample.normal.dot(e);
  if (!(slope_low < 0.0))
    return lower;
  SegmentSample upper = at(high);
  double slope_high = upper.sample.normal.dot(e);
  if (!(slope_high > 0.0))
    return upper;
  // d/ds < 0 at low, > 0 at high: Newton's steps inside the bracket, else its middle
  double s = low - slope_low * (high - low) / (slope_high - slope_low);
  SegmentSample x = at(s);
  for (int iteration = 0; iteration < 200; ++iteration)
  {
    const double slope = x.sample.normal.dot(e);
    if (std::abs(slope) <= 4.0 * std::numeric_limits<double>::epsilon() * length)
      break;
    (slope < 0.0 ? low : high) = s;
    if (high - low <= 4.0 * std::numeric_limits<double>::epsilon())
      break;
    const double curvature = e.dot(x.sample.hessian * e);
    const double newton = curvature > 0.0 ? s - slope / curvature : NAN;
    s = newton > low && newton < high ? newton : 0.5 * (low + high);
    x = at(s);
  }
  x.at_bound = false;
  x.between = e.dot(x.sample.hessian * e) > 1e-6 * length;
  return x;
}

Eigen::Matrix3d rotationFromRpy(const Vec3& rpy)
{
  return (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

const char* shapeTypeName(ShapeType type)
{
  return SHAPE_NAMES[static_cast<int>(type)];
}

std::vector<std::string> shapeTypeNames()
{
  return std::vector<std::string>(SHAPE_NAMES, SHAPE_NAMES + NUM_SHAPE_TYPES);
}

ShapeType parseShapeType(const std::string& name, const std::string& field)
{
  for (int i = 0; i < NUM_SHAPE_TYPES; ++i)
    if (name == SHAPE_NAMES[i])
      return static_cast<ShapeType>(i);
  std::string valid;
  for (int i = 0; i < NUM_SHAPE_TYPES; ++i)
    valid += std::string(i ? ", " : "") + SHAPE_NAMES[i];
  throw InvalidInput(field, "= '" + name + "' is not a shape type; valid: " + valid);
}

void validateShape(const Shape& shape, const std::string& field)
{
  requireInRange(field + ".position", shape.position, limits::COORDINATE);
  if (!shape.rotation.allFinite() ||
      !((shape.rotation.transpose() * shape.rotation - Mat3::Identity()).norm() <= 1e-9) ||
      !(shape.rotation.determinant() > 0.0))
    throw InvalidInput(field + ".rpy", "gives no rotation (the rotation is not orthonormal)");
  if (!shape.frame.empty() && !shape.topic.empty())
    throw InvalidInput(field + ".topic", "= '" + shape.topic + "' beside frame = '" + shape.frame +
                                             "': give a frame or a topic, not both");
  if (!shape.frame.empty() && shape.frame.front() == '/')
    throw InvalidInput(field + ".frame",
                       "= '" + shape.frame + "': tf2 frame names have no leading /");
  switch (shape.type)
  {
    case ShapeType::Plane:
      break;
    case ShapeType::Sphere:
      requireInRange(field + ".radius", shape.radius, limits::SHAPE_SIZE);
      break;
    case ShapeType::Box:
      requireInRange(field + ".size", shape.size, limits::SHAPE_SIZE);
      break;
    case ShapeType::Capsule:
    case ShapeType::Cylinder:
      requireInRange(field + ".radius", shape.radius, limits::SHAPE_SIZE);
      requireInRange(field + ".length", shape.length, limits::SHAPE_SIZE);
      break;
    case ShapeType::Mesh:
      if (!shape.mesh)
        throw InvalidInput(field + ".file",
                           "is missing: a mesh shape reads its triangles from "
                           "a file (STL, OBJ or DAE)");
      break;
  }
}

}  // namespace constrained_particles
