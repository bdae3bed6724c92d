#include "contact.hpp"

#include "constrained_particles/core/diagnostics.hpp"

#include "solvers/solver.hpp"
#include "stabilization.hpp"
#include "stages.hpp"

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
namespace
{
// Off, with no force: a contact that does not act holds no friction (velocity Verlet's and fast
// projection's kicks and the ledger read what it holds)
void switchOff(ContactState& contact)
{
  contact.mode = ContactMode::Separated;
  contact.friction_force.setZero();
}

// Where a unilateral row stands: its metric gap [m] (C >= 0's distance: a contact's height over
// its surface, a slack link's length less its span, a segment's distance less its radius), the
// rate it opens [m/s], and whether it may act there (a segment's nearest point strictly inside)
struct Touch
{
  double gap, opening;
  bool can_act = true;  ///< may switch on where it touches (a segment: s* inside and curved)
  bool at_end = false;  ///< a segment whose nearest point is at a bound: its particle's contact's
};
Touch touchOf(const Model& model, const UnilateralRecord& record, const EffectContext& context,
              const Points& positions, const Points& velocities)
{
  switch (record.kind)
  {
    case UnilateralKind::ParticleContact:
    {
      const ContactFrame frame = contactFrame(model, record, context, positions, velocities);
      return { frame.gap, frame.normalSpeed(frame.relative(velocities.col(record.particles[0]))) };
    }
    case UnilateralKind::SlackLink:
    {
      const SlackLink& link = unilateralRecord<SlackLink>(model, record);
      const Vec3 d = positions.col(link.first) - positions.col(link.second);
      const double span = d.norm();
      const Vec3 relative = velocities.col(link.first) - velocities.col(link.second);
      return { link.length - span, span > 0.0 ? -d.dot(relative) / span : 0.0 };
    }
    case UnilateralKind::LinkPairContact:
    {
      const LinkPairFrame f =
          linkPairFrame(unilateralRecord<LinkPairContact>(model, record), positions, velocities);
      return { f.gap, f.opening, f.between, !f.between };
    }
    case UnilateralKind::SegmentContact:
      break;
  }
  const SegmentContact& contact = unilateralRecord<SegmentContact>(model, record);
  const SegmentFrame s = segmentFrame(contact, context, positions, velocities);
  const Vec3 v = s.pointAt(velocities.col(contact.first), velocities.col(contact.second));
  return { s.frame.gap, s.frame.normal.dot(s.frame.relative(v)), s.between, s.at_bound };
}

// A pin, an anchor or an attachment holds every particle the row touches: it has no free block
bool held(const Model& model, const UnilateralRecord& record)
{
  const auto& w = model.inverseMasses();
  for (int a = 0; a < record.count; ++a)
    if (w[record.particles[a]] > 0.0)
      return false;
  return true;
}

// A row between a link and something (an obstacle, another link): its first two blocks sum to
// its unit normal, and it acts only where its point is strictly inside (Touch::can_act)
bool isLinkRow(const UnilateralRecord& record)
{
  return record.kind == UnilateralKind::SegmentContact ||
         record.kind == UnilateralKind::LinkPairContact;
}

// Switches off each acting segment whose nearest point has reached an end (or a flat stretch):
// it is its particle's contact's there, and on beside it the two rows are nearly dependent
// (J = ((1 - s*) n, s* n) against (n, 0)), their forces large and opposite. True if any.
bool releaseSegmentsAtEnds(const Model& model, Data& data, const EffectContext& context,
                           const State& x)
{
  const auto& rows = model.unilateral();
  bool released = false;
  for (int k = model.numParticleContacts(); k < model.numContacts(); ++k)
    if (isLinkRow(rows[k]) && acts(data.contacts[k]) &&
        !touchOf(model, rows[k], context, x.positions, x.velocities).can_act)
    {
      switchOff(data.contacts[k]);
      released = true;
    }
  if (released)
    writeContactRows(model, data);
  return released;
}

}  // namespace

void recordNormalForces(const Model& model, Data& data)
{
  const auto& rows = model.unilateral();
  for (std::size_t k = 0; k < rows.size(); ++k)
  {
    ContactState& contact = data.contacts[k];
    // J's normal: a particle contact's block, a slack link's -d (so lambda |d| is its tension),
    // a segment's (or a link pair's link a's) two blocks summed ((1 - s) n + s n, n unit)
    const Vec3 normal =
        isLinkRow(rows[k])
            ? Vec3(data.rows.jacobian[rows[k].block] + data.rows.jacobian[rows[k].block + 1])
            : data.rows.jacobian[rows[k].block];
    contact.normal_force = acts(contact) ? data.multipliers[rows[k].row] * normal.norm() : 0.0;
    if (!acts(contact) || rows[k].friction == 0.0)
      contact.friction_force.setZero();
  }
}

void separateContacts(const Model& model, Data& data)
{
  data.contacts.assign(data.contacts.size(), ContactState{});
  data.control.start_contacts = data.contacts;
  data.control.step_normal_forces.assign(data.contacts.size(), 0.0);
  writeContactRows(model, data);
}

void writeContactRows(const Model& model, Data& data)
{
  const auto& rows = model.unilateral();
  for (std::size_t k = 0; k < rows.size(); ++k)
  {
    if (held(model, rows[k]))  // no free block: the row stays off
      switchOff(data.contacts[k]);
    const std::uint8_t off = acts(data.contacts[k]) ? 0 : 1;
    data.rows.inactive[rows[k].row] = off;
    data.trial_rows.inactive[rows[k].row] = off;
  }
}

bool settleActiveSet(const Model& model, Data& data, const StepSettings& settings,
                     SolveReport& solved)
{
  const auto& rows = model.unilateral();
  const State& x = data.state;
  for (std::size_t iteration = 0; iteration < 2 * rows.size() + 4; ++iteration)
  {
    data.stages.p_stage = x.positions;
    data.stages.v_stage = x.velocities;
    solved = forward(model, data, settings, x.time, data.stages.p_stage, data.stages.v_stage,
                     data.accelerations);
    // Baraff's active set: the most negative multiplier leaves, one at a time
    int worst = -1;
    double most_negative = 0.0;
    for (std::size_t k = 0; k < rows.size(); ++k)
      if (acts(data.contacts[k]) && data.multipliers[rows[k].row] < most_negative)
      {
        most_negative = data.multipliers[rows[k].row];
        worst = static_cast<int>(k);
      }
    if (worst >= 0)
    {
      switchOff(data.contacts[worst]);
      writeContactRows(model, data);
      continue;
    }
    bool slips = false;
    for (ContactState& contact : data.contacts)
      if (contact.mode == ContactMode::Sticking && contact.friction_demand > 1.0)
      {
        // more than friction can hold: it slides the way friction, at its limit, held it
        contact.mode = ContactMode::Sliding;
        contact.slip_direction = contact.friction_force.normalized();
        slips = true;
      }
    if (!slips)
      return true;
  }
  return false;
}

double chooseContactModes(const Model& model, Data& data, const StepSettings& settings)
{
  State& x = data.state;
  const auto& w = model.inverseMasses();
  const double gap = contactGap(settings);
  const auto& rows = model.unilateral();
  const std::size_t contacts = static_cast<std::size_t>(model.numParticleContacts());
  const EffectContext context = contextAt(model, data, x.time);
  bool moving = false;  // a candidate to stick slides at all: its slide is stopped below
  // a slack link acts while taut: its span within the gap of its length, neither slackening nor
  // stretching (a stretch is a jerk, resolveImpacts); a segment while it touches, neither
  // leaving nor approaching, its nearest point strictly inside it
  for (std::size_t k = contacts; k < rows.size(); ++k)
  {
    const Touch touch = touchOf(model, rows[k], context, x.positions, x.velocities);
    data.contacts[k].mode = !held(model, rows[k]) && touch.can_act && touch.gap <= gap &&
                                    std::abs(touch.opening) <= CONTACT_SPEED
                                ? ContactMode::Sliding
                                : ContactMode::Separated;
  }
  for (std::size_t k = 0; k < contacts; ++k)
  {
    const UnilateralRecord& record = rows[k];
    ContactState& contact = data.contacts[k];
    const int i = record.particles[0];
    const ContactFrame frame = contactFrame(model, record, context, x.positions, x.velocities);
    const Vec3 v = frame.relative(x.velocities.col(i));  // to the obstacle's point under it
    // touching: on the surface, neither leaving it nor approaching it (an approach within the
    // gap ends in an impact, resolveImpacts, which restitution and the ledger see)
    const double normal_speed = frame.normalSpeed(v);
    if (!(w[i] > 0.0 && frame.gap <= gap && std::abs(normal_speed) <= CONTACT_SPEED))
    {
      switchOff(contact);
      contact.slip_direction.setZero();
      continue;
    }
    // a candidate to stick if friction could stop its slide within the step (Coulomb over one
    // step); it sticks if the solve below finds friction enough to hold it
    const double speed = frame.tangential(v).norm();
    const double stop =
        settings.dt * w[i] * record.friction * std::max(data.control.step_normal_forces[k], 0.0);
    contact.mode = record.friction > 0.0 && speed <= std::max(CONTACT_SPEED, stop)
                       ? ContactMode::Sticking
                       : ContactMode::Sliding;
    moving = moving || (contact.mode == ContactMode::Sticking && speed > 0.0);
  }
  writeContactRows(model, data);
  data.noteStateChange();
  SolveReport solved;
  const bool settled = settleActiveSet(model, data, settings, solved);
  // the sticking contacts stop: their tangential velocity goes, and the rows take the change
  double kinetic_before = 0.0;  // summed (O(n)) only when a contact has a slide to stop
  bool stopped = false;
  // settleActiveSet changes no velocity and makes no new stick: only a candidate that slid at all
  // has a slide to stop
  for (std::size_t k = 0; k < contacts && moving; ++k)
    if (data.contacts[k].mode == ContactMode::Sticking)
    {
      const int i = rows[k].particles[0];
      const ContactFrame frame = contactFrame(model, rows[k], context, x.positions, x.velocities);
      const Vec3 v_t = frame.tangential(frame.relative(x.velocities.col(i)));
      if (!(v_t.norm() > 0.0))
        continue;
      if (!stopped)
        kinetic_before = kineticEnergy(model, x);
      stopped = true;
      x.velocities.col(i) -= v_t;
    }
  if (!stopped)
  {
    // the step's first stage is at this state with these modes: it takes the stage just solved
    if (settled)
    {
      data.control.forward_version = data.stateVersion();
      data.control.forward_time = x.time;
      data.control.forward_report = solved;
    }
    return 0.0;
  }
  projectVelocities(model, data, x.time, x.positions, x.velocities, false, false);
  return kinetic_before - kineticEnergy(model, x);
}

double impactFraction(const Model& model, Data& data, const Points& p0, const Points& v0,
                      const State& x, double h, double tolerance)
{
  const auto& rows = model.unilateral();
  Points& p = data.control.impact_positions;
  bool copied = false;
  double earliest = NAN;
  const EffectContext at_end = contextAt(model, data, x.time);
  for (std::size_t k = 0; k < rows.size(); ++k)
  {
    if (acts(data.contacts[k]) || held(model, rows[k]))  // no frame for them (a resting rope's)
      continue;
    const Touch touch = touchOf(model, rows[k], at_end, x.positions, x.velocities);
    // a contact in but moving out is no impact (resolveImpacts lifts it): no time to meet; a
    // segment in at an end is its particle's contact's
    if (!(touch.gap < -tolerance) || touch.at_end ||
        (rows[k].kind != UnilateralKind::SlackLink && touch.opening > 0.0))
      continue;
    if (!copied)
      p = x.positions;  // the other particles' columns are not read: rows touch their own
    copied = true;
    const int count = rows[k].count;
    // the row's gap with its particles at fraction s along their Hermite paths
    auto gapAt = [&](double s)
    {
      const double s2 = s * s, s3 = s2 * s;
      const double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2,
                   h11 = s3 - s2;
      for (int a = 0; a < count; ++a)
      {
        const int i = rows[k].particles[a];
        p.col(i) = h00 * p0.col(i) + (h10 * h) * v0.col(i) + h01 * x.positions.col(i) +
                   (h11 * h) * x.velocities.col(i);
      }
      // a carried obstacle where it is then
      return touchOf(model, rows[k], contextAt(model, data, x.time - (1.0 - s) * h), p,
                     x.velocities)
          .gap;
    };
    // the crossing sought is twice the tolerance in: the piece taken to it ends in (so
    // resolveImpacts meets the row) by about that much (energy m g 2 tolerance), whatever the
    // integrator's path differs from the Hermite one by, within a tolerance
    const double target = -2.0 * tolerance;
    if (gapAt(0.0) > target)
    {
      double low = 0.0, high = 1.0;  // out at low, in at high
      while (high - low > 1e-12)
      {
        const double middle = 0.5 * (low + high);
        (gapAt(middle) > target ? low : high) = middle;
      }
      if (!(earliest <= high))
        earliest = high;
    }
    for (int a = 0; a < count; ++a)
      p.col(rows[k].particles[a]) = x.positions.col(rows[k].particles[a]);
  }
  return earliest;
}

double releaseFraction(const Model& model, Data& data, const std::vector<ContactState>& at_start,
                       State& x, const StepSettings& settings, int& released)
{
  released = -1;
  const auto& rows = model.unilateral();
  const EffectContext context = contextAt(model, data, x.time);
  bool candidate = false;
  for (int k = 0; k < model.numParticleContacts() && !candidate; ++k)
    if (acts(data.contacts[k]))
    {
      const ContactFrame frame = contactFrame(model, rows[k], context, x.positions, x.velocities);
      const int i = rows[k].particles[0];
      candidate = frame.normal.dot(data.free_accelerations.col(i)) + frame.curvature_term > 0.0;
    }
  // a segment likewise, its point's free acceleration (1 - s*) a_i + s* a_j
  for (int k = model.numParticleContacts(); k < model.numContacts() && !candidate; ++k)
    if (rows[k].kind == UnilateralKind::SegmentContact && acts(data.contacts[k]))
    {
      const SegmentContact& segment = unilateralRecord<SegmentContact>(model, rows[k]);
      const SegmentFrame s = segmentFrame(segment, context, x.positions, x.velocities);
      const Vec3 free = s.pointAt(data.free_accelerations.col(segment.first),
                                  data.free_accelerations.col(segment.second));
      candidate = s.frame.normal.dot(free) + s.frame.curvature_term > 0.0;
    }
    else if (rows[k].kind == UnilateralKind::LinkPairContact && acts(data.contacts[k]))
    {
      // a link pair: its points' free relative acceleration along n
      const LinkPairContact& pair = unilateralRecord<LinkPairContact>(model, rows[k]);
      const LinkPairFrame f = linkPairFrame(pair, x.positions, x.velocities);
      const std::array<Vec3, 4> jacobian = linkPairJacobian(f);
      double free = f.curvature_term;
      for (int a = 0; a < 4; ++a)
        free += jacobian[a].dot(data.free_accelerations.col(rows[k].particles[a]));
      candidate = free > 0.0;
    }
  if (!candidate)
    return NAN;
  // the multipliers at x: a forward stage there, in the stage buffers (the integrator is done)
  data.stages.p_stage = x.positions;
  data.stages.v_stage = x.velocities;
  forward(model, data, settings, x.time, data.stages.p_stage, data.stages.v_stage,
          data.stages.a_stage);
  double earliest = NAN;
  for (int k = 0; k < model.numContacts(); ++k)
  {
    if (!acts(data.contacts[k]) || rows[k].kind == UnilateralKind::SlackLink)
      continue;
    // [N]: a particle contact's J is its normal, a segment's n unit
    const double end = data.multipliers[rows[k].row] *
                       (isLinkRow(rows[k]) ? 1.0 : data.rows.jacobian[rows[k].block].norm());
    if (!(end < 0.0))
      continue;
    const double start = std::max(at_start[k].normal_force, 0.0);
    const double fraction = start / (start - end);
    if (!(earliest <= fraction))
    {
      earliest = fraction;
      released = k;
    }
  }
  return earliest;
}

void releaseContact(const Model& model, Data& data, int k)
{
  switchOff(data.contacts[k]);
  writeContactRows(model, data);
  data.noteStateChange();
}

namespace
{
// Coulomb at an impact (issue 48, item 3): each landing contact's slip after the normal impulse
// P_n (`impulses`: the row's, times |J|) is met by a tangential impulse of at most mu P_n against
// it, which stops it where that is enough (a point's impact law, Brogliato 1999, "Nonsmooth
// Mechanics", 4.3; Stronge 2000); then the velocities are projected onto the rows again, which
// takes along what the particle's links carry. Staggered as the forces' friction is: each impulse
// is its particle's own. It never adds energy: an impulse against the slip of at most the slip
// times the mass lowers the particle's kinetic energy, and a projection in the mass metric does.
void impactFriction(const Model& model, Data& data, const EffectContext& context,
                    const Eigen::VectorXd& impulses, State& x)
{
  const auto& rows = model.unilateral();
  const auto& w = model.inverseMasses();
  bool changed = false;
  for (int k = 0; k < model.numParticleContacts(); ++k)
  {
    ContactState& contact = data.contacts[k];
    if (!contact.landing)
      continue;
    contact.landing = false;
    const int i = rows[k].particles[0];
    const ContactFrame frame = contactFrame(model, rows[k], context, x.positions, x.velocities);
    const double normal_impulse = impulses[rows[k].row] * frame.normal.norm();
    const Vec3 slip = frame.tangential(frame.relative(x.velocities.col(i)));
    const double speed = slip.norm();
    if (!(normal_impulse > 0.0) || !(speed > 0.0))
      continue;
    x.velocities.col(i) -= std::min(speed, rows[k].friction * normal_impulse * w[i]) / speed * slip;
    changed = true;
  }
  if (changed)
    projectVelocities(model, data, x.time, x.positions, x.velocities, false, false);
}
}  // namespace

double resolveImpacts(const Model& model, Data& data, const StepSettings& settings, State& x)
{
  const auto& rows = model.unilateral();
  const std::size_t contacts = static_cast<std::size_t>(model.numParticleContacts());
  const EffectContext context = contextAt(model, data, x.time);
  Eigen::VectorXd& restitution = data.contact_rhs;
  double before = NAN;
  if (releaseSegmentsAtEnds(model, data, context, x))
    data.noteStateChange();
  // a projection onto the new rows moves the particles they are linked to, which may take another
  // contact below its surface: again, until none is (each round switches one on at least)
  for (std::size_t round = 0; round <= rows.size(); ++round)
  {
    // a contact in but moving out is not an impact: its method's path bent past a surface the
    // motion leaves (semi-implicit Euler's drift, dt^2 a where the motion's is dt^2 a / 2, lands
    // a bead leaving a dome inside it until z = R / 2): its particle is lifted out, positions
    // only, and keeps its velocity; an impulse there would hold it on
    bool lift = false, below = false;  // below: a contact off is under its surface
    for (std::size_t k = 0; k < contacts; ++k)
    {
      ContactState& contact = data.contacts[k];
      const int i = rows[k].particles[0];
      if (acts(contact) || !(model.inverseMasses()[i] > 0.0))
        continue;
      const ContactFrame frame = contactFrame(model, rows[k], context, x.positions, x.velocities);
      below = below || frame.gap < -settings.projection_tolerance;
      if (frame.gap < -settings.projection_tolerance &&
          frame.normalSpeed(frame.relative(x.velocities.col(i))) > 0.0)
      {
        contact.mode = ContactMode::Sliding;
        contact.lifting = true;
        lift = true;
      }
    }
    // a segment likewise (one pressed to an end is its particle's contact's)
    for (std::size_t k = contacts; k < rows.size(); ++k)
    {
      ContactState& contact = data.contacts[k];
      if (!isLinkRow(rows[k]) || acts(contact) || held(model, rows[k]))
        continue;
      const Touch touch = touchOf(model, rows[k], context, x.positions, x.velocities);
      if (touch.at_end || !(touch.gap < -settings.projection_tolerance))
        continue;
      below = true;
      if (touch.opening > 0.0)
      {
        contact.mode = ContactMode::Sliding;
        contact.lifting = true;
        lift = true;
      }
    }
    if (lift)
    {
      if (std::isnan(before))
        before = kineticEnergy(model, x) + potentialEnergy(model, x);
      writeContactRows(model, data);
      projectPositions(model, data, x.time, x.positions, settings.projection_tolerance,
                       settings.projection_max_iterations);
      for (ContactState& contact : data.contacts)
        if (contact.lifting)
        {
          switchOff(contact);
          contact.lifting = false;
        }
      writeContactRows(model, data);
      data.noteStateChange();
    }
    restitution.setZero();
    bool impact = false, bounce = false;
    // a slack link stretched past its length: it jerks taut (inelastic, with the rows); a
    // segment in its obstacle: an impact, as a particle contact's below
    for (std::size_t k = contacts; k < rows.size(); ++k)
    {
      if (acts(data.contacts[k]) || held(model, rows[k]))
        continue;
      const Touch touch = touchOf(model, rows[k], context, x.positions, x.velocities);
      if (touch.at_end || !(touch.gap < -settings.projection_tolerance))
        continue;
      data.contacts[k].mode = ContactMode::Sliding;
      impact = true;
      if (rows[k].kind != UnilateralKind::SegmentContact || !(rows[k].restitution > 0.0))
        continue;
      const SegmentContact& segment = unilateralRecord<SegmentContact>(model, rows[k]);
      const SegmentFrame frame = segmentFrame(segment, context, x.positions, x.velocities);
      const Vec3 free = frame.pointAt(data.free_accelerations.col(segment.first),
                                      data.free_accelerations.col(segment.second));
      const double resting =
          std::max(BOUNCE_SPEED, 2.0 * settings.dt * std::abs(frame.frame.normal.dot(free)));
      if (-touch.opening > resting)
      {
        restitution[rows[k].row] = -rows[k].restitution * touch.opening;  // J v + dC/dt, n unit
        bounce = true;
      }
    }
    // nothing below and nothing lifted: no contact impact to look for (each frame evaluated once)
    bool rubbing = false;  // a landing contact with friction
    for (std::size_t k = 0; (lift || below) && k < contacts; ++k)
    {
      ContactState& contact = data.contacts[k];
      const UnilateralRecord& record = rows[k];
      const int i = record.particles[0];
      if (acts(contact) || !(model.inverseMasses()[i] > 0.0))
        continue;
      const ContactFrame frame = contactFrame(model, record, context, x.positions, x.velocities);
      if (!(frame.gap < -settings.projection_tolerance))
        continue;
      contact.mode = ContactMode::Sliding;  // off until now, so with no friction (switchOff)
      contact.landing = record.friction > 0.0;
      rubbing = rubbing || contact.landing;
      impact = true;
      const Vec3 v = frame.relative(x.velocities.col(i));  // to the obstacle's point
      // slower than twice what the applied forces give in a step is a particle at rest
      // landing again within the step: inelastic (else a bounce and the projection's lift
      // cycle for ever)
      const double resting =
          std::max(BOUNCE_SPEED,
                   2.0 * settings.dt *
                       std::abs(frame.normal.normalized().dot(data.free_accelerations.col(i))));
      if (record.restitution > 0.0 && -frame.normalSpeed(v) > resting)
      {
        // the row's rate out of the impact: e times the rate in, Cdot- = J v- + dC/dt < 0
        restitution[record.row] = -record.restitution * frame.normal.dot(v);
        bounce = true;
      }
    }
    if (!impact)
      break;
    if (std::isnan(before))
      before = kineticEnergy(model, x) + potentialEnergy(model, x);
    writeContactRows(model, data);
    projectStep(model, data, ForwardPath::Generic, x.time, x.positions, x.velocities,
                settings.projection_tolerance, settings.projection_max_iterations);
    // the velocity projection's multipliers: dv = -W J^T lambda, an impulse -lambda along each J
    Eigen::VectorXd& impulses = data.impact_impulses;
    if (rubbing)
      impulses = -data.rhs;
    if (bounce)
    {
      // Newton's law: each bouncing row leaves at e times its rate in, every other row at rest
      // (links exact): J W J^T x = those rates, with the velocity projection's factorisation
      // (of these rows at these positions), and v += W J^T x
      data.solver().solveInPlace(restitution);
      addInverseMassJacobianTranspose(model, data.rows, restitution, 1.0, x.velocities);
      if (rubbing)
        impulses += restitution;
      for (std::size_t k = 0; k < contacts; ++k)  // only contacts (and segments) bounce
      {
        if (!acts(data.contacts[k]))
          continue;
        const ContactFrame frame = contactFrame(model, rows[k], context, x.positions, x.velocities);
        if (frame.normalSpeed(frame.relative(x.velocities.col(rows[k].particles[0]))) >
            CONTACT_SPEED)
          switchOff(data.contacts[k]);  // leaving
      }
      for (std::size_t k = contacts; k < rows.size(); ++k)
        if (isLinkRow(rows[k]) && acts(data.contacts[k]) &&
            touchOf(model, rows[k], context, x.positions, x.velocities).opening > CONTACT_SPEED)
          switchOff(data.contacts[k]);
      writeContactRows(model, data);
    }
    if (rubbing)
      impactFriction(model, data, context, impulses, x);
    releaseSegmentsAtEnds(model, data, context, x);
    data.noteStateChange();
  }
  if (std::isnan(before))
    return 0.0;
  return before - (kineticEnergy(model, x) + potentialEnergy(model, x));
}

}  // namespace constrained_particles
