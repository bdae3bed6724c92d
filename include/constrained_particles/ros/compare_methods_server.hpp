/// @file compare_methods_server.hpp
/// @brief ~compare_methods: the method study (core/method_study.hpp) as an actionlib action on
/// the node's scene. Goals are checked when they arrive (a bad one is rejected naming the field,
/// nothing else changes); an accepted one runs on the server's worker thread, at a low priority,
/// on copies of the runner's latest snapshot, so stepping, publishing and services go on. One
/// study at a time, as actionlib's SimpleActionServer: a new goal preempts the running study
/// (which ends PREEMPTED within the run under way) and starts once it has stopped; a cancel at
/// any point of a goal's life ends it RECALLED (not yet started) or PREEMPTED, never SUCCEEDED.
#pragma once

#include "constrained_particles/CompareMethodsAction.h"
#include "constrained_particles/core/method_study.hpp"
#include "constrained_particles/ros/simulation_runner.hpp"

#include <actionlib/server/action_server.h>
#include <ros/ros.h>

#include <atomic>
#include <condition_variable>
#include <memory>
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
  /// actionlib's server with its lock in reach: work() ends a goal SUCCEEDED only under the
  /// lock actionlib holds while it marks a goal cancelled (ActionServerBase::lock_, protected)
  class Server : public actionlib::ActionServer<CompareMethodsAction>
  {
  public:
    using actionlib::ActionServer<CompareMethodsAction>::ActionServer;
    boost::recursive_mutex& lock()
    {
      return lock_;
    }
  };
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

  /// A goal and the flag its study polls (its own: a later goal cannot clear it).
  struct Study
  {
    GoalHandle goal;
    Job job;
    std::shared_ptr<std::atomic<bool>> cancel;
  };

  /// Checks the goal and queues it, preempting the running study and recalling a queued one.
  void goalCallback(GoalHandle goal);
  /// Recalls the goal if queued, stops its study if running (actionlib has already marked it).
  void cancelCallback(GoalHandle goal);
  /// Checks a goal against the current snapshot and builds its job.
  /// @throws InvalidInput naming the field
  Job jobFor(const CompareMethodsGoal& goal) const;
  /// The worker: takes queued goals one at a time until the server is destroyed.
  void serve();
  /// Runs one accepted study and ends its goal: PREEMPTED if cancelled or preempted, whether
  /// by the flag or by actionlib's own status (a cancel that came while it was pending).
  void work(Study& study);
  /// Writes the CSV and draws the diagram (stopped once `cancel` is set); fills the result's
  /// paths, publishes the image. @return '' or what went wrong (the study itself still succeeded)
  std::string writeOutputs(const Job& job, const StudyResult& study,
                           const std::atomic<bool>& cancel, CompareMethodsResult& result);

  ros::NodeHandle nh_;
  SimulationRunner& runner_;
  std::string plot_script_;
  ros::Publisher diagram_publisher_;
  std::mutex mutex_;  // guards queued_, running_*, stopping_; taken before actionlib's lock
  std::condition_variable wake_;
  std::optional<Study> queued_;  // the next goal, still PENDING
  std::optional<GoalHandle> running_;
  std::shared_ptr<std::atomic<bool>> running_cancel_;
  std::atomic<bool> running_preempted_{ false };  // its stop came from a newer goal
  bool stopping_ = false;
  std::thread worker_;
  Server server_;  // last: its callbacks use everything above
};

}  // namespace constrained_particles
