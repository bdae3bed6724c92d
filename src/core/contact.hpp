/// @file contact.hpp
/// @brief The contact stage: which surface contacts act (an active set chosen at each step's
/// start), their Coulomb friction (solved with the rows, staggered), and impacts (a velocity
/// projection after a step that went below a surface). docs/physics.md, "Contact". Private to
/// the core.
///
/// Between impacts a contact's row is an equality while it acts, so the stages, integrators and
/// projections are the bilateral ones: the motion is as exact as theirs. The complementarity
/// lambda_n >= 0, C >= 0, lambda_n C = 0 is kept at the acceleration level at each step's start
/// (Baraff 1994, "Fast contact force computation for nonpenetrating rigid bodies": drop the
/// most negative multiplier, solve again), and at the velocity level at an impact (Moreau 1988:
/// the inelastic impulse is the projection of the velocities onto the active rows; Newton's
/// restitution scales it by 1 + e). Friction is a force in the tangent plane, iterated with the
/// solve to a fixed point (Kaufman, Sueda, James, Pai 2008, staggered projections; each iterate
/// mixed from the last few by Anderson acceleration, fixed_point.hpp), so the matrix stays J W
/// J^T of the rows (symmetric, a chain's still a forest).
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"

#include "fixed_point.hpp"

#include <cmath>

namespace constrained_particles
{
/// Normal or tangential speed below which a contact counts as at rest relative to its surface
/// [m/s]: it touches if it approaches no faster (and its gap is within contactGap()), it may
/// stick if it slides no faster (or no faster than friction stops it within the step).
constexpr double CONTACT_SPEED = 1e-6;
/// Approach speed below which an impact is inelastic whatever its restitution [m/s] (and below
/// twice the normal speed the applied forces give in a step): a bouncing particle comes to rest
/// after finitely many bounces.
constexpr double BOUNCE_SPEED = 1e-3;
/// Friction fixed-point iterations per stage at most; it converges when no friction force changes
/// by more than FRICTION_TOLERANCE of the largest normal force.
constexpr int MAX_FRICTION_ITERATIONS = 100;
constexpr double FRICTION_TOLERANCE = 1e-13;
/// A stage whose friction still changed by more than this fraction of the largest normal force
/// where it stopped (stalled, or at MAX_FRICTION_ITERATIONS) is counted
/// (StepStatistics::unconverged_friction); a stall below it stops the iteration uncounted (run
/// on, its change would stand still to MAX_FRICTION_ITERATIONS).
constexpr double FRICTION_REPORT_TOLERANCE = 1e-9;
/// The friction iteration stops, stalled, after two solves in a row whose change is over this
/// fraction of the one before (its multipliers solved for the friction kept): it has no fixed
/// point there (two sticking contacts joined by straight links; docs/physics.md, "Contact").
/// Where it converges, each change is about 0.75 of the last on test_contact's chains.
constexpr double FRICTION_STALL_RATIO = 0.98;
/// Differences of friction iterates (and of their residuals) the Anderson mixing fits with
/// (fixed_point.hpp).
constexpr int FRICTION_HISTORY = 5;
static_assert(FRICTION_HISTORY <= MAX_ANDERSON_DEPTH, "the fit's normal equations are fixed-size");
/// Below this change, a fraction of the largest normal force, the friction iteration takes plain
/// steps (next = G(x)) to FRICTION_TOLERANCE: the mixing's fit there reads rounding, and the
/// plain steps keep a free split (two sticking contacts joined by links) where it is.
constexpr double FRICTION_MIXING_FLOOR = 1e-9;
/// The friction iteration mixes its iterates (Anderson) only after this many solves in a row
/// whose change fell below FRICTION_STALL_RATIO of the one before, each to a new least: where the
/// plain iteration contracts. Elsewhere (a clamp switching, a split left free, no fixed point)
/// the mixing's extrapolation split rope_over_edge's steps into many sub-steps (docs/physics.md),
/// and the plain steps stay.
constexpr int FRICTION_MIXING_STEADY = 2;

/// A contact touches if its gap is at most this [m]: 10 projection tolerances, so a contact the
/// projection holds on its surface is touching.
inline double contactGap(const StepSettings& settings)
{
  return 10.0 * settings.projection_tolerance;
}

/// Whether a contact's row acts (any mode but ContactMode::Separated).
inline bool acts(const ContactState& contact)
{
  return contact.mode != ContactMode::Separated;
}

/// Each unilateral row's force from the multipliers into data.contacts (a contact's normal force,
/// a slack link's tension [N]); friction zeroed where none acts.
void recordNormalForces(const Model& model, Data& data);

/// Every contact off, its forces 0 (and so at the step's start: StepControl::start_contacts): the
/// state was replaced from outside (a reset, a teleport), so the next step's start chooses again.
void separateContacts(const Model& model, Data& data);

/// Writes the contacts' modes into data.rows.inactive and data.trial_rows.inactive (a row acts
/// unless its contact is ContactMode::Separated, or its particle is held: a pin, an anchor or an
/// attachment holds it, and its contact waits until it is let go).
void writeContactRows(const Model& model, Data& data);

/// The constraint-force stage of a scene with contacts: constraintForceStage() (the rows, the
/// acting contacts' included), then each acting contact's friction: sliding, mu |f_n| against
/// the tangential velocity (or along ContactState::slip_direction below CONTACT_SPEED);
/// sticking, minus the tangential force on the particle, at most mu |f_n|. Friction enters the
/// right-hand side as J W f, solved again with the same factorisation until it stops changing.
/// data.constraint_forces include it; data.contacts get each contact's forces.
/// `time`, `positions`: the stage's (where carried obstacles are, and their points' velocities,
/// which slip is measured against).
SolveReport contactForceStage(const Model& model, Data& data, double time, const Points& positions,
                              const Points& velocities, const Eigen::VectorXd* bias);

/// contactForceStage's first friction check on the multipliers and forces already in `data`
/// (solved without friction; no carried shape): true if no contact with friction acts, or if
/// every acting contact's friction comes out at rounding's level (FRICTION_TOLERANCE of the
/// largest normal force), then taken as none (data.contacts' and data.friction_forces zeroed), as
/// contactForceStage takes it; false if friction must be solved for (contactForceStage).
/// `velocities`: the stage's.
bool frictionAtRounding(const Model& model, Data& data, const Points& velocities);

/// Whether a particle contact with friction slides: its friction, mu |f_n| against the slip, is
/// to be solved for with the rows unless it stops pressing, so a fused stage leaves the stage to
/// contactForceStage before its sweeps (the same stage either way).
bool slidesWithFriction(const Model& model, const Data& data);

/// velocities += dt W (f + f_t): f the applied forces (data.applied_forces), f_t each acting
/// contact's friction force [N] as data.contacts hold it (the step's start: chooseContactModes'
/// solve). The kick of the integrators that hold the constraints themselves (velocity Verlet,
/// fast projection): they evaluate no stage forces, so friction is an explicit force there, held
/// over the step (exact while it is constant, as on a plane; first order where it turns within a
/// step). `velocities`: 3 x numParticles() [m/s]; dt [s]. Books friction's share of the kick's
/// energy change exactly, -dt f_t . (v_0 + v_1) / 2 with v_0, v_1 the velocities before and
/// after the whole kick (1/2 m (|v_1|^2 - |v_0|^2) = dt (f + f_t) . (v_0 + v_1) / 2: a stick,
/// whose friction cancels the applied force's slope, takes nothing out), into
/// StepControl::friction_kick_loss; not with a moving obstacle, whose slip is relative to its
/// point (the ledger's trapezoid there).
void kickForces(const Model& model, Data& data, double dt, Points& velocities);

/// Baraff's active set at data.state with the modes it has: a forward stage (data.accelerations,
/// multipliers, forces), then the contact with the most negative multiplier switched off, or a
/// sticking one whose friction demand is over 1 sliding, and solved again until neither is left.
/// `solved`: the last stage's report. False if it stopped at its iteration limit unsettled.
bool settleActiveSet(const Model& model, Data& data, const StepSettings& settings,
                     SolveReport& solved);

/// The active set at the state's start of a step: contacts within contactGap() and approaching
/// no faster than CONTACT_SPEED act (sticking if they slide slower than friction stops them in
/// one step, their tangential velocity then removed), then, solving at the state, the one with
/// the most negative multiplier is switched off, or a sticking one whose friction demand is over
/// 1 slides, until neither is left. Returns the kinetic energy the removed tangential velocities
/// took out [J] (the ledger's dissipation).
double chooseContactModes(const Model& model, Data& data, const StepSettings& settings);

/// Where in a sub-step of length h from positions `p0`, velocities `v0` to the state `x` the
/// first unilateral row that is off went in: the fraction s in (0, 1) of h at which its gap
/// (contact: height over its surface or obstacle; slack link: length less span) reaches -2
/// `tolerance` (just in: the piece to it ends with the row found) along
/// each particle's cubic Hermite path (positions and velocities at both ends: third order, as the
/// integrators' own paths are to their order), by bisection to 1e-12 of the sub-step. NaN where
/// no row off is in by more than `tolerance` at x, or every such row was already in at p0 (its
/// impact is at the sub-step's start: resolveImpacts takes it as it is). The impacts can then be
/// met at their time (takeContactSubstep): a particle found a sub-step late is depth d in,
/// and projecting it out lifts it by d with the speed of falling that far kept, which adds
/// energy (m g d a bounce).
double impactFraction(const Model& model, Data& data, const Points& p0, const Points& v0,
                      const State& x, double h, double tolerance);

/// Where in a piece of a sub-step, from contact modes `at_start` (forces as its start's solve
/// left them) to the state `x`, the first acting contact should have left: one whose surface
/// curves away from its particle faster than the particle's free motion bends to it at x (J a0 +
/// Jdot v > 0: a convex stretch, an edge) is checked by a forward stage at x (the multipliers
/// there; `settings` its dt's), and one that pulls there (negative multiplier) was let go where
/// its normal force crossed 0, linearly between the start's and x's: that fraction in [0, 1) is
/// returned and the contact's index in `released` (the earliest). NaN where none pulls. A contact
/// is released only at a step's start otherwise (chooseContactModes), and was held on for the
/// rest of a step round an edge it reached in it (a ball sliding off a box's edge pulled round its
/// rounding, 6 cm off its fall by 0.4 s).
double releaseFraction(const Model& model, Data& data, const std::vector<ContactState>& at_start,
                       State& x, const StepSettings& settings, int& released);

/// Contact k off, its forces 0, and the rows so written (the state changed).
void releaseContact(const Model& model, Data& data, int k);

/// After a step's projection at `time`: each contact that is off and below its surface by more
/// than the projection tolerance is switched on and the state projected onto the rows
/// (positions, then velocities: the inelastic impulse), then for contacts with restitution e and
/// an approach speed over BOUNCE_SPEED the impulse is scaled by 1 + e and the contact switched
/// off again. Returns the energy the impacts took out [J] (T + U before less after).
double resolveImpacts(const Model& model, Data& data, const StepSettings& settings, State& state);

/// Impacts and releases met at their time in one sub-step at most (takeContactSubstep); any
/// later one is met at the sub-step's end.
constexpr int MAX_IMPACT_SPLITS = 8;

// ---- contact as a phase of the step (docs/architecture.md, "A step with contacts") ----
// Simulator calls each of these at its place in every step, with contacts or without; in a
// model with no unilateral rows each is a no-op (or takes the sub-step as it is), so the step
// branches on contacts only here (it still reads whether there are any where it chooses a
// forward stage and whether its multipliers are current).

/// The step's start: the active set (chooseContactModes), the kinetic energy a stick took out
/// booked as dissipation, and whether the state's last solve still stands (it does unless a
/// stick changed the velocities).
void startContactStep(const Model& model, Data& data, const StepSettings& settings);

/// An attempt's start, or a step put back: the contacts' modes the step started with
/// (StepControl::start_contacts) written into the rows, and no impact loss yet.
void restoreStartContacts(const Model& model, Data& data);

/// The contacts' part of the ledger's powers at `x` [W]: friction only dissipates, against the
/// slip (`friction`); on a moving obstacle a contact's force (a particle's normal and friction, a
/// segment's normal) does work through the obstacle's point, put in by its holder (`in`).
void addContactPowers(const Model& model, const Data& data, const State& x, double& in,
                      double& friction);

/// One sub-step of length h ending at `end` with its contact events: `take_piece(length, end)`
/// advances data.state by one piece (the integrator, then projection); without contacts that is
/// all. With contacts, a row that the piece takes in (impactFraction) or an acting contact that
/// should have let go (releaseFraction) is met at its time: the piece is taken again to there,
/// the impact resolved or the contact released, and the rest taken from it, at most
/// MAX_IMPACT_SPLITS times; what is still in at the end is resolved as it is. `start`: the
/// step's start (kept whole where a step may be retaken: `at_step_start`, the step's first
/// sub-step with max_substeps > 1); `sub`: the sub-step's settings (resolveImpacts reads its
/// dt); the impacts' energy goes into StepControl::contact_loss.
template <typename TakePiece>
void takeContactSubstep(const Model& model, Data& data, const State& start, bool at_step_start,
                        double h, double end, const StepSettings& sub, double tolerance,
                        TakePiece&& take_piece)
{
  if (model.numContacts() == 0)
  {
    take_piece(h, end);
    return;
  }
  State& x = data.state;
  StepControl& control = data.control;
  double from = x.time, length = h;
  // the piece's start: a step's first sub-step starts where the step did, and the step's start
  // is kept whole where it may be retaken (no copy then); a later one's is copied
  const State* piece_start = at_step_start ? &start : &control.piece_start;
  const std::vector<ContactState>* piece_contacts =
      at_step_start ? &control.start_contacts : &control.piece_contacts;
  if (!at_step_start)
  {
    control.piece_start.positions = x.positions;
    control.piece_start.velocities = x.velocities;
    control.piece_contacts = data.contacts;
  }
  for (int split = 0;; ++split)
  {
    // a piece put back fails no check of the attempt (a projection it did not converge, a
    // singular solve, a forced internal step): those flags are the piece's start's again; its
    // work stays counted (it was done)
    const StepStatistics& now = data.statistics;
    const bool solve_singular = now.solve.singular, converged = now.projection.converged,
               projection_singular = now.projection.singular;
    const long forced = now.forced_internal_steps;
    const double kicked = control.friction_kick_loss;  // the friction kicks' loss before it
    take_piece(length, end);
    // the piece is taken again to the first event in it: an impact, or a contact that should
    // have let go (its force crossing 0) and was held on
    double fraction = NAN;
    int released = -1;
    if (split < MAX_IMPACT_SPLITS)
    {
      fraction = impactFraction(model, data, piece_start->positions, piece_start->velocities, x,
                                length, tolerance);
      const double release = releaseFraction(model, data, *piece_contacts, x, sub, released);
      if (release < fraction || (std::isnan(fraction) && release < 1.0))
        fraction = release;
      else
        released = -1;
    }
    if (!(fraction < 1.0))
      break;
    x.positions = piece_start->positions;
    x.velocities = piece_start->velocities;
    x.time = from;
    data.statistics.solve.singular = solve_singular;
    data.statistics.projection.converged = converged;
    data.statistics.projection.singular = projection_singular;
    data.statistics.forced_internal_steps = forced;
    control.friction_kick_loss = kicked;
    data.contacts = *piece_contacts;
    writeContactRows(model, data);
    data.noteStateChange();
    const double at = from + fraction * length;
    if (fraction > 0.0)
      take_piece(fraction * length, at);
    if (released >= 0)
      releaseContact(model, data, released);
    else
      control.contact_loss += resolveImpacts(model, data, sub, x);
    length = end - at;
    from = at;
    control.piece_start.positions = x.positions;
    control.piece_start.velocities = x.velocities;
    control.piece_contacts = data.contacts;
    piece_start = &control.piece_start;
    piece_contacts = &control.piece_contacts;
  }
  // what is still in (a row in at the sub-step's start, or past the splits): as it is
  control.contact_loss += resolveImpacts(model, data, sub, x);
}

}  // namespace constrained_particles
