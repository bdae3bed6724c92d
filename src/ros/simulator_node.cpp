#include "constrained_particles/ros/simulator_node.hpp"

#include "constrained_particles/SimState.h"
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/ros/clock_owner.hpp"
#include "constrained_particles/ros/conversions.hpp"
#include "constrained_particles/ros/health.hpp"
#include "constrained_particles/ros/reconfigure_mapping.hpp"
#include "constrained_particles/ros/state_message.hpp"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/names.h>
#include <ros/package.h>
#include <rosgraph_msgs/Clock.h>

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
namespace
{
template <typename Response>
bool refuse(Response& response, const std::string& message)
{
  response.success = false;
  response.message = message;
  ROS_WARN("refused: %s", message.c_str());
  return true;
}

/// Copies a runner reply into a service response (logging a refusal).
template <typename Response>
bool answer(Response& response, const RunnerReply& reply)
{
  if (!reply.success)
    return refuse(response, reply.message);
  response.success = true;
  response.message = reply.message;
  return true;
}

}  // namespace

template <typename Request, typename Response>
void SimulatorNode::serve(const char* name, bool (SimulatorNode::*callback)(Request&, Response&))
{
  services_.push_back(nh_.advertiseService(name, callback, this));
}

SimulatorNode::SimulatorNode(const ros::NodeHandle& private_nh)
  : nh_(private_nh)
  , parameters_(readParameters(nh_))
  , publish_nh_(ros::NodeHandle())
  , publish_spinner_(1, &publish_queue_)
{
  publish_nh_.setCallbackQueue(&publish_queue_);
  // in a namespace, frames carry it, so two simulators never share a frame (REP 105 names)
  if (!nh_.hasParam("frame_prefix") && ros::this_node::getNamespace() != "/")
    parameters_.frame_prefix = ros::this_node::getNamespace().substr(1) + "/particle_";
  // a fixed frame named like a particle frame would be its own parent (TF_SELF_TRANSFORM)
  if (parameters_.fixed_frame.rfind(parameters_.frame_prefix, 0) == 0)
    throw InvalidInput("~fixed_frame",
                       "= '" + parameters_.fixed_frame + "' starts with the frame prefix '" +
                           parameters_.frame_prefix + "': particle frames would clash with it");
  if (parameters_.follow_clock && !ros::Time::isSimTime())
    throw InvalidInput("~follow_clock",
                       "= true with /use_sim_time false: set /use_sim_time true "
                       "so that the node reads the /clock it follows");
  if (parameters_.publish_clock)
    requireClockFree(false);
  // robot_description as robot_state_publisher reads it: in the node's namespace, not private
  ros::NodeHandle().getParam("robot_description", parameters_.robot_description);
  SceneDescription scene =
      loadSceneFile(resolveScene(parameters_.scenario, parameters_.scene_directory, "~scenario"),
                    sceneInputs(parameters_));
  for (const std::string& warning : parameters_.overrides.applyTo(scene))
    ROS_WARN("simulator: %s", warning.c_str());
  runner_ = std::make_unique<SimulationRunner>(parameters_, scene);
  const std::shared_ptr<const Snapshot> first = runner_->snapshot();
  parameters_.step = first->parameters.step;

  sim_time_stamps_ = parameters_.publish_clock || ros::Time::isSimTime();
  if (parameters_.publish_clock)
  {
    // latched: a node with use_sim_time started while we are paused still learns the time
    clock_publisher_ = ros::NodeHandle().advertise<rosgraph_msgs::Clock>("/clock", 10, true);
    requireClockFree(true);
    // on nh_'s spinner (several threads), not the publishing one: the master's answers may be
    // slow, and publishing must not wait for them
    clock_check_until_ = std::chrono::steady_clock::now() + CLOCK_CHECK_PERIOD;
    clock_check_timer_ =
        nh_.createWallTimer(ros::WallDuration(1.0), &SimulatorNode::checkClockCallback, this);
  }
  if (parameters_.follow_clock)
  {
    // each /clock (as remapped, like roscpp's own time) to the runner, which steps up to it
    clock_subscriber_ = ros::NodeHandle().subscribe<rosgraph_msgs::Clock>(
        "/clock", 100,
        [this](const rosgraph_msgs::Clock::ConstPtr& clock)
        { runner_->followClock(static_cast<std::int64_t>(clock->clock.toNSec())); },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }
  tf_publisher_ = std::make_unique<TfPublisher>(publish_nh_, parameters_.fixed_frame,
                                                parameters_.frame_prefix, sim_time_stamps_);
  // latched under sim time: while it stands still nothing new is sent
  state_publisher_ = nh_.advertise<SimState>("state", 10, sim_time_stamps_);
  scene_publisher_ = std::make_unique<ScenePublisher>(nh_, parameters_);
  diagnostics_publisher_ =
      ros::NodeHandle().advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 1);
  serve("reset", &SimulatorNode::resetCallback);
  serve("list_scenes", &SimulatorNode::listScenesCallback);
  serve("set_surface", &SimulatorNode::setSurfaceCallback);
  serve("set_obstacle", &SimulatorNode::setObstacleCallback);
  serve("set_chain", &SimulatorNode::setChainCallback);
  serve("set_state", &SimulatorNode::setStateCallback);
  serve("pause", &SimulatorNode::pauseCallback);
  serve("unpause", &SimulatorNode::unpauseCallback);
  serve("step", &SimulatorNode::stepCallback);
  serve("apply_force", &SimulatorNode::applyForceCallback);
  serve("clear_forces", &SimulatorNode::clearForcesCallback);
  serve("attach", &SimulatorNode::attachCallback);
  serve("detach", &SimulatorNode::detachCallback);
  grab_markers_ = std::make_unique<GrabMarkers>(nh_, *runner_, parameters_.fixed_frame);
  wrench_commands_ = std::make_unique<WrenchCommands>(nh_, *runner_, parameters_.frame_prefix);
  anchor_wrenches_ = std::make_unique<AnchorWrenches>(nh_, parameters_.frame_prefix);
  anchor_wrenches_->update(*first);
  obstacle_wrenches_ = std::make_unique<ObstacleWrenches>(nh_);
  obstacle_wrenches_->update(*first);
  // holders' topics are named like any topic the node reads: relative to its namespace
  // a sample's arrival on the clock its stamp is on: the /clock we publish, or ROS time
  auto clock_ns = [this]() -> std::int64_t
  {
    return parameters_.publish_clock ? clock_sent_ns_.load()
                                     : static_cast<std::int64_t>(ros::Time::now().toNSec());
  };
  frame_anchors_ = std::make_unique<FrameAnchors>(
      ros::NodeHandle(), *runner_, parameters_.fixed_frame, parameters_.frame_prefix, clock_ns);
  frame_anchors_->update(*first);
  compare_methods_ = std::make_unique<CompareMethodsServer>(
      nh_, *runner_,
      ros::package::getPath("constrained_particles") + "/scripts/plot_compare_methods.py");

  reconfigure_server_ = std::make_unique<ReconfigureServer<SimulatorConfig>>(
      nh_, configFrom(first->parameters, *first->scene),
      [this](const SimulatorConfig& shown, const SimulatorConfig& requested,
             SimulatorConfig& in_force)
      { return reconfigureCallback(shown, requested, in_force); });

  publish_timer_ = publish_nh_.createWallTimer(ros::WallDuration(1.0 / parameters_.publish_rate),
                                               [this](const ros::WallTimerEvent&) { publish(); });
  diagnostics_timer_ = publish_nh_.createWallTimer(ros::WallDuration(1.0),
                                                   &SimulatorNode::diagnosticsCallback, this);
  if (parameters_.status_period > 0.0)
    status_timer_ = publish_nh_.createWallTimer(ros::WallDuration(parameters_.status_period),
                                                &SimulatorNode::statusCallback, this);
  // ~wrench_timeout on ROS time: wall, or /clock under /use_sim_time (a paused clock pauses it)
  runner_->setCommandClock([] { return ros::Time::now().toSec(); });
  runner_->start();
  publish_spinner_.start();
  ROS_INFO("simulator: scene '%s', %d particles, %s + %s, dt = %g s, solve %s; frames %s<i> in %s",
           first->scene->name.c_str(), first->model->numParticles(),
           parameters_.step.integrator.c_str(), stabilizationName(parameters_.step.stabilization),
           parameters_.step.dt, solveAlgorithmName(*first->model).c_str(),
           parameters_.frame_prefix.c_str(), parameters_.fixed_frame.c_str());
  ROS_INFO("simulator: stages %s: %s", forwardPathName(first->forward_path.path),
           first->forward_path.reason.c_str());
}

void SimulatorNode::checkClockCallback(const ros::WallTimerEvent&)
{
  if (std::chrono::steady_clock::now() > clock_check_until_)
  {
    clock_check_timer_.stop();
    return;
  }
  try
  {
    requireClockFree(true);
  }
  catch (const InvalidInput& e)
  {
    clock_check_timer_.stop();
    // logged here: once ROS has shut down, rosconsole prints nothing
    ROS_FATAL("simulator_node: bad parameter: %s", e.what());
    std::lock_guard<std::mutex> lock(refusal_mutex_);
    refusal_ = e.what();
    ros::requestShutdown();
  }
}

std::string SimulatorNode::refusal() const
{
  std::lock_guard<std::mutex> lock(refusal_mutex_);
  return refusal_;
}

SimulatorNode::~SimulatorNode()
{
  shutdown(std::chrono::milliseconds(0));
}

bool SimulatorNode::shutdown(std::chrono::milliseconds timeout)
{
  publish_spinner_.stop();
  clock_subscriber_.shutdown();
  clock_check_timer_.stop();
  publish_timer_.stop();
  diagnostics_timer_.stop();
  status_timer_.stop();
  compare_methods_.reset();  // cancels a running study: it ends within milliseconds
  return runner_->stop(timeout);
}

ros::Time SimulatorNode::stampOf(const Snapshot& snap, const ros::Time& now) const
{
  ros::Time stamp;
  if (parameters_.publish_clock)  // in integer ns, as the holders' samples are placed on it
    return stamp.fromNSec(static_cast<std::uint64_t>(std::max<std::int64_t>(snap.stamp_ns, 0)));
  if (parameters_.follow_clock)  // the clock time the state stands for (0 before the first)
    return snap.stamp_ns > 0 ? stamp.fromNSec(static_cast<std::uint64_t>(snap.stamp_ns)) : stamp;
  // a foreign /clock the steps do not follow: the time it shows; at rest: the time now
  if (ros::Time::isSimTime() || snap.stamp_ns < 0)
    return now;
  // wall time: the time the state stands for, never after now
  stamp.fromNSec(static_cast<std::uint64_t>(snap.stamp_ns));
  return std::min(stamp, now);
}

const char* SimulatorNode::waitMessage() const
{
  return parameters_.follow_clock ? FOLLOW_WAIT_MESSAGE : CLOCK_WAIT_MESSAGE;
}

std::optional<ros::Time> SimulatorNode::stampFor(const Snapshot& snap, const ros::Time& now)
{
  const ros::Time stamp = stampOf(snap, now);
  if (!parameters_.publish_clock && stamp.isZero())
  {
    // /use_sim_time and no /clock: every stamp would be 0, repeated (TF_REPEATED_DATA). On wall
    // time a 0 is a state the runner has not paced yet (its first batch): sent at the next tick
    if ((ros::Time::isSimTime() || parameters_.follow_clock) && !waiting_for_clock_.exchange(true))
      ROS_WARN("simulator: %s", waitMessage());
    return std::nullopt;
  }
  if (waiting_for_clock_.exchange(false))
    ROS_INFO("simulator: %s has started (t = %.3f s): publishing",
             ros::names::resolve("/clock").c_str(), stamp.toSec());
  if (parameters_.follow_clock)
  {
    // never ahead of the clock: after it went back, the old epoch's states are
    if (static_cast<std::int64_t>(stamp.toNSec()) > runner_->newestClock())
      return std::nullopt;
    if (last_stamp_ && snap.epoch != last_epoch_)
      ROS_INFO("simulator: /clock went back from %.3f s to %.3f s: stamps follow it from here",
               last_stamp_->toSec(), stamp.toSec());
    else if (last_stamp_ && stamp <= *last_stamp_)
      return std::nullopt;
    last_epoch_ = snap.epoch;
    return stamp;
  }
  if (last_stamp_ && stamp < *last_stamp_)
    ROS_WARN(
        "simulator: time went back from %.3f s to %.3f s (a clock restarted?): stamps "
        "follow it from here",
        last_stamp_->toSec(), stamp.toSec());
  else if (last_stamp_ && stamp == *last_stamp_)
    return std::nullopt;
  return stamp;
}

void SimulatorNode::publish()
{
  std::lock_guard<std::mutex> lock(publish_mutex_);
  // now before the snapshot: a message stamped after a request returned shows its effect
  const ros::Time now = ros::Time::now();
  // the statistics of every step up to this snapshot since the last ~state message
  StepStatistics statistics;
  const std::shared_ptr<const Snapshot> snap =
      runner_->snapshot(SimulationRunner::Reader::State, statistics);
  // interactive markers first: shown, hidden or let go even while sim time stands still
  grab_markers_->update(*snap);
  frame_anchors_->update(*snap);  // an attachment made while the clock stands is followed too
  // one rule for every clock source: only a stamp past the last one sent
  const std::optional<ros::Time> stamp = stampFor(*snap, now);
  if (!stamp)
    return;
  // nothing non-finite leaves the node
  if (!isFinite(snap->state) || !snap->diagnostics.finite() ||
      !snap->constraint_forces.allFinite() || !snap->multipliers.allFinite() ||
      !std::isfinite(snap->ledger.residual() + snap->ledger.scale + snap->ledger.t0))
  {
    ROS_ERROR_THROTTLE(5.0, "simulator: non-finite values at t = %.6f s; not published",
                       snap->state.time);
    return;
  }
  std_msgs::Header header;
  header.stamp = *stamp;
  header.frame_id = parameters_.fixed_frame;
  last_stamp_ = header.stamp;
  if (parameters_.publish_clock)
  {
    // the node's clock runs the latency ahead of the states it stamps: holders following it
    // broadcast their poses before the steps reach them
    rosgraph_msgs::Clock clock;
    clock.clock = std::max(last_clock_, header.stamp + ros::Duration(snap->latency));
    last_clock_ = clock.clock;
    // before it goes out: a holder's sample stamped with it never arrives before it
    clock_sent_ns_ = static_cast<std::int64_t>(clock.clock.toNSec());
    clock_publisher_.publish(clock);
  }
  const int n = static_cast<int>(snap->state.positions.cols());

  if (snap->constraint_forces.cols() != n)
  {
    ROS_ERROR_THROTTLE(5.0, "simulator: snapshot with %d positions and %d forces; not published", n,
                       static_cast<int>(snap->constraint_forces.cols()));
    return;
  }
  scene_publisher_->publishSceneOnce(*snap, header.stamp);
  tf_publisher_->publish(*snap, header.stamp);
  anchor_wrenches_->publish(*snap, header);
  obstacle_wrenches_->publish(*snap, header);
  if (state_publisher_.getNumSubscribers() > 0 || sim_time_stamps_)
  {
    SimState msg;
    msg.header = header;
    fillState(*snap, statistics, msg);
    state_publisher_.publish(msg);
  }
  scene_publisher_->publish(*snap, header);
}

void SimulatorNode::pushReconfigure()
{
  const std::shared_ptr<const Snapshot> snap = runner_->snapshot();
  reconfigure_server_->update(configFrom(snap->parameters, *snap->scene));
}

void SimulatorNode::publishNewScene()
{
  // before the caller is answered: a subscriber joining after the reply gets this scene's
  std::lock_guard<std::mutex> lock(publish_mutex_);
  const std::shared_ptr<const Snapshot> snap = runner_->snapshot();
  const ros::Time stamp = stampOf(*snap, ros::Time::now());
  if (parameters_.publish_clock || !stamp.isZero())  // else publish() sends it once time moves
    scene_publisher_->publishSceneOnce(*snap, stamp);
}

bool SimulatorNode::resetCallback(Reset::Request& request, Reset::Response& response)
{
  const RunnerReply reply = runner_->reset(request.scenario);
  answer(response, reply);
  if (reply.success)
  {
    publishNewScene();
    pushReconfigure();
  }
  return true;
}

bool SimulatorNode::listScenesCallback(ListScenes::Request&, ListScenes::Response& response)
{
  response.directory = parameters_.scene_directory;
  response.names = listScenes(parameters_.scene_directory);
  return true;
}

bool SimulatorNode::setSurfaceCallback(SetSurface::Request& request, SetSurface::Response& response)
{
  const RunnerReply reply = runner_->setSurface(request.type, request.coefficients,
                                                request.expression, request.keep_state);
  answer(response, reply);
  response.max_displacement = reply.max_displacement;
  if (response.success)
    publishNewScene();
  return true;
}

bool SimulatorNode::setObstacleCallback(SetObstacle::Request& request,
                                        SetObstacle::Response& response)
{
  if (request.operation > SetObstacle::Request::REMOVE)
    return refuse(response, "operation = " + std::to_string(request.operation) +
                                ", must be 0 (ADD), 1 (REPLACE) or 2 (REMOVE)");
  const RunnerReply reply = runner_->setObstacle(
      static_cast<ObstacleChange>(request.operation), request.name, request.shape,
      [prefix = parameters_.frame_prefix](const std::string& frame, const std::string& topic)
      { return holderRefusal(frame, topic, prefix); });
  answer(response, reply);
  response.max_displacement = reply.max_displacement;
  response.max_velocity_change = reply.max_velocity_change;
  if (response.success)
    publishNewScene();
  return true;
}

bool SimulatorNode::setChainCallback(SetChain::Request& request, SetChain::Response& response)
{
  ChainChange chain;
  chain.num_particles = request.num_particles;
  chain.link_length = request.link_length;
  chain.particle_mass = request.particle_mass;
  switch (request.pin_first)
  {
    case SetChain::Request::PIN_FIRST_KEEP:
      break;
    case SetChain::Request::PIN_FIRST_PIN:
      chain.pin_first = true;
      break;
    case SetChain::Request::PIN_FIRST_UNPIN:
      chain.pin_first = false;
      break;
    default:
      return refuse(response, "pin_first = " + std::to_string(request.pin_first) +
                                  ", must be 0 (keep), 1 (pin) or 2 (unpin)");
  }
  answer(response, runner_->setChain(chain));
  if (response.success)
    publishNewScene();
  return true;
}

bool SimulatorNode::setStateCallback(SetState::Request& request, SetState::Response& response)
{
  const RunnerReply reply =
      runner_->setState(fromMsgs(request.positions),
                        request.velocities.empty() ? Points(3, 0) : fromMsgs(request.velocities));
  response.max_displacement = reply.max_displacement;
  return answer(response, reply);
}

bool SimulatorNode::pauseCallback(std_srvs::Empty::Request&, std_srvs::Empty::Response&)
{
  runner_->pause();
  return true;
}

bool SimulatorNode::unpauseCallback(std_srvs::Empty::Request&, std_srvs::Empty::Response&)
{
  runner_->unpause();
  return true;
}

bool SimulatorNode::stepCallback(Step::Request& request, Step::Response& response)
{
  const RunnerReply reply = runner_->step(request.steps);
  response.sim_time = reply.sim_time;
  response.steps_taken = static_cast<std::uint32_t>(reply.steps_taken);
  if (reply.success || reply.steps_taken == 0)
    return answer(response, reply);
  // stopped part-way (a pause, reset, fault or shutdown): an outcome, not a refusal
  ROS_INFO("~step: %s", reply.message.c_str());
  response.success = false;
  response.message = reply.message;
  return true;
}

bool SimulatorNode::applyForceCallback(ApplyForce::Request& request, ApplyForce::Response& response)
{
  return answer(
      response,
      runner_->applyForce(request.particle, Vec3(request.force.x, request.force.y, request.force.z),
                          request.duration));
}

bool SimulatorNode::attachCallback(Attach::Request& request, Attach::Response& response)
{
  const Vec3 offset(request.offset.x, request.offset.y, request.offset.z);
  // a frame tf has not known within a second is refused naming it (a node with no holder yet
  // listens from now); the runner checks the rest, and one it refuses anyway is not waited for
  const std::shared_ptr<const Snapshot> snap = runner_->snapshot();
  const bool named =
      request.particle < snap->state.positions.cols() && !request.frame.empty() &&
      request.frame.front() != '/' && request.frame.rfind(parameters_.frame_prefix, 0) != 0 &&
      limits::COORDINATE.contains(offset.x()) && limits::COORDINATE.contains(offset.y()) &&
      limits::COORDINATE.contains(offset.z());
  if (named && !frame_anchors_->waitForFrame(request.frame, 1.0))
    return refuse(response,
                  "frame = '" + request.frame +
                      "' is not in tf (no pose of it arrived within 1 s, resolvable into '" +
                      parameters_.fixed_frame + "'); nothing changed");
  const RunnerReply reply =
      runner_->attach(request.particle, request.frame, offset, request.keep_offset,
                      frame_anchors_->poseLookup(request.frame));
  response.moved = reply.max_displacement;
  if (reply.stamp_ns > 0)
    response.stamp.fromNSec(static_cast<std::uint64_t>(reply.stamp_ns));
  return answer(response, reply);
}

bool SimulatorNode::detachCallback(Detach::Request& request, Detach::Response& response)
{
  return answer(response, runner_->detach(request.particle));
}

bool SimulatorNode::clearForcesCallback(ClearForces::Request&, ClearForces::Response& response)
{
  return answer(response, runner_->clearForces());
}

bool SimulatorNode::reconfigureCallback(const SimulatorConfig& shown,
                                        const SimulatorConfig& requested, SimulatorConfig& in_force)
{
  // by value: the runner may still hold the edit if this call gives up at shutdown
  const RunnerReply reply = runner_->reconfigure(
      [shown, requested](NodeParameters& candidate, const SceneDescription& scene)
      { applyChangedFields(shown, requested, scene, candidate); });
  if (!reply.success)
  {
    // named as dynparam names it: "~gravity.z" is gravity_z there, "~dt" is dt
    std::string field = reply.field;
    if (!field.empty() && field[0] == '~')
      field.erase(0, 1);
    std::replace(field.begin(), field.end(), '.', '_');
    const std::string reason =
        reply.message.substr(std::min(reply.field.size(), reply.message.size()));
    ROS_WARN("dynamic_reconfigure refused: %s%s; keeping the current settings", field.c_str(),
             reason.c_str());
    return false;
  }
  const std::shared_ptr<const Snapshot> snap = runner_->snapshot();
  in_force = configFrom(snap->parameters, *snap->scene);
  publish_timer_.setPeriod(ros::WallDuration(1.0 / snap->parameters.publish_rate));
  return true;
}

void SimulatorNode::diagnosticsCallback(const ros::WallTimerEvent&)
{
  StepStatistics statistics;
  const std::shared_ptr<const Snapshot> snap =
      runner_->snapshot(SimulationRunner::Reader::Diagnostics, statistics);
  diagnostic_msgs::DiagnosticStatus status;
  status.name = ros::this_node::getName() + ": physics";
  status.hardware_id = "constrained_particles";
  auto add = [&status](const std::string& key, const std::string& value)
  {
    diagnostic_msgs::KeyValue kv;
    kv.key = key;
    kv.value = value;
    status.values.push_back(kv);
  };
  // the health from one list of conditions; the adapters say what they saw
  HealthInputs inputs{ *snap, statistics };
  inputs.waiting_for_clock = waiting_for_clock_;
  inputs.wait_message = waitMessage();
  inputs.follow_clock = parameters_.follow_clock;
  inputs.wrench_drops = wrench_commands_->newDrops(*snap);  // since the last second
  inputs.wrench_drop_reason = wrench_commands_->lastDropReason();
  inputs.holders_warn = frame_anchors_->report(*snap, add, inputs.holder_warning);
  const Health health = assess(inputs);
  status.level = health.level;
  status.message = health.message;
  if (snap->faulted && snap->fault_reason != logged_fault_)
    ROS_ERROR("simulator: %s", snap->fault_reason.c_str());
  logged_fault_ = snap->faulted ? snap->fault_reason : "";
  const bool fallback = !snap->energy_fallback.empty();
  if (fallback && !logged_fallback_)
    ROS_WARN("simulator: %s", snap->energy_fallback.c_str());
  logged_fallback_ = fallback;
  // the figures: the snapshot's tables, the settings in force, the steps' statistics
  const NodeParameters& p = snap->parameters;
  add("solve", solveAlgorithmName(*snap->model));
  addSnapshotKeys(*snap, add);
  add("fault limit: max_constraint_error [m]", formatValue(p.max_constraint_error));
  add("real_time_factor wanted", formatValue(p.real_time_factor));
  add("integrator", p.step.integrator);
  add("stabilization", stabilizationName(p.step.stabilization));
  add("max_substeps", std::to_string(p.step.max_substeps));
  add("energy_budget", formatValue(p.step.energy_budget));
  addStatistics(statistics, add);
  wrench_commands_->report(*snap, add);
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = ros::Time::now();
  array.status.push_back(status);
  diagnostics_publisher_.publish(array);
}

void SimulatorNode::statusCallback(const ros::WallTimerEvent&)
{
  const std::shared_ptr<const Snapshot> snap = runner_->snapshot();
  // the fault's reason is logged once in full (diagnosticsCallback): here only what to do
  const std::string status = statusText(*snap);
  const std::string tag = snap->faulted    ? "  [FAULT: call ~reset]"
                          : status.empty() ? ""
                                           : "  [" + status + "]";
  ROS_INFO("t = %8.3f s  energy = %.6f J  max error = %.2e m  step = %.1f us%s", snap->state.time,
           snap->diagnostics.totalEnergy(), snap->diagnostics.max_position_error,
           1e6 * snap->step_time, tag.c_str());
}

}  // namespace constrained_particles
