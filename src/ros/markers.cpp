#include "constrained_particles/ros/markers.hpp"

#include "constrained_particles/core/rope_readings.hpp"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <tuple>
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

}  // namespace

double particleSize(const Model& model)
{
  double shortest = 0.0;
  for (const Constraint& c : model.scene().constraints)
    if (const auto* link = std::get_if<LinkConstraint>(&c))
      shortest = shortest > 0.0 ? std::min(shortest, link->length) : link->length;
  // a rope with a thickness (its obstacles' radius, or its self-collision's) is drawn that thick
  double thickest = 0.0;
  for (const Constraint& c : model.scene().constraints)
    if (const auto* contact = std::get_if<ShapeContact>(&c))
      thickest = std::max(thickest, 2.0 * contact->radius);
    else if (const auto* segment = std::get_if<SegmentContact>(&c))
      thickest = std::max(thickest, 2.0 * segment->radius);
  for (const SelfCollision& rope : model.scene().self_collisions)  // or its own links' radius
    thickest = std::max(thickest, 2.0 * rope.radius);
  return thickest > 0.0 ? thickest : 0.3 * (shortest > 0.0 ? shortest : 0.5);
}

double arrowScale(double force_scale, const Points& forces, double region_radius,
                  double force_floor)
{
  if (force_scale > 0.0)
    return force_scale;
  const double largest =
      std::max(forces.cols() > 0 ? forces.colwise().norm().maxCoeff() : 0.0, force_floor);
  return largest > 0.0 && std::isfinite(largest) ? FORCE_ARROW_FRACTION * region_radius / largest
                                                 : 0.0;
}

double arrowForceFloor(const Model& model)
{
  double mass = 0.0;
  for (const double m : model.scene().masses)
    mass += m;
  return ARROW_FORCE_FLOOR * mass * 9.81;
}

visualization_msgs::MarkerArray contactForceMarkers(const std_msgs::Header& header,
                                                    const Model& model, const Points& positions,
                                                    const std::vector<ContactState>& contacts,
                                                    double scale, int previous_count,
                                                    const std::vector<AnchorTrack>* carriers,
                                                    double time)
{
  const EffectContext context{ model.scene().surfaces, time, nullptr, carriers };
  visualization_msgs::MarkerArray array;
  const auto& table = model.unilateral();
  const std::size_t count = static_cast<std::size_t>(model.numParticleContacts());
  for (std::size_t k = 0; k < count && k < contacts.size(); ++k)
  {
    const ContactState& contact = contacts[k];
    const Eigen::Vector3d start = positions.col(table[k].particles[0]);
    const ContactFrame frame = contactFrame(model, table[k], context, positions, positions);
    const Eigen::Vector3d forces[2] = { contact.normal_force * frame.normal.normalized(),
                                        contact.friction_force };
    const int id = 2 * static_cast<int>(k);
    for (int a = 0; a < 2; ++a)
    {
      const Eigen::Vector3d end = start + scale * forces[a];
      if (contact.mode == ContactMode::Separated || !end.allFinite() || !start.allFinite())
      {
        array.markers.push_back(deleteMarker(header, CONTACT_FORCE_NAMESPACE, id + a));
        continue;
      }
      visualization_msgs::Marker m =
          makeMarker(header, CONTACT_FORCE_NAMESPACE, id + a, visualization_msgs::Marker::ARROW);
      m.points = { tf2::toMsg(start), tf2::toMsg(end) };
      m.scale.x = 0.015;  // shaft diameter [m]
      m.scale.y = 0.03;   // head diameter [m]
      m.color = a == 0 ? color(0.1f, 0.8f, 0.2f, 1.0f) : color(1.0f, 0.55f, 0.0f, 1.0f);
      array.markers.push_back(m);
    }
  }
  // a link's capsule: its normal force at its point nearest the obstacle (frictionless), ids 2k;
  // a rope's link pair: the push on link a at its point nearest link b
  int next_id = 2 * static_cast<int>(count);
  for (std::size_t k = count; k < table.size() && k < contacts.size(); ++k)
  {
    Eigen::Vector3d start, normal;
    if (table[k].kind == UnilateralKind::SegmentContact)
    {
      const SegmentContact& segment = unilateralRecord<SegmentContact>(model, table[k]);
      const SegmentFrame frame = segmentFrame(segment, context, positions, positions);
      start = frame.pointAt(positions.col(segment.first), positions.col(segment.second));
      normal = frame.frame.normal;
    }
    else if (table[k].kind == UnilateralKind::LinkPairContact)
    {
      const LinkPairContact& pair = unilateralRecord<LinkPairContact>(model, table[k]);
      const LinkPairFrame frame = linkPairGeometry(pair, positions);
      start =
          (1.0 - frame.s) * positions.col(pair.first_a) + frame.s * positions.col(pair.second_a);
      normal = frame.normal;
    }
    else
      continue;
    const Eigen::Vector3d end = start + scale * contacts[k].normal_force * normal;
    const int id = 2 * static_cast<int>(k);
    for (; next_id < id; ++next_id)  // slack links before it: none
      array.markers.push_back(deleteMarker(header, CONTACT_FORCE_NAMESPACE, next_id));
    next_id = id + 1;
    if (contacts[k].mode == ContactMode::Separated || !end.allFinite() || !start.allFinite())
    {
      array.markers.push_back(deleteMarker(header, CONTACT_FORCE_NAMESPACE, id));
      continue;
    }
    visualization_msgs::Marker m =
        makeMarker(header, CONTACT_FORCE_NAMESPACE, id, visualization_msgs::Marker::ARROW);
    m.points = { tf2::toMsg(start), tf2::toMsg(end) };
    m.scale.x = 0.015;  // shaft diameter [m]
    m.scale.y = 0.03;   // head diameter [m]
    m.color = color(0.1f, 0.8f, 0.2f, 1.0f);
    array.markers.push_back(m);
  }
  for (int id = next_id; id < previous_count; ++id)
    array.markers.push_back(deleteMarker(header, CONTACT_FORCE_NAMESPACE, id));
  return array;
}

visualization_msgs::MarkerArray constraintForceMarkers(const std_msgs::Header& header,
                                                       const Points& positions,
                                                       const Points& forces, double scale,
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
    m.points = { tf2::toMsg(start), tf2::toMsg(Eigen::Vector3d(start + scale * force)) };
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

visualization_msgs::MarkerArray surfaceMarkers(const std_msgs::Header& header, const Model& model,
                                               const Vec3& low, const Vec3& high, int cells)
{
  visualization_msgs::MarkerArray array;
  if (model.scene().surfaces.empty())
  {
    array.markers.push_back(deleteMarker(header, "surface", 0));
    return array;
  }
  visualization_msgs::Marker mesh =
      makeMarker(header, "surface", 0, visualization_msgs::Marker::TRIANGLE_LIST);
  mesh.scale.x = mesh.scale.y = mesh.scale.z = 1.0;
  mesh.color = color(0.3f, 0.7f, 0.9f, 0.6f);
  const double hx = (high.x() - low.x()) / cells, hy = (high.y() - low.y()) / cells;
  for (const Surface& surface : model.scene().surfaces)
  {
    auto vertex = [&](int i, int j)
    {
      const double x = low.x() + i * hx, y = low.y() + j * hy;
      return tf2::toMsg(Eigen::Vector3d(x, y, evaluateSurface(surface, x, y).z));
    };
    for (int i = 0; i < cells; ++i)
      for (int j = 0; j < cells; ++j)
      {
        const auto a = vertex(i, j), b = vertex(i + 1, j), c = vertex(i + 1, j + 1),
                   d = vertex(i, j + 1);
        // a formula may be undefined over part of the region (sqrt(x) for x < 0): leave it out
        if (std::isfinite(a.z) && std::isfinite(b.z) && std::isfinite(c.z) && std::isfinite(d.z))
          mesh.points.insert(mesh.points.end(), { a, b, c, a, c, d });
      }
  }
  array.markers.push_back(mesh);
  return array;
}

bool topicCarriedShapes(const Model& model)
{
  for (const Shape& shape : model.carriers())
    if (shape.frame.empty() && !shape.topic.empty())
      return true;
  return false;
}

// Triangles a mesh obstacle's marker lists at most; a larger mesh is drawn as its bounding box.
constexpr std::size_t MESH_MARKER_TRIANGLES = 20000;

visualization_msgs::MarkerArray obstacleMarkers(const std_msgs::Header& header, const Model& model,
                                                const Vec3& low, const Vec3& high,
                                                const std::vector<AnchorTrack>* carriers,
                                                double time, bool topic_carried_only)
{
  visualization_msgs::MarkerArray array;
  visualization_msgs::Marker clear = makeMarker(header, "obstacles", 0, 0);
  clear.action = visualization_msgs::Marker::DELETEALL;
  array.markers.push_back(clear);
  std::vector<std::string> drawn;
  int id = 0;
  // a pose-topic shape's holder frame in header's: where its track has it at `time`
  Vec3 holder_origin = Vec3::Zero();
  Eigen::Matrix3d holder_turn = Eigen::Matrix3d::Identity();
  auto add = [&](const Shape& shape, int type, const Vec3& centre, const Vec3& scale)
  {
    const int marker_id = id++;  // counted for every shape: the ids stay those of the whole set
    if (topic_carried_only && !(shape.frame.empty() && !shape.topic.empty()))
      return;
    visualization_msgs::Marker m = makeMarker(header, "obstacles", marker_id, type);
    if (!shape.frame.empty())
    {
      // its pose is in its frame, and rviz moves it with tf's newest pose of it (frame_locked;
      // stamp 0: a latched marker a late subscriber takes is still placed)
      m.header.frame_id = shape.frame;
      m.header.stamp = ros::Time(0);
      m.frame_locked = true;
    }
    const Vec3 at = holder_origin + holder_turn * centre;
    const Eigen::Matrix3d turn = holder_turn * shape.rotation;
    if (!at.allFinite() || !turn.allFinite())
      return;  // nothing non-finite reaches rviz
    m.pose.position = tf2::toMsg(Eigen::Vector3d(at));
    m.pose.orientation = tf2::toMsg(Eigen::Quaterniond(turn));  // tf2_eigen converts
    m.scale.x = scale.x();
    m.scale.y = scale.y();
    m.scale.z = scale.z();
    m.color = color(0.55f, 0.55f, 0.6f, 0.8f);
    array.markers.push_back(m);
  };
  for (const Constraint& c : model.scene().constraints)
  {
    // a shape a particle or a link keeps out of, with its carrier
    const Shape* named = nullptr;
    int carrier = -1;
    if (const auto* contact = std::get_if<ShapeContact>(&c))
      std::tie(named, carrier) = std::make_pair(&contact->shape, contact->carrier);
    else if (const auto* segment = std::get_if<SegmentContact>(&c))
      std::tie(named, carrier) = std::make_pair(&segment->shape, segment->carrier);
    if (!named || std::find(drawn.begin(), drawn.end(), named->name) != drawn.end())
      continue;
    drawn.push_back(named->name);
    const Shape& shape = *named;
    holder_origin.setZero();
    holder_turn.setIdentity();
    if (shape.frame.empty() && !shape.topic.empty())
    {
      // on a pose topic: no frame rviz could carry it in, so drawn where its track has it
      if (!carriers || carrier < 0 || static_cast<std::size_t>(carrier) >= carriers->size())
        continue;
      const AnchorTrack& track = (*carriers)[static_cast<std::size_t>(carrier)];
      holder_origin = track.motion(time).position;
      holder_turn = track.orientation(time).toRotationMatrix();
    }
    const Vec3 axis = shape.rotation.col(2);
    const double d = 2.0 * shape.radius;
    switch (shape.type)
    {
      case ShapeType::Plane:
      {
        // a thin slab under the plane, centred below the region's centre, as wide as the region
        // (a carried plane's region is not known in its holder's frame: centred at its origin)
        const Vec3 middle = shape.carried() ? shape.position : Vec3(0.5 * (low + high));
        const Vec3 foot = middle - axis * axis.dot(middle - shape.position);
        const double width = 2.0 * (high - low).norm();
        add(shape, visualization_msgs::Marker::CUBE, foot - 0.005 * axis, Vec3(width, width, 0.01));
        break;
      }
      case ShapeType::Sphere:
        add(shape, visualization_msgs::Marker::SPHERE, shape.position, Vec3(d, d, d));
        break;
      case ShapeType::Box:
        add(shape, visualization_msgs::Marker::CUBE, shape.position, shape.size);
        break;
      case ShapeType::Cylinder:
        add(shape, visualization_msgs::Marker::CYLINDER, shape.position, Vec3(d, d, shape.length));
        break;
      case ShapeType::Capsule:
        add(shape, visualization_msgs::Marker::CYLINDER, shape.position, Vec3(d, d, shape.length));
        for (const double end : { -0.5, 0.5 })
          add(shape, visualization_msgs::Marker::SPHERE, shape.position + end * shape.length * axis,
              Vec3(d, d, d));
        break;
      case ShapeType::Mesh:
      {
        // its triangles in its own frame (rviz reads no file: a mesh from any path draws); one
        // of more than MESH_MARKER_TRIANGLES as its bounding box (a marker of 3 points a
        // triangle, sent at every change, and each tick where a topic carries it)
        if (!shape.mesh)
          break;
        const TriangleMesh& mesh = *shape.mesh;
        if (mesh.triangles.size() > MESH_MARKER_TRIANGLES)
        {
          add(shape, visualization_msgs::Marker::CUBE,
              shape.position + shape.rotation * (0.5 * (mesh.low + mesh.high)),
              mesh.high - mesh.low);
          break;
        }
        const std::size_t before = array.markers.size();
        add(shape, visualization_msgs::Marker::TRIANGLE_LIST, shape.position, Vec3::Ones());
        if (array.markers.size() > before)
          for (const auto& triangle : mesh.triangles)
            for (const int v : triangle)
              array.markers.back().points.push_back(tf2::toMsg(Eigen::Vector3d(mesh.vertices[v])));
        break;
      }
    }
  }
  return array;
}

std_msgs::ColorRGBA tensionColor(double tension, double largest)
{
  // grey at no load, to red at the largest pull now, to blue at the largest push
  const float share =
      largest > 0.0 ? static_cast<float>(std::min(std::abs(tension) / largest, 1.0)) : 0.0f;
  const float grey = 0.8f * (1.0f - share);
  return tension >= 0.0 ? color(grey + share, grey, grey, 1.0f)
                        : color(grey, grey, grey + share, 1.0f);
}

visualization_msgs::MarkerArray sceneMarkers(const std_msgs::Header& header, const Model& model,
                                             const Points& positions,
                                             const Eigen::VectorXd& multipliers)
{
  visualization_msgs::MarkerArray array;
  const double size = particleSize(model);

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
  // each link and slack link, coloured by its tension (rope_readings.hpp) where it is known
  const bool known = multipliers.size() >= model.numRows() && multipliers.allFinite();
  const std::vector<LinkTension> tensions =
      linkTensions(model, positions, known ? multipliers : Eigen::VectorXd::Zero(model.numRows()));
  double largest = 0.0;
  for (const LinkTension& link : tensions)
    largest = std::max(largest, std::abs(link.tension));
  for (const LinkTension& link : tensions)
  {
    links.points.push_back(tf2::toMsg(Eigen::Vector3d(positions.col(link.first))));
    links.points.push_back(tf2::toMsg(Eigen::Vector3d(positions.col(link.second))));
    const std_msgs::ColorRGBA shade = tensionColor(link.tension, largest);
    links.colors.push_back(shade);
    links.colors.push_back(shade);
  }
  array.markers.push_back(links.points.empty() ? deleteMarker(header, "links", 0) : links);
  return array;
}

visualization_msgs::MarkerArray referenceMarkers(const std_msgs::Header& header, const Model& model,
                                                 const Points& live, const Points& reference,
                                                 double lifetime)
{
  visualization_msgs::MarkerArray array;
  const double size = particleSize(model);
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
