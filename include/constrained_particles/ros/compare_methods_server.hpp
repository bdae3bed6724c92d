/// @file compare_methods_server.hpp
/// @brief ~compare_methods: the method study (core/method_study.hpp) as an actionlib action on
/// the node's scene. Goals are checked when they arrive (a bad one is rejected naming the field,
/// nothing else changes); an accepted one runs on a worker thread of its own, at a low priority,
/// on copies of the runner's latest snapshot, so stepping, publishing and services go on. One
/// study at a time; a cancel stops it within milliseconds (inside a run).
#pragma once

#include "constrained_particles/CompareMethodsAction.h"
#include "constrained_particles/core/method_study.hpp"
#include "constrained_particles/ros/simulation_runner.hpp"

#include <actionlib/server/action_server.h>
#include <ros/ros.h>

#include <atomic>
#include <mutex>
#include <optional>
#include <thread>

namespace constrained_particles
{
class CompareMethodsServer
{
public:
  /// Longest a diagram may take to draw before its plotting process is stopped [s].
  static constexpr double PLOT_TIMEOUT = 60.0;

  /// Advertises ~compare_methods and ~compare_methods/diagram (sensor_msgs/Image, latched) on
  /// `private_nh`. `plot_script`: the matplotlib script that draws the diagram.
  CompareMethodsServer(const ros::NodeHandle& private_nh, SimulationRunner& runner,
                       std::string plot_script);
  /// Cancels a running study and waits for its worker.
  ~CompareMethodsServer();

  CompareMethodsServer(const CompareMethodsServer&) = delete;
  CompareMethodsServer& operator=(const CompareMethodsServer&) = delete;

private:
  using Server = actionlib::ActionServer<CompareMethodsAction>;
  using GoalHandle = Server::GoalHandle;

  /// What an accepted goal runs on: copies, taken when it was accepted.
  struct Job
  {
    StudyRequest request;
    Scene scene;
    State start;
    std::string scenario;
    std::string output_directory;
  };

  void goalCallback(GoalHandle goal);
  void cancelCallback(GoalHandle goal);
  /// Checks a goal against the current snapshot and builds its job.
  /// @throws InvalidInput naming the field
  Job jobFor(const CompareMethodsGoal& goal) const;
  void work(GoalHandle goal, Job job);
  /// Writes the CSV and draws the diagram; fills the result's paths, publishes the image.
  /// @return '' or what went wrong (the study itself still succeeded)
  std::string writeOutputs(const Job& job, const StudyResult& study, CompareMethodsResult& result);

  ros::NodeHandle nh_;
  SimulationRunner& runner_;
  std::string plot_script_;
  ros::Publisher diagram_publisher_;
  std::mutex mutex_;  // guards busy_, current_ and worker_
  bool busy_ = false;
  std::optional<GoalHandle> current_;
  std::atomic<bool> cancel_{ false };
  std::thread worker_;
  Server server_;  // last: its callbacks use everything above
};

}  // namespace constrained_particles
