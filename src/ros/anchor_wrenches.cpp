#include "constrained_particles/ros/anchor_wrenches.hpp"

#include <cctype>
#include <utility>

namespace constrained_particles
{
Vec3 holderForce(const Model& model, const Eigen::VectorXd& multipliers, int eliminated_index)
{
  // Newton's third law: the particle pushes its holder with minus the holder's push on it
  return -model.eliminatedReaction(multipliers, eliminated_index);
}

std::string anchorWrenchTopic(const std::string& frame)
{
  return wrenchTopic("anchor_wrench", frame);
}

std::string wrenchTopic(const std::string& prefix, const std::string& name_in)
{
  std::string name = name_in;
  for (char& c : name)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
          c == '/'))
      c = '_';
  // a ROS name's parts start with a letter (or '_' in a private name): frames rarely break it
  std::string topic = prefix;
  std::string part;
  for (std::size_t i = 0; i <= name.size(); ++i)
  {
    if (i == name.size() || name[i] == '/')
    {
      if (!part.empty())
        topic += "/" + (std::isalpha(static_cast<unsigned char>(part[0])) ? part : "_" + part);
      part.clear();
    }
    else
      part += name[i];
  }
  return topic;
}

AnchorWrenches::AnchorWrenches(ros::NodeHandle node, std::string frame_prefix)
  : node_(std::move(node)), frame_prefix_(std::move(frame_prefix))
{
}

void AnchorWrenches::update(const Snapshot& snap)
{
  const std::vector<int>& held = snap.model->eliminatedParticles();
  if (snap.scene_serial != scene_serial_ || snap.tracks_serial != tracks_serial_)
  {
    // a new scene may hold other particles: new topics first, then the vanished ones end, so a
    // holder's subscriber stays connected across a reset or a change of forces
    std::map<std::string, ros::Publisher> kept;
    for (const int particle : held)
    {
      const std::string topic = anchorWrenchTopic(frame_prefix_ + std::to_string(particle));
      const auto found = by_topic_.find(topic);
      kept[topic] = found != by_topic_.end()
                        ? found->second
                        : node_.advertise<geometry_msgs::WrenchStamped>(topic, 10);
    }
    by_topic_.swap(kept);
    publishers_.clear();
    for (const int particle : held)
      publishers_.push_back(
          &by_topic_[anchorWrenchTopic(frame_prefix_ + std::to_string(particle))]);
    scene_serial_ = snap.scene_serial;
    tracks_serial_ = snap.tracks_serial;
  }
}

void AnchorWrenches::publish(const Snapshot& snap, const std_msgs::Header& header)
{
  update(snap);
  const Model& model = *snap.model;
  if (snap.multipliers.size() != model.numMultipliers())
    return;  // not the snapshot's model: never a force of one scene on another's topic
  for (std::size_t k = 0; k < publishers_.size(); ++k)
  {
    if (publishers_[k]->getNumSubscribers() == 0)
      continue;
    Vec3 force = holderForce(model, snap.multipliers, static_cast<int>(k));
    geometry_msgs::WrenchStamped msg;
    msg.header = header;
    // a frame anchor's holder reads it in its own frame, as a force/torque sensor in it would
    const auto* anchor =
        std::get_if<FrameAnchorConstraint>(&model.scene().constraints[model.eliminated()[k]]);
    if (anchor && !anchor->frame.empty() &&
        anchor->track < static_cast<int>(snap.holder_orientations.size()))
    {
      force = snap.holder_orientations[anchor->track].conjugate() * force;
      msg.header.frame_id = anchor->frame;
    }
    msg.wrench.force.x = force.x();
    msg.wrench.force.y = force.y();
    msg.wrench.force.z = force.z();
    publishers_[k]->publish(msg);
  }
}

}  // namespace constrained_particles
