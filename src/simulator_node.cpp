// simulator_node: reads ~parameters, then steps and publishes until shutdown.
#include "constrained_particles/ros/simulator_node.hpp"

#include <chrono>
#include <cstdlib>
#include <thread>

int main(int argc, char** argv)
{
  ros::init(argc, argv, "simulator");
  // started before roscore: wait for it (throttled on the wall clock: ros::Time is not yet set)
  auto last_warning = std::chrono::steady_clock::now() - std::chrono::seconds(10);
  while (!ros::master::check() && ros::ok())
  {
    if (std::chrono::steady_clock::now() - last_warning >= std::chrono::seconds(5))
    {
      ROS_WARN("simulator_node: waiting for the ROS master at %s", ros::master::getURI().c_str());
      last_warning = std::chrono::steady_clock::now();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  if (!ros::ok())
    return 0;
  // outlives the node: destroying the last handle shuts ROS (and its logging) down
  ros::NodeHandle private_nh("~");
  try
  {
    constrained_particles::SimulatorNode node(private_nh);
    // several threads: a ~step waiting for its steps must not hold up ~pause or publishing
    ros::AsyncSpinner spinner(4);
    spinner.start();
    ros::waitForShutdown();
    // Ctrl-C within 0.5 s even inside one long step: then leave without waiting for it
    if (!node.shutdown(std::chrono::milliseconds(400)))
    {
      ROS_WARN("simulator_node: a step is still running; exiting without waiting for it");
      std::_Exit(0);
    }
    spinner.stop();
  }
  catch (const constrained_particles::InvalidInput& e)
  {
    ROS_FATAL("simulator_node: bad parameter: %s", e.what());
    return 1;
  }
  return 0;
}
