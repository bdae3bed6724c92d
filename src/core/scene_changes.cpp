/// @file scene_changes.cpp
/// @brief The Simulator's construction (compile, install) and its scene changes between steps:
/// reset, teleports, a new scene, new step settings, forces, constraints, surfaces and
/// perturbations, each keeping what the change does not touch (simulator.cpp takes the steps).
#include "constrained_particles/core/simulator.hpp"

#include "contact.hpp"
#include "simulator_support.hpp"
#include "stabilization.hpp"
#include "stages.hpp"

#include "constrained_particles/core/constraints.hpp"
#include "constrained_particles/core/diagnostics.hpp"
#include "constrained_particles/core/forces.hpp"
#include "constrained_particles/core/self_collision.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>

namespace constrained_particles
{
namespace
{
// The running scene changed in place (its forces, its constraints): a model of `scene` and its
// data, with `data`'s state and perturbations (they come from outside the scene) carried over.
// The method is the model's, but a self-colliding rope's, whose structure its link pairs change
// as it moves (a tree now, sparse later): the one the scene asked for.
std::pair<std::unique_ptr<Model>, std::unique_ptr<Data>> recompile(const Scene& scene,
                                                                   const Model& model,
                                                                   const Data& data,
                                                                   StagePaths paths,
                                                                   SolveMethod requested)
{
  const SolveMethod method = scene.self_collisions.empty() ? model.solveMethod() : requested;
  auto compiled = std::make_unique<Model>(Model::compile(scene, method, paths));
  auto fresh = std::make_unique<Data>(*compiled);
  fresh->state = data.state;
  fresh->perturbations = data.perturbations;
  return { std::move(compiled), std::move(fresh) };
}

// A change whose contacts the projection finds no way out of (installChangedWorld): setObstacles
// may then move the shapes there in steps
struct TooDeepChange : InvalidInput
{
  using InvalidInput::InvalidInput;
};

// How finely setObstacles may step a shape along its way before a change is refused as too deep:
// down to 1/256 of the way, in at most 64 projections (a long way to a shape's last few
// centimetres takes about two a halving); the node's physics thread waits for them
constexpr int MAX_PATH_HALVINGS = 8;
constexpr int MAX_PATH_PROJECTIONS = 64;

// Where `shape`'s way starts: the shape of that name in `old` if it is the same shape changed (its
// type, on its holder: another holder's pose is in another frame; not a mesh, whose size is its
// file's), else nullptr (added, retyped, unchanged: no way to move it along)
const Shape* wayStart(const Shape& shape, const std::vector<Constraint>& old)
{
  for (const Constraint& c : old)
    if (const Shape* was = obstacleShape(c); was && was->name == shape.name)
      return sameCarrier(*was, shape) && was->type == shape.type && shape.type != ShapeType::Mesh &&
                     !(was->position == shape.position && was->rotation == shape.rotation &&
                       was->radius == shape.radius && was->length == shape.length &&
                       was->size == shape.size)
                 ? was
                 : nullptr;
  return nullptr;
}

// Shape `to` a fraction `s` of its way from `from` (the same shape moved, turned or resized):
// its position and sizes linear in s, its rotation along the slerp between the two
Shape between(const Shape& from, const Shape& to, double s)
{
  if (s >= 1.0)  // exactly as asked (from + (to - from) need not round to it)
    return to;
  Shape shape = to;
  shape.position = from.position + s * (to.position - from.position);
  shape.rotation = Eigen::Quaterniond(from.rotation)
                       .slerp(s, Eigen::Quaterniond(to.rotation))
                       .toRotationMatrix();
  shape.radius = from.radius + s * (to.radius - from.radius);
  shape.length = from.length + s * (to.length - from.length);
  shape.size = from.size + s * (to.size - from.size);
  return shape;
}

// `contacts` with each shape that has a way from `old` (wayStart) a fraction `s` of its way there
std::vector<Constraint> contactsAt(const std::vector<Constraint>& contacts,
                                   const std::vector<Constraint>& old, double s)
{
  std::vector<Constraint> at = contacts;
  for (Constraint& c : at)
    if (Shape* shape = obstacleShape(c))
      if (const Shape* was = wayStart(*shape, old))
        *shape = between(*was, *shape, s);
  return at;
}

}  // namespace

Simulator::Compiled Simulator::compile(const Scene& scene, const State& initial_state,
                                       const StepSettings& settings, SolveMethod method,
                                       StagePaths paths)
{
  validateStepSettings(settings);
  Compiled compiled;
  compiled.model = std::make_unique<Model>(Model::compile(scene, method, paths));
  const Model& model = *compiled.model;
  model.validateState(initial_state, "initial_state");
  compiled.data = std::make_unique<Data>(model);
  restartTracks(model, *compiled.data, initial_state.positions);
  compiled.initial_state = initial_state;
  State& start = compiled.initial_state;
  // a run starts at t = 0 (reset): driven motion is imposed at that time, not the state's
  start.time = 0.0;
  start.steps = 0;
  const ProjectionReport projection =
      projectPositions(model, *compiled.data, start.time, start.positions,
                       settings.projection_tolerance, settings.projection_max_iterations);
  if (!projection.converged)
  {
    // name the constraint left furthest from holding: it is (one of) those that cannot all hold
    // (named by kind and particles: a scene file's indices differ, its chains' links come first)
    const RowData& rows = compiled.data->rows;
    const RowRecord* worst = nullptr;
    double worst_violation = -1.0;
    for (const RowRecord& record : model.rowRecords())
      for (int r = record.first_row; r < record.first_row + record.rows; ++r)
        if (worst_violation == worst_violation &&  // a NaN row is the worst and stays so
            !(rows.violation[r] <= worst_violation))
        {
          worst_violation = rows.violation[r];
          worst = &record;
        }
    std::string where = "(none)";
    if (worst)
    {
      const Constraint& constraint = scene.constraints[worst->constraint];
      where = std::string("a ") + kindOf(constraint) + " on particles";
      std::visit(
          [&](const auto& c)
          {
            using Kind = std::decay_t<decltype(c)>;
            if constexpr (!Kind::ELIMINATED)
              for (int particle : rowParticles(c))
                where += " " + std::to_string(particle);
          },
          constraint);
    }
    throw InvalidInput("initial_state.positions",
                       "cannot be projected onto the constraints: error " +
                           formatValue(projection.max_position_error) + " m after " +
                           std::to_string(projection.iterations) +
                           " Newton iterations, largest at " + where +
                           "; the constraints may not all hold at once (check lengths, angles "
                           "and anchors against each other)");
  }
  projectVelocities(model, *compiled.data, start.time, start.positions, start.velocities, false,
                    false);
  if (!isFinite(start))
    throw InvalidInput("initial_state.positions",
                       "projection onto the constraints produced a non-finite state");
  return compiled;
}

Simulator::Simulator(const Scene& scene, const State& initial_state, const StepSettings& settings,
                     SolveMethod method, StagePaths paths)
  : paths_(paths)
{
  Compiled compiled = compile(scene, initial_state, settings, method, paths_);
  requested_method_ = method;
  settings_ = settings;
  substep_settings_ = settings;
  integrator_ = &findIntegrator(settings.integrator);
  stiff_ = &findIntegrator(STIFF_FALLBACK);
  install(std::move(compiled.model), std::move(compiled.data));
  initial_state_ = compiled.initial_state;
  reset();
}

void Simulator::install(std::unique_ptr<Model> model, std::unique_ptr<Data> data)
{
  data_.reset();  // the old data refers to the old model: it goes first
  model_ = std::move(model);
  ++model_version_;
  data_ = std::move(data);
  readSceneKind();
  diagnostic_rows_.resize(*model_);
  diagnostic_rates_.setZero(model_->numRows());
}

void Simulator::reset()
{
  // the obstacles' paths were in the old run's time too: each rests where it is now, its
  // holder's next pose followed from there
  const double now = data_->state.time;
  for (AnchorTrack& track : data_->carriers)
    track.restAt(now);
  data_->setState(initial_state_);
  separateContacts(*model_, *data_);
  // the holders' paths were in the old run's time: each rests where its particle starts again
  restartTracks(*model_, *data_, initial_state_.positions);
  data_->state.time = 0.0;
  data_->state.steps = 0;
  data_->statistics = StepStatistics{};
  forgetControl(*data_);
  openLedger();
}

ProjectionReport Simulator::setState(const State& state)
{
  model_->validateState(state, "");
  State projected = state;
  projected.time = data_->state.time;
  projected.steps = data_->state.steps;
  // a teleport: the contacts touching before say nothing of where it goes (the next step's start
  // chooses); kept if it is refused
  const std::vector<ContactState> contacts = data_->contacts;
  const std::vector<double> step_normal_forces = data_->control.step_normal_forces;
  separateContacts(*model_, *data_);
  ProjectionReport report;
  try
  {
    report = projectState(*model_, *data_, settings_, projected, "positions",
                          "cannot be projected onto the constraints");
    // below a contact's surface it is refused, as a scene starting there is: the next step would
    // take the jump as an impact as deep as it
    const BelowSurface below =
        deepestBelowSurface(model_->scene().constraints, contextAt(*model_, *data_, projected.time),
                            projected.positions, &model_->inverseMasses());
    if (below.contact)
      throw InvalidInput("positions[" + std::to_string(below.particle) + "]",
                         "would put particle " + std::to_string(below.particle) + " " +
                             formatValue(below.depth) + " m " + contactTargetText(*below.contact) +
                             " (after projecting onto the constraints), which its contact keeps "
                             "it out of; place it on or above the surface, outside the obstacle");
  }
  catch (const InvalidInput&)
  {
    data_->contacts = contacts;
    data_->control.start_contacts = contacts;
    data_->control.step_normal_forces = step_normal_forces;  // the next stick test's, as before
    writeContactRows(*model_, *data_);
    throw;
  }
  report.max_displacement = (projected.positions - state.positions).colwise().norm().maxCoeff();
  data_->setState(projected);
  forgetControl(*data_);
  openLedger();  // a teleport: the energy it brought or took is no step's
  return report;
}

void Simulator::restoreState(const State& state)
{
  model_->validateState(state);
  data_->setState(state);
  separateContacts(*model_, *data_);
  forgetControl(*data_);
  openLedger();
}

void Simulator::setScene(const Scene& scene, const State& initial_state, SolveMethod method)
{
  setScene(scene, initial_state, settings_, method);
}

void Simulator::setScene(const Scene& scene, const State& initial_state,
                         const StepSettings& settings, SolveMethod method)
{
  // compiled with the new settings (the initial state's projection reads them), which are taken
  // only once it succeeds
  Compiled compiled = compile(scene, initial_state, settings, method, paths_);
  setStepSettings(settings);
  requested_method_ = method;
  // the world outside the scene goes on: an obstacle carried in both rests where it is now
  carryCarriers(*model_, *data_, *compiled.model, *compiled.data, true);
  install(std::move(compiled.model), std::move(compiled.data));
  initial_state_ = compiled.initial_state;
  reset();
}

void Simulator::setStepSettings(const StepSettings& settings)
{
  validateStepSettings(settings);
  // other settings end the fallback and take the run from here, judged by what they gain
  // themselves (the fallback took over at the budget's edge); without a fallback the account
  // stands (a method study's segments change dt and stay judged on the whole run); the same
  // settings (a reconfigure of the node's own) change nothing
  if (!(settings == settings_) && data_->control.budget_fallback)
  {
    data_->control.budget_fallback = false;
    data_->control.budget_base_residual = data_->ledger.residual();
    data_->control.budget_base_time = data_->state.time;
  }
  integrator_ = &findIntegrator(settings.integrator);
  settings_ = settings;
  substep_settings_ = settings;
  data_->control.multipliers_current = false;  // another integrator may have left none
  data_->control.end_energies_current = false;
  data_->noteStateChange();  // the kept factorisation may not serve the new settings' stages
}

void Simulator::setForces(const std::vector<Force>& forces)
{
  Scene scene = model_->scene();
  scene.forces = forces;
  auto [model, data] = recompile(scene, *model_, *data_, paths_, requested_method_);
  data->tracks = data_->tracks;  // the holders' paths come from outside the scene too
  data->carriers = data_->carriers;
  const std::vector<double> loads = hold_loads_;  // the same holds: their last loads stand
  install(std::move(model), std::move(data));
  hold_loads_ = loads;
  openLedger();  // new forces: a new potential and new powers
}

void Simulator::restTracks()
{
  if (data_->tracks.empty() && data_->carriers.empty())
    return;
  const double now = data_->state.time;
  for (AnchorTrack& track : data_->tracks)
    track.restart(track.motion(now).position);
  for (AnchorTrack& track : data_->carriers)  // an obstacle rests as it is placed and turned now
    track.restAt(now);
  separateContacts(*model_, *data_);  // a teleport of the held particles: chosen again
  imposeEliminated(*model_, *data_, now, &data_->state.positions, &data_->state.velocities);
  projectVelocities(*model_, *data_, now, data_->state.positions, data_->state.velocities, false,
                    true);
  data_->noteStateChange();
  forgetControl(*data_);
  openLedger();
}

ProjectionReport Simulator::setConstraints(const std::vector<Constraint>& constraints)
{
  Scene scene = model_->scene();
  scene.constraints = constraints;
  auto [model, data] = recompile(scene, *model_, *data_, paths_, requested_method_);
  // tracks by the particle they hold (each particle has at most one holder)
  restartTracks(*model, *data, data_->state.positions);
  for (std::size_t k = 0; k < data->tracks.size(); ++k)
  {
    const int particle = eliminatedParticle(model->scene().constraints[model->tracked()[k]]);
    for (std::size_t old = 0; old < data_->tracks.size(); ++old)
      if (eliminatedParticle(model_->scene().constraints[model_->tracked()[old]]) == particle)
        data->tracks[k] = data_->tracks[old];
  }
  // carried shapes by name and holder: the world outside the scene goes on
  carryCarriers(*model_, *data_, *model, *data, false);
  // project with the new model before anything is replaced: a refusal changes nothing
  State projected = data_->state;
  ProjectionReport report = projectState(*model, *data, settings_, projected, "constraints",
                                         "the state cannot be projected onto them");
  report.max_displacement =
      (projected.positions - data_->state.positions).colwise().norm().maxCoeff();
  data->setState(projected);
  install(std::move(model), std::move(data));
  forgetControl(*data_);
  openLedger();  // a new holder does work, a freed particle no longer
  return report;
}

ProjectionReport Simulator::setSurfaces(const std::vector<Surface>& surfaces)
{
  if (surfaces.size() != model_->scene().surfaces.size())
    throw InvalidInput("surfaces", "has " + std::to_string(surfaces.size()) +
                                       " height fields, the scene " +
                                       std::to_string(model_->scene().surfaces.size()) +
                                       ": a change replaces each, it adds or removes none");
  Scene scene = model_->scene();
  scene.surfaces = surfaces;
  auto [model, data] = recompile(scene, *model_, *data_, paths_, requested_method_);
  data->tracks = data_->tracks;  // the world outside the scene goes on
  data->carriers = data_->carriers;
  return installChangedWorld(std::move(model), std::move(data), "surfaces", data_->state);
}

ProjectionReport Simulator::setObstacles(const std::vector<Constraint>& contacts)
{
  for (std::size_t k = 0; k < contacts.size(); ++k)
    if (!isObstacleContact(contacts[k]))
      throw InvalidInput("contacts[" + std::to_string(k) + "]",
                         "is a " + std::string(kindOf(contacts[k])) +
                             " record: only shape_contact and segment_contact records are "
                             "obstacle contacts");
  // every other record stays, in its order (holders' tracks follow their records' order); the
  // rope's link pairs go and come back at the next step's start (updateLinkPairs)
  Scene scene = model_->scene();
  scene.constraints.erase(std::remove_if(scene.constraints.begin(), scene.constraints.end(),
                                         [](const Constraint& c)
                                         {
                                           return isObstacleContact(c) ||
                                                  (std::holds_alternative<LinkPairContact>(c) &&
                                                   std::get<LinkPairContact>(c).generated);
                                         }),
                          scene.constraints.end());
  const std::size_t first = scene.constraints.size();
  scene.constraints.insert(scene.constraints.end(), contacts.begin(), contacts.end());
  for (std::size_t k = 0; k < contacts.size(); ++k)
    validateConstraint(scene.constraints[first + k], model_->numParticles(),
                       static_cast<int>(scene.surfaces.size()),
                       "contacts[" + std::to_string(k) + "]");
  // the model and data with the obstacle contacts at fraction s of their shapes' way
  auto compiledAt = [&](double s)
  {
    Scene at = scene;
    const std::vector<Constraint> placed = contactsAt(contacts, model_->scene().constraints, s);
    std::copy(placed.begin(), placed.end(), at.constraints.begin() + first);
    auto compiled = recompile(at, *model_, *data_, paths_, requested_method_);
    compiled.second->tracks = data_->tracks;  // the same eliminated records, in the same order
    carryCarriers(*model_, *data_, *compiled.first, *compiled.second, false);  // name and holder
    return compiled;
  };
  try
  {
    auto [model, data] = compiledAt(1.0);
    return installChangedWorld(std::move(model), std::move(data), "contacts", data_->state);
  }
  catch (const TooDeepChange&)
  {
    // no shape with a way there (added, retyped, a mesh, another holder): refused
    if (std::none_of(contacts.begin(), contacts.end(),
                     [&](const Constraint& c)
                     {
                       const Shape* shape = obstacleShape(c);
                       return shape && wayStart(*shape, model_->scene().constraints);
                     }))
      throw;
  }
  // too deep at once: the shapes moved there in steps, each pushing the particles out of its
  // way as a shape moving slowly there would (a step still too deep halved)
  int projections = 0, taken = 0;
  double error = 0.0;
  std::function<State(const State&, double, double, int)> along =
      [&](const State& from, double s0, double s1, int halvings)
  {
    if (halvings > 0)  // the whole way at once has just failed
    {
      auto [model, data] = compiledAt(s1);
      ++projections;
      if (std::optional<State> out = movedOut(*model, *data, from, "contacts", nullptr, &error))
      {
        ++taken;
        return *out;
      }
    }
    if (halvings == MAX_PATH_HALVINGS || projections >= MAX_PATH_PROJECTIONS)
      throw TooDeepChange(
          "contacts", "leave the particles " + formatValue(error) +
                          " m from their constraints even moved there in steps (down to 1/" +
                          std::to_string(1 << MAX_PATH_HALVINGS) + " of the way, " +
                          std::to_string(MAX_PATH_PROJECTIONS) +
                          " projections): a change too deep for the projection to undo (make it "
                          "in smaller moves, the rope settling between them); nothing changed");
    const double middle = 0.5 * (s0 + s1);
    return along(along(from, s0, middle, halvings + 1), middle, s1, halvings + 1);
  };
  const State there = along(data_->state, 0.0, 1.0, 0);
  auto [model, data] = compiledAt(1.0);
  // its displacement measured from the state before the change, as a change made at once is
  ProjectionReport report =
      installChangedWorld(std::move(model), std::move(data), "contacts", there);
  report.change_steps = taken;
  return report;
}

std::optional<State> Simulator::movedOut(const Model& model, Data& data, const State& from,
                                         const std::string& field, ProjectionReport* report,
                                         double* error) const
{
  State moved = from;
  const ProjectionReport projected = projectState(
      model, data, settings_, moved, field, "the state cannot be projected onto the constraints");
  if (report)
    *report = projected;
  data.setState(moved);
  separateContacts(model, data);
  // a contact now inside its surface or obstacle: switched on and projected, its approach taken
  // out (resolveImpacts at rest: no bounce below BOUNCE_SPEED)
  data.free_accelerations.setZero();
  State lifted = data.state;
  resolveImpacts(model, data, settings_, lifted);
  if (!isFinite(lifted))
    throw InvalidInput(field,
                       "moving the particles out of what their contacts keep them out of "
                       "produced a non-finite state; nothing changed");
  // the impacts' projection stops at its iteration limit without a word: a shape put deep over
  // a rope (its normals all along one line, the links across it) may leave no way out it finds
  const double left =
      computeDiagnostics(model, lifted, &data.tracks, &data.carriers).max_position_error;
  if (error)
    *error = left;
  if (!(left <= 2.0 * settings_.projection_tolerance))
    return std::nullopt;
  separateContacts(model, data);
  data.setState(lifted);
  return lifted;
}

ProjectionReport Simulator::installChangedWorld(std::unique_ptr<Model> model,
                                                std::unique_ptr<Data> data,
                                                const std::string& field, const State& from)
{
  // with the new model, before anything is replaced: a refusal changes nothing
  ProjectionReport report;
  double error = 0.0;
  const std::optional<State> lifted = movedOut(*model, *data, from, field, &report, &error);
  if (!lifted)
    throw TooDeepChange(field,
                        "leave the particles " + formatValue(error) +
                            " m from their constraints after moving them out of what "
                            "their contacts keep them out of (a change too deep for the "
                            "projection to undo: make it in smaller moves); nothing changed");
  report.max_displacement =
      (lifted->positions - data_->state.positions).colwise().norm().maxCoeff();
  report.max_velocity_change =
      (lifted->velocities - data_->state.velocities).colwise().norm().maxCoeff();
  const std::vector<double> loads = hold_loads_;  // the same holds: their last loads stand
  install(std::move(model), std::move(data));
  hold_loads_ = loads;
  forgetControl(*data_);
  openLedger();  // a new potential (a surface moved under a particle on it) and new powers
  return report;
}

void Simulator::setPerturbations(const std::vector<Force>& perturbations)
{
  for (std::size_t k = 0; k < perturbations.size(); ++k)
    validateForce(perturbations[k], model_->numParticles(),
                  "perturbations[" + std::to_string(k) + "]");
  data_->perturbations = perturbations;
  // the forces the next step starts from are no longer those of the last step
  data_->control.multipliers_current = false;
  data_->control.end_energies_current = false;
  const std::vector<double> loads = hold_loads_;  // the same holds: their last loads stand
  readSceneKind();
  hold_loads_ = loads;
  // the next step's work is booked from the new forces' power at its start, and the account is
  // measured against what they could move too (a drag on a chain at rest: |f| times its extent)
  EnergyLedger& ledger = data_->ledger;
  ledgerPowers(*model_, *data_, data_->state, ledger.power_in, ledger.power_dissipated,
               ledger.power_friction);
  ledger.power_in += drivenPower();
  ledger.scale = std::max(ledger.scale, ledgerScale(*model_, *data_));
}

void Simulator::updateLinkPairs()
{
  const Scene& scene = model_->scene();
  if (scene.self_collisions.empty())
    return;
  const Data& data = *data_;
  const std::vector<LinkPairContact> near =
      nearLinkPairs(scene.self_collisions, data.state.positions,
                    linkPairMargin(scene.self_collisions, data.state.velocities, settings_.dt));
  using Key = std::array<int, 4>;
  auto key = [](const LinkPairContact& c) {
    return Key{ { c.first_a, c.second_a, c.first_b, c.second_b } };
  };
  // the link pairs' rows come last (a scene's own, then the made ones): every pair by its
  // particles, each with its contact (the scene's own are on no rope: validateSelfCollisions)
  const auto& table = std::get<std::vector<KindRecord<LinkPairContact>>>(model_->kindTables());
  const int first_pair = model_->numContacts() - static_cast<int>(table.size());
  const auto generated = static_cast<std::size_t>(std::count_if(
      table.begin(), table.end(), [](const auto& pair) { return pair.record.generated; }));
  std::vector<std::pair<Key, int>> have;
  have.reserve(table.size());
  for (std::size_t k = 0; k < table.size(); ++k)
    have.emplace_back(key(table[k].record), first_pair + static_cast<int>(k));
  std::sort(have.begin(), have.end());
  auto find = [&have](const Key& k)
  {
    const auto it = std::lower_bound(have.begin(), have.end(), std::make_pair(k, -1));
    return it != have.end() && it->first == k ? it->second : -1;
  };
  const bool missing = std::any_of(near.begin(), near.end(),
                                   [&](const LinkPairContact& c) { return find(key(c)) < 0; });
  // far pairs are kept until they outnumber the near ones (their rows are off: they cost the
  // solve an identity row each), so a pair at the margin's edge does not recompile every step
  if (!missing && generated <= 2 * near.size() + 16)
    return;
  Scene next = scene;
  next.constraints.erase(std::remove_if(next.constraints.begin(), next.constraints.end(),
                                        [](const Constraint& c)
                                        {
                                          const auto* pair = std::get_if<LinkPairContact>(&c);
                                          return pair && pair->generated;
                                        }),
                         next.constraints.end());
  next.constraints.insert(next.constraints.end(), near.begin(), near.end());
  auto model = std::make_unique<Model>(Model::compile(next, requested_method_, paths_));
  auto fresh = std::make_unique<Data>(*model);
  fresh->setState(data.state);
  fresh->perturbations = data.perturbations;
  fresh->tracks = data.tracks;
  fresh->carriers = data.carriers;
  // the rows before the link pairs are the same rows in the same order; the pairs by particles
  StepControl control = data.control;
  const auto& pairs = std::get<std::vector<KindRecord<LinkPairContact>>>(model->kindTables());
  const int new_first_pair = model->numContacts() - static_cast<int>(pairs.size());
  std::vector<int> source(model->numContacts(), -1);
  for (int k = 0; k < new_first_pair; ++k)
    source[k] = k;
  for (std::size_t k = 0; k < pairs.size(); ++k)
    source[new_first_pair + k] = find(key(pairs[k].record));
  control.start_contacts = fresh->control.start_contacts;
  control.step_normal_forces = fresh->control.step_normal_forces;
  for (std::size_t k = 0; k < source.size(); ++k)
    if (source[k] >= 0)
    {
      fresh->contacts[k] = data.contacts[source[k]];
      control.start_contacts[k] = data.control.start_contacts[source[k]];
      control.step_normal_forces[k] = data.control.step_normal_forces[source[k]];
    }
  // the contact stage's buffers are sized for the new model (none without contacts)
  control.piece_start = fresh->control.piece_start;
  control.piece_contacts = fresh->control.piece_contacts;
  control.impact_positions = fresh->control.impact_positions;
  control.multipliers_current = false;  // of the old rows
  control.forward_version = 0;
  fresh->control = std::move(control);
  fresh->statistics = data.statistics;
  fresh->ledger = data.ledger;  // no work is done: the rows are frictionless and off or at rest
  fresh->counters = data.counters;
  writeContactRows(*model, *fresh);
  fresh->noteStateChange();
  const std::vector<double> loads = hold_loads_;  // the same holds: their last loads stand
  install(std::move(model), std::move(fresh));
  hold_loads_ = loads;
}

}  // namespace constrained_particles
