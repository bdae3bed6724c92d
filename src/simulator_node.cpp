// simulator_node: reads ~parameters, then steps and publishes until shutdown.
#include "constrained_particles/ros/simulator_node.hpp"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "simulator");
  // started before roscore: wait for it rather than read defaults from nowhere
  while (!ros::master::check() && ros::ok())
  {
    ROS_WARN_THROTTLE(5.0, "simulator_node: waiting for the ROS master at %s",
                      ros::master::getURI().c_str());
    ros::WallDuration(0.2).sleep();
  }
  // outlives the node: destroying the last handle shuts ROS (and its logging) down
  ros::NodeHandle private_nh("~");
  try
  {
    constrained_particles::SimulatorNode node(private_nh);
    ros::spin();
  }
  catch (const constrained_particles::InvalidInput& e)
  {
    ROS_FATAL("simulator_node: bad parameter: %s", e.what());
    return 1;
  }
  return 0;
}
