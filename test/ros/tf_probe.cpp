// tf_probe: a tf2 listener that counts tf2's own TF_REPEATED_DATA and TF_OLD_DATA warnings and
// reports, on ~report, the latest transform it holds for ~frame. With ~sim_time it follows /clock
// exactly as roscpp does under /use_sim_time (Time::setNow on each message), so one launch can
// hold listeners of both kinds.
#include <console_bridge/console.h>
#include <diagnostic_msgs/DiagnosticStatus.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <cstring>
#include <memory>
#include <string>

namespace
{
std::atomic<long> repeated{ 0 }, old_data{ 0 };

// tf2's BufferCore and TimeCache warn through console_bridge: count what they say
class CountingHandler : public console_bridge::OutputHandler
{
public:
  void log(const std::string& text, console_bridge::LogLevel level, const char* filename,
           int line) override
  {
    if (text.find("TF_REPEATED_DATA") != std::string::npos)
      ++repeated;
    if (text.find("TF_OLD_DATA") != std::string::npos)
      ++old_data;
    std::fprintf(stderr, "tf_probe: console_bridge %d: %s (%s:%d)\n", static_cast<int>(level),
                 text.c_str(), filename, line);
  }
};

std::string text(double value)
{
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.9f", value);
  return buffer;
}

}  // namespace

int main(int argc, char** argv)
{
  ros::init(argc, argv, "tf_probe");
  CountingHandler handler;
  console_bridge::useOutputHandler(&handler);
  ros::NodeHandle nh, private_nh("~");
  const bool sim_time = private_nh.param("sim_time", false);
  const std::string frame = private_nh.param<std::string>("frame", "particle_1");
  const std::string fixed = private_nh.param<std::string>("fixed_frame", "world");
  ros::Subscriber clock_subscriber;
  if (sim_time)
  {
    ros::Time::setNow(ros::Time());
    clock_subscriber = nh.subscribe<rosgraph_msgs::Clock>(
        "/clock", 100,
        boost::function<void(const rosgraph_msgs::ClockConstPtr&)>(
            [](const rosgraph_msgs::ClockConstPtr& m) { ros::Time::setNow(m->clock); }));
  }
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  ros::Publisher report = private_nh.advertise<diagnostic_msgs::DiagnosticStatus>("report", 10);
  long lookups = 0, failures = 0;
  ros::WallTimer timer =
      nh.createWallTimer(ros::WallDuration(0.05),
                         [&](const ros::WallTimerEvent&)
                         {
                           diagnostic_msgs::DiagnosticStatus status;
                           status.name = ros::this_node::getName();
                           auto add = [&status](const std::string& key, const std::string& value)
                           {
                             diagnostic_msgs::KeyValue kv;
                             kv.key = key;
                             kv.value = value;
                             status.values.push_back(kv);
                           };
                           try
                           {
                             const geometry_msgs::TransformStamped t =
                                 buffer.lookupTransform(fixed, frame, ros::Time(0));
                             ++lookups;
                             add("stamp", text(t.header.stamp.toSec()));
                             add("x", text(t.transform.translation.x));
                             add("y", text(t.transform.translation.y));
                             add("z", text(t.transform.translation.z));
                           }
                           catch (const tf2::TransformException& e)
                           {
                             ++failures;
                             status.message = e.what();
                           }
                           add("repeated", std::to_string(repeated.load()));
                           add("old_data", std::to_string(old_data.load()));
                           add("lookups", std::to_string(lookups));
                           add("failures", std::to_string(failures));
                           report.publish(status);
                         });
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ros::waitForShutdown();
  console_bridge::restorePreviousOutputHandler();
  return 0;
}
