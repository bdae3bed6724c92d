// simulator_node: reads ~parameters, then steps and publishes until shutdown.
#include "constrained_particles/ros/simulator_node.hpp"

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <thread>

namespace
{
volatile std::sig_atomic_t interrupted = 0;

// ours, not roscpp's: roscpp's ros::shutdown() waits for service callbacks in flight, and a
// ~step's callback waits for the runner, so the runner must be stopped first
void onSigint(int)
{
  interrupted = 1;
}

}  // namespace

int main(int argc, char** argv)
{
  ros::init(argc, argv, "simulator", ros::init_options::NoSigintHandler);
  std::signal(SIGINT, onSigint);
  // started before roscore: wait for it (throttled on the wall clock: ros::Time is not yet set)
  auto last_warning = std::chrono::steady_clock::now() - std::chrono::seconds(10);
  while (!interrupted && !ros::master::check())
  {
    if (std::chrono::steady_clock::now() - last_warning >= std::chrono::seconds(5))
    {
      ROS_WARN("simulator_node: waiting for the ROS master at %s", ros::master::getURI().c_str());
      last_warning = std::chrono::steady_clock::now();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (interrupted)
    return 0;
  // outlives the node: destroying the last handle shuts ROS (and its logging) down
  ros::NodeHandle private_nh("~");
  int status = 0;
  try
  {
    constrained_particles::SimulatorNode node(private_nh);
    // several threads: a ~step waiting for its steps must not hold up ~pause or publishing
    ros::AsyncSpinner spinner(4);
    spinner.start();
    // Ctrl-C, or a shutdown asked over the master's API (rosnode kill)
    while (!interrupted && ros::ok() && !ros::isShuttingDown())
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    // another node took /clock just after we started (logged then): as a refusal at start-up
    if (!node.refusal().empty())
      status = 1;
    // within 0.5 s even inside one long step: then leave without waiting for it
    if (!node.shutdown(std::chrono::milliseconds(400)))
    {
      ROS_WARN("simulator_node: a step is still running; exiting without waiting for it");
      std::_Exit(status);
    }
    ros::shutdown();
    spinner.stop();
  }
  catch (const constrained_particles::InvalidInput& e)
  {
    ROS_FATAL("simulator_node: bad parameter: %s", e.what());
    return 1;
  }
  return status;
}
