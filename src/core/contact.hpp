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
/// solve to a fixed point (Kaufman, Sueda, James, Pai 2008, staggered projections), so the
/// matrix stays J W J^T of the rows (symmetric, a chain's still a forest).
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/settings.hpp"

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
/// (StepStatistics::unconverged_friction); below it, a stall does not stop the iteration.
constexpr double FRICTION_REPORT_TOLERANCE = 1e-9;
/// The friction iteration stops, stalled, after two solves in a row whose change is over this
/// fraction of the one before (its multipliers solved for the friction kept): it has no fixed
/// point there (two sticking contacts joined by straight links; docs/physics.md, "Contact").
/// Where it converges, each change is about 0.75 of the last on test_contact's chains.
constexpr double FRICTION_STALL_RATIO = 0.98;

/// A contact touches if its gap is at most this [m]: 10 projection tolerances, so a contact the
/// projection holds on its surface is touching.
inline double contactGap(const StepSettings& settings)
{
  return 10.0 * settings.projection_tolerance;
}

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

/// velocities += dt W f_t, f_t each acting contact's friction force [N] as data.contacts hold it
/// (the step's start: chooseContactModes' solve). For the integrators that hold the constraints
/// themselves (velocity Verlet, fast projection): they evaluate no stage forces, so friction is
/// an explicit force there, held over the step (exact while it is constant, as on a plane; first
/// order where it turns within a step). `velocities`: 3 x numParticles() [m/s]; dt [s].
void kickFriction(const Model& model, const Data& data, double dt, Points& velocities);

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
/// met at their time (Simulator::attemptStep): a particle found a sub-step late is depth d in,
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

}  // namespace constrained_particles
