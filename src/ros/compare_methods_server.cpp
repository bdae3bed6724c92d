#include "constrained_particles/ros/compare_methods_server.hpp"

#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/ros/shadow_reference.hpp"

#include <sensor_msgs/Image.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <spawn.h>
#include <sys/wait.h>

extern char** environ;

namespace constrained_particles
{
namespace
{
/// Runs `argv` and waits up to `timeout` [s]; a process still running then, or once `cancel`
/// is set, is stopped. @return '' or what went wrong
std::string runProcess(const std::vector<std::string>& args, double timeout,
                       const std::atomic<bool>& cancel)
{
  std::vector<char*> argv;
  for (const std::string& a : args)
    argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0)
    return "could not start " + args[0];
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0)
  {
    if (cancel || std::chrono::steady_clock::now() > deadline)
    {
      kill(pid, SIGKILL);  // ours, by its pid
      waitpid(pid, &status, 0);
      return cancel ? args[1] + " stopped: the goal was cancelled"
                    : args[1] + " took over " + formatValue(timeout) + " s and was stopped";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return args[1] + " failed (exit status " + std::to_string(WEXITSTATUS(status)) +
           "); is python3-matplotlib installed?";
  return "";
}

/// The image the plotting script wrote raw: "width height\n" then width x height RGBA bytes.
bool readRawImage(const std::string& path, sensor_msgs::Image& image)
{
  std::ifstream in(path, std::ios::binary);
  int width = 0, height = 0;
  if (!(in >> width >> height) || width <= 0 || height <= 0 || width > 10000 || height > 10000)
    return false;
  in.get();  // the newline
  image.width = static_cast<std::uint32_t>(width);
  image.height = static_cast<std::uint32_t>(height);
  image.encoding = "rgba8";
  image.step = 4 * image.width;
  image.data.resize(static_cast<std::size_t>(image.step) * image.height);
  in.read(reinterpret_cast<char*>(image.data.data()),
          static_cast<std::streamsize>(image.data.size()));
  return static_cast<std::size_t>(in.gcount()) == image.data.size();
}

/// Method message -> core method. @throws InvalidInput naming methods[k].<field>
StudyMethod fromMsg(const Method& m, std::size_t k)
{
  const std::string field = "methods[" + std::to_string(k) + "]";
  StudyMethod method;
  method.integrator = findIntegrator(m.integrator, field + ".integrator").name;
  method.stabilization = m.stabilization.empty()
                             ? Stabilization::Projection
                             : parseStabilization(m.stabilization, field + ".stabilization");
  method.dt = m.dt;
  method.tolerance = m.tolerance;
  return method;
}

Method toMsg(const StudyMethod& m)
{
  Method msg;
  msg.integrator = m.integrator;
  msg.stabilization = stabilizationName(m.stabilization);
  msg.dt = m.dt;
  msg.tolerance = m.tolerance;
  return msg;
}

}  // namespace

CompareMethodsServer::CompareMethodsServer(const ros::NodeHandle& private_nh,
                                           SimulationRunner& runner, std::string plot_script)
  : nh_(private_nh)
  , runner_(runner)
  , plot_script_(std::move(plot_script))
  , diagram_publisher_(nh_.advertise<sensor_msgs::Image>("compare_methods/diagram", 1, true))
  , server_(
        nh_, "compare_methods", [this](GoalHandle g) { goalCallback(g); },
        [this](GoalHandle g) { cancelCallback(g); }, false)
{
  server_.start();
  // after the server: a throwing constructor leaves no joinable thread (goals queued meanwhile
  // are taken by the first wait)
  worker_ = std::thread(&CompareMethodsServer::serve, this);
}

CompareMethodsServer::~CompareMethodsServer()
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    if (running_cancel_)
      *running_cancel_ = true;
    if (queued_)
    {
      CompareMethodsResult result;
      result.recommended = -1;
      result.message = "the node is shutting down";
      queued_->goal.setCanceled(result, result.message);
      queued_.reset();
    }
  }
  wake_.notify_all();
  worker_.join();
}

CompareMethodsServer::Job CompareMethodsServer::jobFor(const CompareMethodsGoal& goal) const
{
  const std::shared_ptr<const Snapshot> snap = runner_.snapshot();
  Job job;
  job.request.horizon = goal.horizon;
  job.request.error_target = goal.error_target;
  job.request.base = snap->parameters.step;
  job.request.carriers = snap->carriers;  // the obstacles where they are, at rest
  requireInRange("methods", static_cast<double>(goal.methods.size()), limits::STUDY_METHODS);
  for (std::size_t k = 0; k < goal.methods.size(); ++k)
    job.request.methods.push_back(fromMsg(goal.methods[k], k));
  validateStudyRequest(job.request);
  // one part of a study split across nodes: methods k with k % parts == part
  const std::uint32_t parts = std::max<std::uint32_t>(goal.parts, 1);
  if (goal.part >= parts)
    throw InvalidInput("part", "= " + std::to_string(goal.part) + ", must be below parts (" +
                                   std::to_string(parts) + ")");
  if (parts > 1)
  {
    const std::vector<StudyMethod> all = job.request.methods.empty()
                                             ? studyDefaultMethods(job.request.base.dt)
                                             : job.request.methods;
    job.request.methods.clear();
    for (std::size_t k = goal.part; k < all.size(); k += parts)
      job.request.methods.push_back(all[k]);
    if (job.request.methods.empty())
      throw InvalidInput("part", "= " + std::to_string(goal.part) + " of " + std::to_string(parts) +
                                     " holds no method (the study has " +
                                     std::to_string(all.size()) + ")");
  }
  if (!goal.output_directory.empty())
  {
    namespace fs = std::filesystem;
    std::error_code error;
    fs::create_directories(goal.output_directory, error);
    const fs::path probe = fs::path(goal.output_directory) / ".compare_methods_write_test";
    std::ofstream out(probe);
    const bool writable = !error && out.good() && (out << "x") && (out.close(), true);
    fs::remove(probe, error);
    if (!writable)
      throw InvalidInput("output_directory",
                         "= '" + goal.output_directory + "' cannot be created or written to");
    job.output_directory = fs::absolute(goal.output_directory).string();
  }
  const BuiltScene built = buildScene(*snap->scene);
  job.scene = built.scene;
  job.start = goal.from_current_state ? snap->state : built.initial_state;
  job.scenario = snap->scene->name;
  return job;
}

void CompareMethodsServer::goalCallback(GoalHandle goal)
{
  CompareMethodsResult result;
  result.recommended = -1;
  Job job;
  try
  {
    job = jobFor(*goal.getGoal());
  }
  catch (const InvalidInput& e)
  {
    result.message = e.what();
    ROS_WARN("~compare_methods: goal rejected: %s", e.what());
    goal.setRejected(result, result.message);
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (stopping_)
  {
    result.message = "the node is shutting down";
    goal.setRejected(result, result.message);
    return;
  }
  // the newest goal wins, as with actionlib's SimpleActionServer: a queued one is recalled, a
  // running one stops inside its run and ends PREEMPTED
  if (queued_)
  {
    result.message = "preempted by a newer goal before it started";
    queued_->goal.setCanceled(result, result.message);
  }
  if (running_cancel_)
  {
    running_preempted_ = true;  // first: work() reads it once it sees the flag
    *running_cancel_ = true;
  }
  queued_ = Study{ goal, std::move(job), std::make_shared<std::atomic<bool>>(false) };
  wake_.notify_all();
}

void CompareMethodsServer::cancelCallback(GoalHandle goal)
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (queued_ && queued_->goal == goal)
  {
    CompareMethodsResult result;
    result.recommended = -1;
    result.message = "cancelled before it started";
    queued_->goal.setCanceled(result, result.message);  // RECALLED
    queued_.reset();
  }
  else if (running_ && *running_ == goal)
    *running_cancel_ = true;
}

namespace
{
/// Whether actionlib has a cancel request on the goal (its status, which no later callback can
/// reset: PREEMPTING once accepted, RECALLING before).
template <typename GoalHandle>
bool cancelRequested(GoalHandle& goal)
{
  const std::uint8_t status = goal.getGoalStatus().status;
  return status == actionlib_msgs::GoalStatus::PREEMPTING ||
         status == actionlib_msgs::GoalStatus::RECALLING;
}
}  // namespace

void CompareMethodsServer::serve()
{
  // the study yields the cores to live stepping: it is the one that may take longer
  lowerThreadPriority();
  for (;;)
  {
    std::optional<Study> study;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || queued_; });
      if (stopping_)
        return;
      study.swap(queued_);
      CompareMethodsResult result;
      result.recommended = -1;
      if (cancelRequested(study->goal))  // a cancel came while it was pending: RECALLED
      {
        result.message = "cancelled before it started";
        study->goal.setCanceled(result, result.message);
        continue;
      }
      running_ = study->goal;
      running_cancel_ = study->cancel;
      study->goal.setAccepted("study accepted");
      // a cancel between the check above and the acceptance: PREEMPTING now
      if (cancelRequested(study->goal))
        *study->cancel = true;
    }
    work(*study);
    std::lock_guard<std::mutex> lock(mutex_);
    running_.reset();
    running_cancel_.reset();
    running_preempted_ = false;
  }
}

void CompareMethodsServer::work(Study& s)
{
  GoalHandle& goal = s.goal;
  const Job& job = s.job;
  CompareMethodsResult result;
  result.recommended = -1;
  result.scenario = job.scenario;
  result.start_time = job.start.time;
  try
  {
    const StudyResult study = runMethodStudy(
        job.scene, job.start, job.request,
        [&goal](int done, int total, const std::string& current)
        {
          CompareMethodsFeedback feedback;
          feedback.done = static_cast<std::uint32_t>(done);
          feedback.total = static_cast<std::uint32_t>(total);
          feedback.current = current;
          goal.publishFeedback(feedback);
        },
        s.cancel.get());
    for (const StudyRun& run : study.runs)
    {
      MethodRun r;
      r.method = toMsg(run.method);
      r.position_error = run.position_error;
      r.max_constraint_error = run.max_constraint_error;
      r.energy_drift = run.energy_drift;
      r.cpu_time_per_sim_second = run.cpu_time_per_sim_second;
      r.steps = static_cast<std::uint64_t>(run.steps);
      r.substeps = static_cast<std::uint64_t>(run.substeps);
      r.finite = run.finite;
      r.failure = run.failure;
      result.runs.push_back(r);
    }
    result.reference_error = study.reference_error;
    result.reference_cpu_time_per_sim_second = study.reference_cpu_time_per_sim_second;
    result.recommended = study.recommended;
    result.horizon = study.horizon;
    result.error_target = study.error_target;
    // no mutex_ here: it may run under actionlib's lock, which goalCallback takes under mutex_
    auto endCancelled = [&]
    {
      result.message =
          (running_preempted_ ? "preempted by a newer goal after " : "cancelled after ") +
          std::to_string(study.runs.size()) + " runs";
      goal.setCanceled(result, result.message);
    };
    // a cancel that came after the last run still ends it PREEMPTED (its runs are kept)
    if (study.cancelled || *s.cancel || cancelRequested(goal))
      return endCancelled();
    result.message = study.recommended >= 0
                         ? "cheapest run within " + formatValue(study.error_target) +
                               " m: " + studyMethodLabel(study.runs[study.recommended].method) +
                               " (" +
                               formatValue(study.runs[study.recommended].cpu_time_per_sim_second) +
                               " s CPU per sim s)"
                         : "no run met " + formatValue(study.error_target) +
                               " m (reference error " + formatValue(study.reference_error) + " m)";
    if (!job.output_directory.empty())
      if (const std::string problem = writeOutputs(job, study, *s.cancel, result); !problem.empty())
        result.message += "; " + problem;
    // the last check and the success under actionlib's own lock, which its cancel handling
    // holds while it marks a goal PREEMPTING: a cancel is seen here, or comes after the result
    boost::recursive_mutex::scoped_lock actionlib_lock(server_.lock());
    if (*s.cancel || cancelRequested(goal))
      return endCancelled();
    ROS_INFO("~compare_methods on '%s': %s", job.scenario.c_str(), result.message.c_str());
    goal.setSucceeded(result, result.message);
  }
  catch (const std::exception& e)
  {
    result.message = std::string("study failed: ") + e.what();
    ROS_WARN("~compare_methods: %s", result.message.c_str());
    goal.setAborted(result, result.message);
  }
}

std::string CompareMethodsServer::writeOutputs(const Job& job, const StudyResult& study,
                                               const std::atomic<bool>& cancel,
                                               CompareMethodsResult& result)
{
  const std::string base = job.output_directory + "/" + job.scenario + "_compare_methods";
  {
    std::ofstream csv(base + ".csv");
    csv << studyCsv(study);
    if (!csv.good())
      return "could not write " + base + ".csv";
  }
  result.csv_path = base + ".csv";
  // matplotlib draws it (a well-kept plotting library; C++ has none packaged that we trust more)
  const std::string raw = base + ".rgba";
  const std::string problem = runProcess({ "/usr/bin/python3", plot_script_, result.csv_path,
                                           base + ".png", "--raw", raw, "--title", job.scenario },
                                         PLOT_TIMEOUT, cancel);
  if (!problem.empty())
    return "diagram not drawn: " + problem;
  result.diagram_path = base + ".png";
  sensor_msgs::Image image;
  const bool read = readRawImage(raw, image);
  std::error_code error;
  std::filesystem::remove(raw, error);
  if (!read)
    return "diagram drawn but its raw image could not be read";
  image.header.stamp = ros::Time::now();
  image.header.frame_id = "";
  diagram_publisher_.publish(image);
  return "";
}

}  // namespace constrained_particles
