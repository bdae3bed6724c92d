/// @file contact_friction.cpp
/// @brief Coulomb friction at the contacts (contact.hpp): the constraint-force stage of a scene
/// with contacts, its friction iterated to a fixed point with the rows' factorisation (staggered,
/// Anderson-mixed where it contracts: fixed_point.hpp), and the friction kick of the integrators
/// that solve no stages. docs/physics.md, "Contact".
#include "contact.hpp"

#include "fixed_point.hpp"
#include "solvers/solver.hpp"
#include "stages.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

namespace constrained_particles
{
namespace
{
// The friction force [N] an acting contact exerts at multiplier `lambda` (its row's J `normal`):
// sliding, mu |f_n| against the tangential part of `v` (relative to the obstacle; below
// CONTACT_SPEED along its slip direction); sticking, minus the tangential part of `other` (the
// particle's other forces), at most mu |f_n| (its demand, the ratio, kept in `contact`)
Vec3 frictionForce(const UnilateralRecord& record, ContactState& contact, const Vec3& normal,
                   double lambda, const Vec3& v, const Vec3& other)
{
  const double normal_force = std::max(lambda, 0.0) * normal.norm();
  const double limit = record.friction * normal_force;
  auto tangential = [&normal](const Vec3& x) { return tangentialPart(normal, x); };
  if (contact.mode == ContactMode::Sliding)
  {
    const Vec3 v_t = tangential(v);
    const double speed = v_t.norm();
    if (speed > CONTACT_SPEED)
    {
      contact.slip_direction = -v_t / speed;  // where friction pulls if it slows below
      return limit * contact.slip_direction;
    }
    const Vec3 slip = tangential(contact.slip_direction);
    return slip.norm() > 0.0 ? Vec3(limit / slip.norm() * slip) : Vec3::Zero();
  }
  const Vec3 needed = -tangential(other);
  const double size = needed.norm();
  contact.friction_demand =
      size == 0.0 ? 0.0 : (limit > 0.0 ? size / limit : std::numeric_limits<double>::infinity());
  return contact.friction_demand > 1.0 ? Vec3(limit / size * needed) : needed;
}

// Each particle's friction force [N] (3 x n) from the contacts' stacked ones `stacked` (3 per
// particle contact, Data::friction_iterate's layout)
void spreadFriction(const Model& model, const Eigen::VectorXd& stacked, Points& forces)
{
  forces.setZero();
  const auto& table = model.unilateral();
  for (int k = 0; k < model.numParticleContacts(); ++k)
    forces.col(table[k].particles[0]) += stacked.segment<3>(3 * k);
}

// The sizes of one friction image [N]: the largest change from the friction solved with, the
// largest friction force, the largest normal force (what FRICTION_TOLERANCE is a fraction of).
struct FrictionImage
{
  double change = 0.0, largest = 0.0, scale = 0.0;
};

// One image g = G(x) of the friction iteration: each acting contact's friction force at the
// multipliers solved with friction x (3 per particle contact; nullptr: none), into `g` (if given)
// and data.contacts. `velocities` the stage's.
FrictionImage frictionImage(const Model& model, Data& data, const Points& velocities,
                            const Eigen::VectorXd* x, Eigen::VectorXd* g)
{
  const auto& table = model.unilateral();
  const auto& w = model.inverseMasses();
  FrictionImage image;
  if (g)
    g->setZero();
  for (std::size_t k = 0; k < static_cast<std::size_t>(model.numParticleContacts()); ++k)
  {
    ContactState& contact = data.contacts[k];
    const UnilateralRecord& record = table[k];
    if (!acts(contact) || record.friction == 0.0)
      continue;
    const int i = record.particles[0];
    const Vec3& normal = data.rows.jacobian[record.block];
    const double lambda = data.multipliers[record.row];
    // the particle's other forces: applied and J^T lambda (data.constraint_forces has no
    // friction yet), less this contact's own normal force, which has no tangential part
    Vec3 other = data.applied_forces.col(i) + data.constraint_forces.col(i);
    Vec3 v = velocities.col(i);
    if (model.hasCarriers())  // m a_s less its other forces: what a stick must give
    {
      v = data.contact_relative_velocities.col(k);
      other -= data.contact_surface_accelerations.col(k) / w[i];
    }
    const Vec3 f = frictionForce(record, contact, normal, lambda, v, other);
    image.change = std::max(image.change, x ? (f - x->segment<3>(3 * k)).norm() : f.norm());
    image.largest = std::max(image.largest, f.norm());
    image.scale = std::max(image.scale, std::max(lambda, 0.0) * normal.norm());
    contact.friction_force = f;
    if (g)
      g->segment<3>(3 * k) = f;
  }
  return image;
}

// Every contact's friction force 0 (friction at rounding's level is none).
void noFriction(Data& data)
{
  for (ContactState& contact : data.contacts)
    contact.friction_force.setZero();
}

// Whether a contact with friction acts.
bool anyFriction(const Model& model, const Data& data)
{
  const auto& table = model.unilateral();
  for (std::size_t k = 0; k < static_cast<std::size_t>(model.numParticleContacts()); ++k)
    if (acts(data.contacts[k]) && table[k].friction > 0.0)
      return true;
  return false;
}

}  // namespace

SolveReport contactForceStage(const Model& model, Data& data, double time, const Points& positions,
                              const Points& velocities, const Eigen::VectorXd* bias)
{
  const SolveReport report = constraintForceStage(model, data, bias);
  const auto& table = model.unilateral();
  const std::size_t contacts = static_cast<std::size_t>(model.numParticleContacts());
  if (!anyFriction(model, data))
  {
    recordNormalForces(model, data);
    return report;
  }
  // friction enters as a force f: (J W J^T) lambda = b - J W f, so lambda = lambda_0 - (J W
  // J^T)^-1 J W f with the factorisation already made; iterated to a fixed point (staggered)
  const int m = model.numRows();
  const auto& w = model.inverseMasses();
  if (model.hasCarriers())
  {
    // on a carried shape the slip is relative to the shape's point under the particle, and a
    // stick must give the particle that point's acceleration: both fixed over the iteration
    const EffectContext context = contextAt(model, data, time);
    for (std::size_t k = 0; k < contacts; ++k)
      if (acts(data.contacts[k]) && table[k].friction > 0.0)
      {
        const ContactFrame frame = contactFrame(model, table[k], context, positions, velocities);
        data.contact_relative_velocities.col(k) =
            frame.relative(velocities.col(table[k].particles[0]));
        data.contact_surface_accelerations.col(k) = frame.surface_acceleration;
      }
  }
  data.frictionless_multipliers = data.multipliers.head(m);
  // x: the friction the multipliers were solved with (none yet); g = G(x), each contact's force
  // from them. Anderson's mixing (fixed_point.hpp) takes the next x from the last few (x, g).
  Eigen::VectorXd& x = data.friction_iterate;
  Eigen::VectorXd& g = data.friction_image;
  x.setZero();
  clearHistory(data.friction_history);
  bool converged = false;
  double last_change = 0.0, last_scale = 0.0, least_change = 0.0;
  int slow = 0;        // solves in a row whose change fell by less than FRICTION_STALL_RATIO
  int steady = 0;      // solves in a row whose change fell by more, to a new least
  bool mixed = false;  // x came from andersonStep (its first call after a clear is plain)
  for (int iteration = 0; iteration < MAX_FRICTION_ITERATIONS; ++iteration)
  {
    const FrictionImage image = frictionImage(model, data, velocities, &x, &g);
    const double change = image.change, scale = image.scale, largest = image.largest;
    // the multipliers are of the forces x (none yet, or the last round's); friction at
    // rounding's level (a chain at rest on a level plane) is none
    if (iteration == 0 && largest <= FRICTION_TOLERANCE * scale)
    {
      g.setZero();
      noFriction(data);
      converged = true;
    }
    else if (iteration > 0 && change <= FRICTION_TOLERANCE * scale)
      converged = true;
    if (converged)
    {
      x = g;
      break;
    }
    // two plain solves in a row that barely shrink the change: no fixed point to reach (two
    // sticking contacts joined by straight links, docs/physics.md), further solves only drift it
    // (a mixed step's change may rise and says nothing of the plain map's)
    slow = iteration > 1 && !mixed && change > FRICTION_STALL_RATIO * last_change ? slow + 1 : 0;
    const bool stalled = slow >= 2;
    // the mixing steps only where the iteration shrinks steadily: solves in a row whose change
    // fell (below FRICTION_STALL_RATIO of the one before), none of them above the least yet
    steady =
        iteration > 0 && change < FRICTION_STALL_RATIO * last_change && !(change > least_change)
            ? steady + 1
            : 0;
    least_change = iteration == 0 ? change : std::min(least_change, change);
    last_change = change;
    last_scale = scale;
    // the last solve, stalled or at the limit, is of g itself: within each cone, the forces the
    // contacts hold. Below FRICTION_MIXING_FLOOR the plain steps finish: there the differences
    // near rounding would steer the fit, and two solves of the same scene (another elimination
    // order) part where a stick's split between linked particles is free (test_stage_paths)
    if (stalled || iteration + 1 == MAX_FRICTION_ITERATIONS ||
        change <= FRICTION_MIXING_FLOOR * scale || steady < FRICTION_MIXING_STEADY)
    {
      // a plain step starts the mixing afresh: between cone clamps the map is only piecewise
      // linear, and differences across a clamp's switch (or a split left free) mislead the fit
      clearHistory(data.friction_history);
      x = g;
      mixed = false;
    }
    else
    {
      andersonStep(data.friction_history, x, g, data.friction_mixed);
      x.swap(data.friction_mixed);
      mixed = true;
    }
    spreadFriction(model, x, data.friction_forces);
    for (int i = 0; i < model.numParticles(); ++i)
      data.friction_accelerations.col(i) = w[i] * data.friction_forces.col(i);
    multiplyJacobian(model, data.rows, data.friction_accelerations, data.contact_rhs);
    data.solver().solveInPlace(data.contact_rhs);
    data.multipliers.head(m) = data.frictionless_multipliers - data.contact_rhs;
    data.constraint_forces.setZero();
    addJacobianTranspose(model, data.rows, data.multipliers.head(m), 1.0, data.constraint_forces);
    addEliminatedReactions(model, data);
    if (stalled)  // after the solve: the multipliers are of the friction kept
      break;
  }
  spreadFriction(model, x, data.friction_forces);
  // stalled or at the limit the last iterate stands; a change above FRICTION_REPORT_TOLERANCE is
  // reported
  if (!converged && !(last_change <= FRICTION_REPORT_TOLERANCE * last_scale))
    ++data.control.unconverged_friction;
  data.constraint_forces += data.friction_forces;  // on free particles only: no reaction changes
  recordNormalForces(model, data);
  return report;
}

bool frictionAtRounding(const Model& model, Data& data, const Points& velocities)
{
  assert(!model.hasCarriers());  // their slip is relative to a shape's point: contactForceStage
  if (!anyFriction(model, data))
    return true;
  const FrictionImage image = frictionImage(model, data, velocities, nullptr, nullptr);
  if (!(image.largest <= FRICTION_TOLERANCE * image.scale))
    return false;
  noFriction(data);
  data.friction_forces.setZero();
  return true;
}

bool slidesWithFriction(const Model& model, const Data& data)
{
  const auto& table = model.unilateral();
  for (std::size_t k = 0; k < static_cast<std::size_t>(model.numParticleContacts()); ++k)
    if (data.contacts[k].mode == ContactMode::Sliding && table[k].friction > 0.0)
      return true;
  return false;
}

void kickForces(const Model& model, Data& data, double dt, Points& velocities)
{
  const auto& w = model.inverseMasses();
  const Points& applied = data.applied_forces;
  for (int i = 0; i < model.numParticles(); ++i)
    velocities.col(i) += (dt * w[i]) * applied.col(i);
  const auto& table = model.unilateral();
  double loss = 0.0;
  for (std::size_t k = 0; k < static_cast<std::size_t>(model.numParticleContacts()); ++k)
    if (acts(data.contacts[k]) && table[k].friction > 0.0)
    {
      const int i = table[k].particles[0];
      if (w[i] == 0.0)  // an eliminated particle: not moved, no work
        continue;
      const Vec3& f = data.contacts[k].friction_force;
      const Vec3 before = velocities.col(i);
      velocities.col(i) += (dt * w[i]) * f;
      // dt f . (v_0 + v_1) / 2 from the velocities around this contact's kick, less what they
      // hold of the applied force's kick (v_0 is before it): summed over a particle's contacts,
      // friction's share of the whole kick
      loss -= 0.5 * dt * f.dot(before + velocities.col(i)) -
              0.5 * dt * dt * w[i] * f.dot(applied.col(i));
    }
  // a moving obstacle's slip is relative to its point: the ledger's trapezoid books it there
  if (model.hasCarriers())
    return;
  data.control.friction_kicked = true;
  data.control.friction_kick_loss += loss;
}

}  // namespace constrained_particles
