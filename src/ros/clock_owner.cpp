#include "constrained_particles/ros/clock_owner.hpp"

#include "constrained_particles/core/types.hpp"

#include <ros/master.h>
#include <ros/names.h>
#include <ros/network.h>
#include <ros/this_node.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <algorithm>
#include <string>
#include <vector>

namespace constrained_particles
{
namespace
{
/// Whether `node` answers on its XML-RPC API (a node killed with SIGKILL stays registered).
bool nodeAnswers(const std::string& node)
{
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = node;
  std::string host;
  std::uint32_t port = 0;
  if (!ros::master::execute("lookupNode", args, result, payload, false) ||
      payload.getType() != XmlRpc::XmlRpcValue::TypeString ||
      !ros::network::splitURI(static_cast<std::string>(payload), host, port))
    return false;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue pid_args, pid_result;
  pid_args[0] = ros::this_node::getName();
  const bool answered = client.execute("getPid", pid_args, pid_result) && !client.isFault();
  client.close();
  return answered;
}

/// Nodes other than this one that publish `topic` and answer, from the master's system state.
std::vector<std::string> otherPublishers(const std::string& topic)
{
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  std::vector<std::string> nodes;
  if (!ros::master::execute("getSystemState", args, result, payload, true) ||
      payload.getType() != XmlRpc::XmlRpcValue::TypeArray || payload.size() < 1)
    return nodes;
  XmlRpc::XmlRpcValue& publishers = payload[0];
  for (int k = 0; k < publishers.size(); ++k)
  {
    if (static_cast<std::string>(publishers[k][0]) != topic)
      continue;
    for (int j = 0; j < publishers[k][1].size(); ++j)
      if (static_cast<std::string>(publishers[k][1][j]) != ros::this_node::getName() &&
          nodeAnswers(publishers[k][1][j]))
        nodes.push_back(publishers[k][1][j]);
  }
  return nodes;
}

std::string join(const std::vector<std::string>& items)
{
  std::string text;
  for (const std::string& item : items)
    text += (text.empty() ? "" : ", ") + item;
  return text;
}

}  // namespace

void requireClockFree(bool advertised)
{
  // the name after the node's remappings (__ns:=robot1 /clock:=/robot1/clock), as advertised
  const std::string clock = ros::names::resolve("/clock");
  std::vector<std::string> others = otherPublishers(clock);
  if (advertised)
    others.erase(std::remove_if(others.begin(), others.end(),
                                [](const std::string& other)
                                { return !(other < ros::this_node::getName()); }),
                 others.end());
  if (!others.empty())
    throw InvalidInput("~publish_clock", "= true, but " + clock + " is already published by " +
                                             join(others) + ": only one node may publish " + clock +
                                             "; start this one with _publish_clock:=false, or "
                                             "remap its clock (/clock:=<ns>/clock)");
}

}  // namespace constrained_particles
