#include "constrained_particles/ros/markers.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
namespace
{

std_msgs::ColorRGBA color(float r, float g, float b, float a)
{
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

visualization_msgs::Marker makeMarker(const std_msgs::Header& header, const std::string& ns, int id,
                                      int type)
{
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = ns;
  m.id = id;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  return m;
}

visualization_msgs::Marker deleteMarker(const std_msgs::Header& header, const std::string& ns,
                                        int id)
{
  visualization_msgs::Marker m = makeMarker(header, ns, id, visualization_msgs::Marker::ARROW);
  m.action = visualization_msgs::Marker::DELETE;
  return m;
}

// a size for particles and arrows that suits the scene's lengths
double typicalLength(const Model& model)
{
  double shortest = 0.0;
  for (const Constraint& c : model.scene().constraints)
    if (const auto* link = std::get_if<LinkConstraint>(&c))
      shortest = shortest > 0.0 ? std::min(shortest, link->length) : link->length;
  return shortest > 0.0 ? shortest : 0.5;
}

}  // namespace

visualization_msgs::MarkerArray constraintForceMarkers(const std_msgs::Header& header,
                                                       const Points& positions,
                                                       const Points& forces, double force_scale,
                                                       int previous_count)
{
  visualization_msgs::MarkerArray array;
  const int n = static_cast<int>(positions.cols());
  const double largest = n > 0 ? forces.colwise().norm().maxCoeff() : 0.0;
  array.markers.reserve(std::max(n, previous_count));
  for (int i = 0; i < n; ++i)
  {
    visualization_msgs::Marker m =
        makeMarker(header, CONSTRAINT_FORCE_NAMESPACE, i, visualization_msgs::Marker::ARROW);
    const Eigen::Vector3d start = positions.col(i);
    const Eigen::Vector3d force = forces.col(i);
    m.points = { tf2::toMsg(start), tf2::toMsg(Eigen::Vector3d(start + force_scale * force)) };
    m.scale.x = 0.02;  // shaft diameter [m]
    m.scale.y = 0.04;  // head diameter [m]
    m.scale.z = 0.0;   // rviz's default head length
    const float t = largest > 0.0 ? static_cast<float>(force.norm() / largest) : 0.0f;
    m.color = color(t, 0.2f, 1.0f - t, 1.0f);
    array.markers.push_back(m);
  }
  for (int i = n; i < previous_count; ++i)
    array.markers.push_back(deleteMarker(header, CONSTRAINT_FORCE_NAMESPACE, i));
  return array;
}

const visualization_msgs::Marker& SurfaceMeshCache::mesh(const std_msgs::Header& header,
                                                         const Model& model,
                                                         const Points& positions,
                                                         bool scene_changed)
{
  const Eigen::Vector3d low = positions.rowwise().minCoeff();
  const Eigen::Vector3d high = positions.rowwise().maxCoeff();
  const bool inside =
      low.x() >= min_x_ && high.x() <= max_x_ && low.y() >= min_y_ && high.y() <= max_y_;
  if (scene_changed || !inside)
  {
    // a margin around the particles, so the mesh is rebuilt only now and then
    const double margin = std::max({ 1.0, 0.5 * (high.x() - low.x()), 0.5 * (high.y() - low.y()) });
    min_x_ = low.x() - margin;
    max_x_ = high.x() + margin;
    min_y_ = low.y() - margin;
    max_y_ = high.y() + margin;
    marker_ = makeMarker(header, "surface", 0, visualization_msgs::Marker::TRIANGLE_LIST);
    marker_.scale.x = marker_.scale.y = marker_.scale.z = 1.0;
    marker_.color = color(0.3f, 0.7f, 0.9f, 0.6f);
    const double hx = (max_x_ - min_x_) / cells_, hy = (max_y_ - min_y_) / cells_;
    for (const Surface& surface : model.scene().surfaces)
    {
      auto vertex = [&](int i, int j)
      {
        const double x = min_x_ + i * hx, y = min_y_ + j * hy;
        return tf2::toMsg(Eigen::Vector3d(x, y, evaluateSurface(surface, x, y).z));
      };
      for (int i = 0; i < cells_; ++i)
        for (int j = 0; j < cells_; ++j)
        {
          const auto a = vertex(i, j), b = vertex(i + 1, j), c = vertex(i + 1, j + 1),
                     d = vertex(i, j + 1);
          // a formula may be undefined over part of the region (sqrt(x) for x < 0): leave it out
          if (std::isfinite(a.z) && std::isfinite(b.z) && std::isfinite(c.z) && std::isfinite(d.z))
            marker_.points.insert(marker_.points.end(), { a, b, c, a, c, d });
        }
    }
  }
  marker_.header = header;
  return marker_;
}

visualization_msgs::MarkerArray sceneMarkers(const std_msgs::Header& header, const Model& model,
                                             const Points& positions, SurfaceMeshCache& mesh_cache,
                                             bool scene_changed)
{
  visualization_msgs::MarkerArray array;
  const double size = 0.3 * typicalLength(model);

  visualization_msgs::Marker particles =
      makeMarker(header, "particles", 0, visualization_msgs::Marker::SPHERE_LIST);
  particles.scale.x = particles.scale.y = particles.scale.z = size;
  particles.color = color(1.0f, 0.55f, 0.1f, 1.0f);
  for (int i = 0; i < positions.cols(); ++i)
    particles.points.push_back(tf2::toMsg(Eigen::Vector3d(positions.col(i))));
  array.markers.push_back(particles);

  visualization_msgs::Marker links =
      makeMarker(header, "links", 0, visualization_msgs::Marker::LINE_LIST);
  links.scale.x = 0.25 * size;
  links.color = color(0.8f, 0.8f, 0.8f, 1.0f);
  for (const Constraint& c : model.scene().constraints)
    if (const auto* link = std::get_if<LinkConstraint>(&c))
    {
      links.points.push_back(tf2::toMsg(Eigen::Vector3d(positions.col(link->first))));
      links.points.push_back(tf2::toMsg(Eigen::Vector3d(positions.col(link->second))));
    }
  array.markers.push_back(links.points.empty() ? deleteMarker(header, "links", 0) : links);

  if (model.scene().surfaces.empty())
    array.markers.push_back(deleteMarker(header, "surface", 0));
  else
    array.markers.push_back(mesh_cache.mesh(header, model, positions, scene_changed));
  return array;
}

visualization_msgs::MarkerArray referenceMarkers(const std_msgs::Header& header, const Model& model,
                                                 const Points& live, const Points& reference,
                                                 double lifetime)
{
  visualization_msgs::MarkerArray array;
  const double size = 0.3 * typicalLength(model);
  visualization_msgs::Marker ghosts =
      makeMarker(header, REFERENCE_NAMESPACE, 0, visualization_msgs::Marker::SPHERE_LIST);
  ghosts.scale.x = ghosts.scale.y = ghosts.scale.z = 1.2 * size;
  ghosts.color = color(0.6f, 0.9f, 1.0f, 0.35f);
  ghosts.lifetime = ros::Duration(lifetime);
  visualization_msgs::Marker errors =
      makeMarker(header, REFERENCE_ERROR_NAMESPACE, 0, visualization_msgs::Marker::LINE_LIST);
  errors.scale.x = 0.1 * size;
  errors.color = color(1.0f, 0.2f, 0.6f, 0.9f);
  errors.lifetime = ros::Duration(lifetime);
  for (int i = 0; i < reference.cols() && i < live.cols(); ++i)
  {
    ghosts.points.push_back(tf2::toMsg(Eigen::Vector3d(reference.col(i))));
    errors.points.push_back(tf2::toMsg(Eigen::Vector3d(live.col(i))));
    errors.points.push_back(tf2::toMsg(Eigen::Vector3d(reference.col(i))));
  }
  array.markers.push_back(ghosts);
  array.markers.push_back(errors);
  return array;
}

}  // namespace constrained_particles
