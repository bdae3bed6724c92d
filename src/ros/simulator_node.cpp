#include "constrained_particles/ros/simulator_node.hpp"

#include "constrained_particles/SimState.h"
#include "constrained_particles/core/integrators.hpp"
#include "constrained_particles/ros/conversions.hpp"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <rosgraph_msgs/Clock.h>
#include <geometry_msgs/TransformStamped.h>

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
namespace
{
// longest stretch of wall time one batch of steps may cover; more means we are behind
constexpr double MAX_BATCH_WALL = 0.02;  // [s]
constexpr auto MAX_WAIT = std::chrono::milliseconds(100);

double seconds(std::chrono::steady_clock::duration d)
{
  return std::chrono::duration<double>(d).count();
}

SimulatorConfig configFrom(const NodeParameters& p, const SceneDescription& scene)
{
  SimulatorConfig c;
  c.dt = p.step.dt;
  c.real_time_factor = p.real_time_factor;
  c.publish_rate = p.publish_rate;
  c.integrator = p.step.integrator;
  c.stabilization = stabilizationName(p.step.stabilization);
  c.baumgarte_frequency = p.step.baumgarte_frequency;
  c.baumgarte_damping_ratio = p.step.baumgarte_damping_ratio;
  c.adaptive_tolerance = p.step.adaptive_tolerance;
  const Vec3 gravity = sceneGravity(scene);
  c.gravity_x = gravity.x();
  c.gravity_y = gravity.y();
  c.gravity_z = gravity.z();
  c.damping = sceneDamping(scene);
  return c;
}

template <typename Response>
bool refuse(Response& response, const std::string& message)
{
  response.success = false;
  response.message = message;
  ROS_WARN("refused: %s", message.c_str());
  return true;
}

}  // namespace

SimulatorNode::SimulatorNode(const ros::NodeHandle& private_nh)
  : nh_(private_nh), parameters_(readParameters(nh_))
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    SceneDescription scene =
        loadSceneFile(resolveScene(parameters_.scenario, parameters_.scene_directory, "~scenario"));
    for (const std::string& warning : parameters_.overrides.applyTo(scene))
      ROS_WARN("simulator: %s", warning.c_str());
    if (scene.numParticles() > parameters_.max_particles)
      throw InvalidInput(
          "~scenario",
          "= '" + parameters_.scenario + "' has " + std::to_string(scene.numParticles()) +
              " particles, over ~max_particles = " + std::to_string(parameters_.max_particles));
    // the scene's solver settings, unless set as parameters
    chosen_step_.values = parameters_.step;
    chosen_step_.given = parameters_.step_given;
    const StepSettings settings = settingsFor(scene);
    const BuiltScene built = buildScene(scene);
    simulator_ = std::make_unique<Simulator>(built.scene, built.initial_state, settings,
                                             scene.solver.solve_method);
    parameters_.step = settings;
    scene_ = scene;
    published_model_ = std::make_shared<const Model>(simulator_->model());
  }

  mesh_cache_ = SurfaceMeshCache(parameters_.mesh_cells);
  if (parameters_.publish_clock)
    clock_publisher_ = ros::NodeHandle().advertise<rosgraph_msgs::Clock>("/clock", 10);
  state_publisher_ = nh_.advertise<SimState>("state", 10);
  force_marker_publisher_ = nh_.advertise<visualization_msgs::MarkerArray>("constraint_forces", 1);
  scene_marker_publisher_ = nh_.advertise<visualization_msgs::MarkerArray>("scene", 1, true);
  diagnostics_publisher_ =
      ros::NodeHandle().advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 1);

  services_.push_back(nh_.advertiseService("reset", &SimulatorNode::resetCallback, this));
  services_.push_back(
      nh_.advertiseService("list_scenes", &SimulatorNode::listScenesCallback, this));
  services_.push_back(
      nh_.advertiseService("set_surface", &SimulatorNode::setSurfaceCallback, this));
  services_.push_back(nh_.advertiseService("set_chain", &SimulatorNode::setChainCallback, this));
  services_.push_back(nh_.advertiseService("set_state", &SimulatorNode::setStateCallback, this));
  services_.push_back(nh_.advertiseService("pause", &SimulatorNode::pauseCallback, this));
  services_.push_back(nh_.advertiseService("unpause", &SimulatorNode::unpauseCallback, this));
  services_.push_back(nh_.advertiseService("step", &SimulatorNode::stepCallback, this));

  reconfigure_server_ = std::make_unique<ReconfigureServer<SimulatorConfig>>(
      nh_, configFrom(parameters_, scene_),
      [this](const SimulatorConfig& config) { return reconfigureCallback(config); });

  publish_timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / parameters_.publish_rate),
                                       [this](const ros::WallTimerEvent&) { publish(); });
  diagnostics_timer_ =
      nh_.createWallTimer(ros::WallDuration(1.0), &SimulatorNode::diagnosticsCallback, this);
  if (parameters_.status_period > 0.0)
    status_timer_ = nh_.createWallTimer(ros::WallDuration(parameters_.status_period),
                                        &SimulatorNode::statusCallback, this);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    reanchorLocked();
    rate_wall_ = Clock::now();
  }
  physics_thread_ = std::thread(&SimulatorNode::physicsLoop, this);
  ROS_INFO("simulator: scene '%s', %d particles, %s + %s, dt = %g s, solve %s", scene_.name.c_str(),
           simulator_->model().numParticles(), parameters_.step.integrator.c_str(),
           stabilizationName(parameters_.step.stabilization), parameters_.step.dt,
           solveMethodName(simulator_->model().solveMethod()));
}

SimulatorNode::~SimulatorNode()
{
  running_ = false;
  wake_physics_.notify_all();
  if (physics_thread_.joinable())
    physics_thread_.join();
}

void SimulatorNode::reanchorLocked()
{
  anchor_wall_ = Clock::now();
  anchor_sim_time_ = simulator_->state().time;
  wake_physics_.notify_all();
}

void SimulatorNode::stepLocked(int count)
{
  last_good_state_ = simulator_->state();
  const auto start = Clock::now();
  simulator_->step(count);
  step_time_ = seconds(Clock::now() - start) / count;
  const State& state = simulator_->state();
  if (!isFinite(state))
  {
    faultLocked("the state became non-finite between t = " + formatValue(last_good_state_.time) +
                " s and t = " + formatValue(state.time) + " s");
    return;
  }
  const double error = simulator_->diagnostics().max_position_error;
  if (!(error <= parameters_.max_constraint_error))
    faultLocked("the constraint error reached " + formatValue(error) +
                " m at t = " + formatValue(state.time) + " s, over ~max_constraint_error = " +
                formatValue(parameters_.max_constraint_error) + " m");
}

void SimulatorNode::faultLocked(const std::string& reason)
{
  faulted_ = true;
  fault_reason_ = reason + "; stepping stopped at the last good state (t = " +
                  formatValue(last_good_state_.time) + " s); call ~reset";
  simulator_->restoreState(last_good_state_);
  ROS_ERROR("simulator: %s", fault_reason_.c_str());
}

void SimulatorNode::physicsLoop()
{
  std::unique_lock<std::mutex> lock(mutex_);
  while (running_)
  {
    if (paused_ || faulted_)
    {
      wake_physics_.wait_for(lock, MAX_WAIT);
      continue;
    }
    const double dt = simulator_->stepSettings().dt;
    const double rtf = parameters_.real_time_factor;
    const double target = anchor_sim_time_ + rtf * seconds(Clock::now() - anchor_wall_);
    const long due = static_cast<long>(std::floor((target - simulator_->state().time) / dt + 1e-9));
    if (due > 0)
    {
      const long max_batch = std::max(1L, static_cast<long>(std::ceil(MAX_BATCH_WALL * rtf / dt)));
      stepLocked(static_cast<int>(std::min(due, max_batch)));
      // behind wall time: slow sim time down instead of building a backlog, and say so
      if (due > max_batch)
      {
        reanchorLocked();
        ++behind_events_;
      }
    }
    const double until_next = (simulator_->state().time + dt - anchor_sim_time_) / rtf;
    const auto wake = anchor_wall_ + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(until_next));
    wake_physics_.wait_until(lock, std::min(wake, Clock::now() + MAX_WAIT));
  }
}

void SimulatorNode::publish()
{
  const bool want_state = state_publisher_.getNumSubscribers() > 0;
  const bool want_forces = force_marker_publisher_.getNumSubscribers() > 0;
  const bool want_scene = scene_marker_publisher_.getNumSubscribers() > 0;

  Snapshot snap;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    snap.scenario = scene_.name;
    snap.status = faulted_  ? SimState::STATUS_FAULT
                  : paused_ ? SimState::STATUS_PAUSED
                            : SimState::STATUS_RUNNING;
    snap.status_message = faulted_ ? fault_reason_ : paused_ ? "paused" : "";
    snap.state = simulator_->state();
    if (want_state || want_forces)
      simulator_->constraintForces(snap.constraint_forces, snap.multipliers);
    if (want_state)
      snap.diagnostics = simulator_->diagnostics();
    snap.step_time = step_time_;
    snap.real_time_factor = achieved_rtf_;
    snap.behind = behind_ && !paused_ && !faulted_;
    if (snap.behind)
      snap.status_message = "behind: achieved real-time factor " + formatValue(achieved_rtf_) +
                            " of " + formatValue(parameters_.real_time_factor) +
                            "; sim time is slowed, no steps are dropped";
    if (want_scene)
    {
      snap.model = published_model_;
      snap.scene_changed = scene_changed_;
      scene_changed_ = false;
    }
  }
  // nothing non-finite leaves the node
  if (!isFinite(snap.state) || (want_state && !snap.diagnostics.finite()) ||
      ((want_state || want_forces) &&
       (!snap.constraint_forces.allFinite() || !snap.multipliers.allFinite())))
  {
    ROS_ERROR_THROTTLE(5.0, "simulator: non-finite values at t = %.6f s; not published",
                       snap.state.time);
    return;
  }

  std_msgs::Header header;
  // sim time as ROS time: nodes with use_sim_time follow /clock
  header.stamp =
      parameters_.publish_clock ? ros::Time(std::max(snap.state.time, 0.0)) : ros::Time::now();
  if (parameters_.publish_clock)
  {
    rosgraph_msgs::Clock clock;
    clock.clock = header.stamp;
    clock_publisher_.publish(clock);
  }
  header.frame_id = parameters_.fixed_frame;
  const int n = static_cast<int>(snap.state.positions.cols());

  std::vector<geometry_msgs::TransformStamped> transforms(n);
  for (int i = 0; i < n; ++i)
  {
    geometry_msgs::TransformStamped& t = transforms[i];
    t.header = header;
    t.child_frame_id = parameters_.frame_prefix + std::to_string(i);
    t.transform.translation.x = snap.state.positions(0, i);
    t.transform.translation.y = snap.state.positions(1, i);
    t.transform.translation.z = snap.state.positions(2, i);
    t.transform.rotation.w = 1.0;
  }
  tf_broadcaster_.sendTransform(transforms);

  if (want_state)
  {
    SimState msg;
    msg.header = header;
    msg.scenario = snap.scenario;
    msg.sim_time = snap.state.time;
    msg.steps = snap.state.steps;
    msg.positions = toPointMsgs(snap.state.positions);
    msg.velocities = toVectorMsgs(snap.state.velocities);
    msg.constraint_forces = toVectorMsgs(snap.constraint_forces);
    msg.multipliers.assign(snap.multipliers.data(),
                           snap.multipliers.data() + snap.multipliers.size());
    msg.max_position_error = snap.diagnostics.max_position_error;
    msg.max_velocity_error = snap.diagnostics.max_velocity_error;
    msg.kinetic_energy = snap.diagnostics.kinetic_energy;
    msg.potential_energy = snap.diagnostics.potential_energy;
    msg.step_time = snap.step_time;
    msg.real_time_factor = snap.real_time_factor;
    msg.behind = snap.behind;
    msg.status = snap.status;
    msg.status_message = snap.status_message;
    state_publisher_.publish(msg);
  }
  if (want_forces)
  {
    force_marker_publisher_.publish(
        constraintForceMarkers(header, snap.state.positions, snap.constraint_forces,
                               parameters_.force_scale, published_arrows_));
    published_arrows_ = n;
  }
  if (want_scene)
    scene_marker_publisher_.publish(
        sceneMarkers(header, *snap.model, snap.state.positions, mesh_cache_, snap.scene_changed));
}

void SimulatorNode::rebuildLocked(const SceneDescription& description, const StepSettings& settings)
{
  if (description.numParticles() > parameters_.max_particles)
    throw InvalidInput(
        "num_particles",
        "= " + std::to_string(description.numParticles()) + " in scene '" + description.name +
            "', must be at most ~max_particles = " + std::to_string(parameters_.max_particles));
  const BuiltScene built = buildScene(description);
  // settings first: if the scene is refused, put them back
  const StepSettings saved = simulator_->stepSettings();
  simulator_->setStepSettings(settings);
  try
  {
    simulator_->setScene(built.scene, built.initial_state, description.solver.solve_method);
  }
  catch (const InvalidInput&)
  {
    simulator_->setStepSettings(saved);
    throw;
  }
  parameters_.step = settings;
  scene_ = description;
  faulted_ = false;
  fault_reason_.clear();
  published_model_ = std::make_shared<const Model>(simulator_->model());
  scene_changed_ = true;
  reanchorLocked();
}

StepSettings SimulatorNode::settingsFor(const SceneDescription& scene) const
{
  // defaults, then the scene's own, then the user's: nothing carries over from the last scene
  return chosen_step_.applyTo(scene.solver.applyTo(StepSettings{}));
}

void SimulatorNode::loadSceneLocked(const std::string& name_or_path, const std::string& field)
{
  const SceneDescription description =
      loadSceneFile(resolveScene(name_or_path, parameters_.scene_directory, field));
  rebuildLocked(description, settingsFor(description));
}

void SimulatorNode::pushReconfigure()
{
  SimulatorConfig config;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    config = configFrom(parameters_, scene_);
  }
  reconfigure_server_->update(config);
}

bool SimulatorNode::resetCallback(Reset::Request& request, Reset::Response& response)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    try
    {
      if (request.scenario.empty())
        rebuildLocked(scene_, parameters_.step);
      else
        loadSceneLocked(request.scenario, "scenario");
    }
    catch (const InvalidInput& e)
    {
      return refuse(response, e.what());
    }
    response.success = true;
    response.message = "reset to scene '" + scene_.name + "' (" +
                       std::to_string(simulator_->model().numParticles()) + " particles, solve " +
                       solveMethodName(simulator_->model().solveMethod()) + "; " +
                       parameters_.step.integrator + " + " +
                       stabilizationName(parameters_.step.stabilization) +
                       ", dt = " + formatValue(parameters_.step.dt) + " s)";
  }
  pushReconfigure();
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
  std::lock_guard<std::mutex> lock(mutex_);
  try
  {
    const SurfaceType type = parseSurfaceType(request.type, "type");
    Surface surface;
    if (type == SurfaceType::Expression && !request.coefficients.empty())
      throw InvalidInput("coefficients", "has " + std::to_string(request.coefficients.size()) +
                                             " values, must be empty for type 'expression'");
    if (type == SurfaceType::Expression)
      surface = makeExpressionSurface(request.expression, "expression");
    else if (!request.expression.empty())
      throw InvalidInput("expression",
                         "is only for type 'expression' (type is '" + request.type + "')");
    else
      surface = makeSurface(type, request.coefficients, "coefficients");
    SceneDescription changed = scene_;
    setFirstSurface(changed, surface);
    rebuildLocked(changed, parameters_.step);
  }
  catch (const InvalidInput& e)
  {
    return refuse(response, e.what());
  }
  response.success = true;
  response.message = "surface set to '" + request.type + "'; scene '" + scene_.name + "' reset";
  return true;
}

bool SimulatorNode::setChainCallback(SetChain::Request& request, SetChain::Response& response)
{
  std::lock_guard<std::mutex> lock(mutex_);
  ChainChange chain;
  // a uint32 above INT_MAX must not wrap to a valid count
  chain.num_particles =
      static_cast<int>(std::min<double>(request.num_particles, limits::PARTICLES.high + 1));
  chain.link_length = request.link_length;
  chain.particle_mass = request.particle_mass;
  chain.pin_first = request.pin_first;
  try
  {
    validateChainChange(chain, parameters_.max_particles, "");
    SceneDescription changed = scene_;
    setChains(changed, chain);
    rebuildLocked(changed, parameters_.step);
  }
  catch (const InvalidInput& e)
  {
    return refuse(response, e.what());
  }
  response.success = true;
  response.message = "chain set to " + std::to_string(chain.num_particles) +
                     " particles, l = " + formatValue(chain.link_length) +
                     " m, m = " + formatValue(chain.particle_mass) + " kg; scene '" + scene_.name +
                     "' reset (" + std::to_string(simulator_->model().numParticles()) +
                     " particles)";
  return true;
}

bool SimulatorNode::setStateCallback(SetState::Request& request, SetState::Response& response)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const std::size_t n = static_cast<std::size_t>(simulator_->model().numParticles());
  if (request.positions.size() != n)
    return refuse(response, "positions has " + std::to_string(request.positions.size()) +
                                " entries, must have one per particle (" + std::to_string(n) + ")");
  if (!request.velocities.empty() && request.velocities.size() != n)
    return refuse(response, "velocities has " + std::to_string(request.velocities.size()) +
                                " entries, must be empty (at rest) or one per particle (" +
                                std::to_string(n) + ")");
  // finite is not enough: a teleport to 1e300 m would overflow on the first step
  State state = simulator_->state();
  state.positions = fromMsgs(request.positions);
  state.velocities =
      request.velocities.empty() ? Points(Points::Zero(3, n)) : fromMsgs(request.velocities);
  try
  {
    // finite is not enough: a teleport to 1e300 m would overflow on the first step
    for (std::size_t i = 0; i < n; ++i)
    {
      requireInRange("positions[" + std::to_string(i) + "]", Vec3(state.positions.col(i)),
                     limits::COORDINATE);
      requireInRange("velocities[" + std::to_string(i) + "]", Vec3(state.velocities.col(i)),
                     limits::VELOCITY);
    }
    const ProjectionReport report = simulator_->setState(state);
    response.max_displacement = report.max_displacement;
    response.message =
        "state set; projection moved particles by up to " + formatValue(report.max_displacement) +
        " m and changed velocities by up to " + formatValue(report.max_velocity_change) + " m/s";
  }
  catch (const InvalidInput& e)
  {
    return refuse(response, e.what());
  }
  faulted_ = false;
  fault_reason_.clear();
  reanchorLocked();
  response.success = true;
  return true;
}

bool SimulatorNode::pauseCallback(std_srvs::Empty::Request&, std_srvs::Empty::Response&)
{
  std::lock_guard<std::mutex> lock(mutex_);
  paused_ = true;
  return true;
}

bool SimulatorNode::unpauseCallback(std_srvs::Empty::Request&, std_srvs::Empty::Response&)
{
  std::lock_guard<std::mutex> lock(mutex_);
  paused_ = false;
  reanchorLocked();
  return true;
}

bool SimulatorNode::stepCallback(Step::Request& request, Step::Response& response)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    response.sim_time = simulator_->state().time;
    if (!paused_)
      return refuse(response, "the simulation is running: call ~pause before ~step");
    if (faulted_)
      return refuse(response, "stepping is stopped (" + fault_reason_ + ")");
    if (!limits::STEPS_PER_CALL.contains(request.steps))
      return refuse(response, "steps = " + std::to_string(request.steps) + ", must be in " +
                                  limits::STEPS_PER_CALL.text());
    stepLocked(static_cast<int>(request.steps));
    response.sim_time = simulator_->state().time;
    response.success = !faulted_;
    response.message =
        faulted_ ? fault_reason_ : "stepped " + std::to_string(request.steps) + " steps";
  }
  publish();
  return true;
}

bool SimulatorNode::reconfigureCallback(const SimulatorConfig& config)
{
  std::lock_guard<std::mutex> lock(mutex_);
  NodeParameters candidate = parameters_;
  try
  {
    candidate.step.dt = config.dt;
    candidate.step.integrator = findIntegrator(config.integrator).name;
    candidate.step.stabilization = parseStabilization(config.stabilization);
    candidate.step.baumgarte_frequency = config.baumgarte_frequency;
    candidate.step.baumgarte_damping_ratio = config.baumgarte_damping_ratio;
    candidate.step.adaptive_tolerance = config.adaptive_tolerance;
    candidate.real_time_factor = config.real_time_factor;
    candidate.publish_rate = config.publish_rate;
    candidate.overrides.damping = config.damping;
    candidate.overrides.gravity = Vec3(config.gravity_x, config.gravity_y, config.gravity_z);
    validateNodeParameters(candidate);
    simulator_->setStepSettings(candidate.step);
    // new forces recompile the model (and restart dopri5's step control): only when they change
    if (candidate.overrides.gravity != parameters_.overrides.gravity ||
        candidate.overrides.damping != parameters_.overrides.damping)
    {
      SceneDescription changed = scene_;
      setGravityAndDamping(changed, *candidate.overrides.gravity, config.damping);
      simulator_->setForces(changed.forces);
      scene_.forces = changed.forces;
      published_model_ = std::make_shared<const Model>(simulator_->model());
      scene_changed_ = true;
    }
  }
  catch (const InvalidInput& e)
  {
    // named as dynparam names it: "~gravity.z" is gravity_z there, "~dt" is dt
    std::string field = e.field();
    if (!field.empty() && field[0] == '~')
      field.erase(0, 1);
    std::replace(field.begin(), field.end(), '.', '_');
    const std::string reason = std::string(e.what()).substr(e.field().size());
    ROS_WARN("dynamic_reconfigure refused: %s%s; keeping the current settings", field.c_str(),
             reason.c_str());
    simulator_->setStepSettings(parameters_.step);
    return false;
  }
  if (candidate.publish_rate != parameters_.publish_rate)
    publish_timer_.setPeriod(ros::WallDuration(1.0 / candidate.publish_rate));
  // a step setting changed here is the user's choice from now on, for every scene
  forEachField<StepSettings>(
      [&](const auto& spec)
      {
        if (candidate.step.*(spec.member) != parameters_.step.*(spec.member) &&
            std::find(chosen_step_.given.begin(), chosen_step_.given.end(), spec.name) ==
                chosen_step_.given.end())
          chosen_step_.given.push_back(spec.name);
      });
  chosen_step_.values = candidate.step;
  parameters_ = candidate;
  reanchorLocked();
  return true;
}

void SimulatorNode::updateRateLocked()
{
  const Clock::time_point now = Clock::now();
  const double wall = seconds(now - rate_wall_);
  const double sim = simulator_->state().time;
  if (wall > 0.0)
    achieved_rtf_ =
        (paused_ || faulted_ || sim < rate_sim_time_) ? 0.0 : (sim - rate_sim_time_) / wall;
  behind_ = behind_events_ > 0;
  behind_events_ = 0;
  rate_wall_ = now;
  rate_sim_time_ = sim;
}

void SimulatorNode::diagnosticsCallback(const ros::WallTimerEvent&)
{
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
  {
    std::lock_guard<std::mutex> lock(mutex_);
    updateRateLocked();
    const Diagnostics d = simulator_->diagnostics();
    const bool behind = behind_ && !paused_ && !faulted_;
    status.level = faulted_ ? diagnostic_msgs::DiagnosticStatus::ERROR
                   : behind ? diagnostic_msgs::DiagnosticStatus::WARN
                            : diagnostic_msgs::DiagnosticStatus::OK;
    status.message = faulted_  ? fault_reason_
                     : paused_ ? "paused"
                     : behind  ? "behind: cannot keep up with the real-time factor; sim time slowed"
                               : "running";
    add("scenario", scene_.name);
    add("solve", solveMethodName(simulator_->model().solveMethod()));
    add("particles", std::to_string(simulator_->model().numParticles()));
    add("sim_time [s]", formatValue(simulator_->state().time));
    add("steps", std::to_string(simulator_->state().steps));
    add("max_position_error [m]", formatValue(d.max_position_error));
    add("max_constraint_error [m]", formatValue(parameters_.max_constraint_error));
    add("step_time [s]", formatValue(step_time_));
    add("real_time_factor achieved", formatValue(achieved_rtf_));
    add("real_time_factor wanted", formatValue(parameters_.real_time_factor));
    add("integrator", parameters_.step.integrator);
    add("stabilization", stabilizationName(parameters_.step.stabilization));
  }
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = ros::Time::now();
  array.status.push_back(status);
  diagnostics_publisher_.publish(array);
}

void SimulatorNode::statusCallback(const ros::WallTimerEvent&)
{
  Diagnostics d;
  double time = 0, step_time = 0;
  bool paused = false, faulted = false, behind = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    behind = behind_;
    d = simulator_->diagnostics();
    time = simulator_->state().time;
    step_time = step_time_;
    paused = paused_;
    faulted = faulted_;
  }
  ROS_INFO("t = %8.3f s  energy = %.6f J  max error = %.2e m  step = %.1f us%s", time,
           d.totalEnergy(), d.max_position_error, 1e6 * step_time,
           faulted  ? "  [FAULT: call ~reset]"
           : paused ? "  [paused]"
           : behind ? "  [behind: sim time slowed]"
                    : "");
}

}  // namespace constrained_particles
