#include "constrained_particles/ros/obstacle_wrenches.hpp"

#include "constrained_particles/ros/anchor_wrenches.hpp"

#include <algorithm>

namespace constrained_particles
{
std::vector<ObstacleWrench> obstacleWrenches(const Model& model, const Points& positions,
                                             const std::vector<ContactState>& contacts,
                                             const std::vector<AnchorTrack>* carriers, double time)
{
  std::vector<ObstacleWrench> loads;
  const EffectContext context{ model.scene().surfaces, time, nullptr, carriers };
  const auto& rows = model.unilateral();
  const bool current = contacts.size() == rows.size();
  for (int k = 0; k < model.numParticleContacts(); ++k)
  {
    const auto* contact = std::get_if<ShapeContact>(&model.scene().constraints[rows[k].constraint]);
    if (!contact)
      continue;
    auto load =
        std::find_if(loads.begin(), loads.end(),
                     [&](const ObstacleWrench& w) { return w.shape == contact->shape.name; });
    if (load == loads.end())
      load = loads.insert(loads.end(), ObstacleWrench{ contact->shape.name });
    if (!current || contacts[k].mode == ContactMode::Separated)
      continue;
    const Vec3 p = positions.col(contact->particle);
    const ShapePose pose = shapePose(*contact, context);
    const Vec3 normal = evaluateShape(contact->shape, pose, p).normal;
    const Vec3 force = -(contacts[k].normal_force * normal + contacts[k].friction_force);
    const Vec3 at = p - contact->radius * normal;  // where the ball touches the shape
    load->force += force;
    load->torque += (at - pose.origin).cross(force);
  }
  // a link's capsule pushes at its point nearest the shape (frictionless: along the normal)
  for (int k = model.numParticleContacts(); k < model.numContacts(); ++k)
  {
    if (rows[k].kind != UnilateralKind::SegmentContact)
      continue;
    const SegmentContact& contact = unilateralRecord<SegmentContact>(model, rows[k]);
    auto load =
        std::find_if(loads.begin(), loads.end(),
                     [&](const ObstacleWrench& w) { return w.shape == contact.shape.name; });
    if (load == loads.end())
      load = loads.insert(loads.end(), ObstacleWrench{ contact.shape.name });
    if (!current || contacts[k].mode == ContactMode::Separated)
      continue;
    const SegmentFrame s = segmentFrame(contact, context, positions, positions);
    const Vec3 point = s.pointAt(positions.col(contact.first), positions.col(contact.second));
    const Vec3 force = -contacts[k].normal_force * s.frame.normal;
    const Vec3 at = point - contact.radius * s.frame.normal;
    load->force += force;
    load->torque += (at - shapePose(contact.shape, contact.carrier, context).origin).cross(force);
  }
  return loads;
}

std::string obstacleWrenchTopic(const std::string& shape)
{
  return wrenchTopic("obstacle_wrench", shape);
}

ObstacleWrenches::ObstacleWrenches(ros::NodeHandle node) : node_(std::move(node))
{
}

void ObstacleWrenches::update(const Snapshot& snap)
{
  if (snap.scene_serial == scene_serial_)
    return;
  // topics the new scene still has keep their publishers (and subscribers)
  std::map<std::string, ros::Publisher> kept;
  for (const ObstacleWrench& load : obstacleWrenches(*snap.model, snap.state.positions, {}))
  {
    const std::string topic = obstacleWrenchTopic(load.shape);
    const auto found = by_topic_.find(topic);
    kept[topic] = found != by_topic_.end()
                      ? found->second
                      : node_.advertise<geometry_msgs::WrenchStamped>(topic, 10);
  }
  by_topic_.swap(kept);
  scene_serial_ = snap.scene_serial;
}

void ObstacleWrenches::publish(const Snapshot& snap, const std_msgs::Header& header)
{
  update(snap);
  if (by_topic_.empty())
    return;
  bool listened = false;
  for (const auto& entry : by_topic_)
    listened = listened || entry.second.getNumSubscribers() > 0;
  if (!listened)
    return;
  for (const ObstacleWrench& load : obstacleWrenches(
           *snap.model, snap.state.positions, snap.contacts, &snap.carriers, snap.state.time))
  {
    auto found = by_topic_.find(obstacleWrenchTopic(load.shape));
    if (found == by_topic_.end() || found->second.getNumSubscribers() == 0 ||
        !load.force.allFinite() || !load.torque.allFinite())
      continue;
    geometry_msgs::WrenchStamped msg;
    msg.header = header;
    msg.wrench.force.x = load.force.x();
    msg.wrench.force.y = load.force.y();
    msg.wrench.force.z = load.force.z();
    msg.wrench.torque.x = load.torque.x();
    msg.wrench.torque.y = load.torque.y();
    msg.wrench.torque.z = load.torque.z();
    found->second.publish(msg);
  }
}

}  // namespace constrained_particles
