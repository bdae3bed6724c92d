/// @file data.hpp
/// @brief Data: everything that changes while a Model runs (MuJoCo's mjData), allocated once
/// when it is made so that a steady step allocates nothing (but inside Eigen's sparse
/// factorisation, and dopri5's workspace on its first step). Shapes: n particles, m rows, b
/// Jacobian blocks, e eliminated records (model.hpp).
#pragma once

#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/statistics.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace constrained_particles
{
class ConstraintSolver;  // src/core/solvers/solver.hpp: the factorisation of J W J^T
struct Dopri5Workspace;  // src/core/integrators/dopri5.cpp: Boost.Odeint's stepper and state

/// Constraint rows evaluated at one state.
struct RowData
{
  Eigen::VectorXd value;      ///< C (m): [C] = [m] surface, line, plane; [m^2] link; [rad] angle
  Eigen::VectorXd jdot_v;     ///< Jdot v (m), [C]/s^2
  Eigen::VectorXd violation;  ///< metric position error of each row (m) [m]
  Eigen::VectorXd diagonal;   ///< (J W J^T)_rr, each row's own mobility (m), [C]^2/(kg m^2)
  Eigen::VectorXd velocity;   ///< Cdot = J v + dC/dt (m), [C]/s
  /// dC/dt at fixed positions (m), [C]/s: non-zero only on rows against a moving body (a carried
  /// shape's contact), 0 on an inactive row
  Eigen::VectorXd time_rate;
  Eigen::VectorXd bias;        ///< Baumgarte term 2 zeta omega Cdot + omega^2 C (m), [C]/s^2
  std::vector<Vec3> jacobian;  ///< dC/dp blocks (b), [C]/m, row r's from model.rowStart()[r]
  double max_violation = 0.0;  ///< largest violation [m], infinite if any is NaN
  /// Rows the contact stage has switched off (m, 1 = off; empty in scenes without contacts):
  /// evaluated as zero (C, J, Jdot v, violation), and solved as identity rows, so their
  /// multiplier is 0 and the others' solve is the one without them.
  std::vector<std::uint8_t> inactive;

  /// Sized for the model's rows and blocks, zeroed.
  void resize(const Model& model);
};

/// What a particle contact (surface_contact, shape_contact) or slack link does during a step
/// (contact.hpp): the contact stage's choice at the step's start, kept through its stages.
enum class ContactMode : std::uint8_t
{
  Separated,  ///< its rows are off: above the surface, leaving it, or pulled from it
  Sliding,    ///< the row acts (lambda_n >= 0); friction mu |f_n| against the slip
  Sticking,   ///< the row acts; friction cancels the tangential force, up to mu |f_n|
};

/// One unilateral row's state (Model::numContacts(), in Model::unilateral()'s order).
struct ContactState
{
  ContactMode mode = ContactMode::Separated;
  /// Unit direction of the friction force while sliding slower than CONTACT_SPEED: the holding
  /// force's when it began to slip (then -v_t^ as it moves)
  Vec3 slip_direction = Vec3::Zero();
  double normal_force = 0.0;           ///< |f_n| = lambda_n |J_n| at the last stage [N]
  Vec3 friction_force = Vec3::Zero();  ///< f_t at the last stage [N]
  /// Sticking: the friction the particle needs to stay, over mu |f_n| (> 1: it slips)
  double friction_demand = 0.0;
  /// Switched on only to lift its particle out (resolveImpacts: in, but moving out)
  bool lifting = false;
  /// Switched on by an impact this round, with friction: its slip meets an impulse
  /// (resolveImpacts)
  bool landing = false;
};

/// Stage buffers of the integrators, by name, each 3 x n.
struct StageBuffers
{
  /// accelerations of the stage being evaluated [m/s^2] (RK4: of stages 2 to 4, stage 1's go
  /// straight into sum_v; the Euler methods, midpoint's first stage, dopri5's right-hand side)
  Points a_stage;
  Points a_midpoint;  ///< midpoint's second-stage accelerations [m/s^2] (its first are a_stage)
  Points sum_p;    ///< RK4's running weighted sum v1 + 2 v2 + 2 v3 of its stages' velocities [m/s]
  Points sum_v;    ///< RK4's running weighted sum a1 + 2 a2 + 2 a3 of its accelerations [m/s^2]
  Points p_stage;  ///< positions of the stage being evaluated [m]
  Points v_stage;  ///< velocities of the stage being evaluated [m/s]
  Points p_start;  ///< positions at the start of the step [m] (SHAKE's reference)
  Points correction;     ///< displacement SHAKE applied in this step [m]
  Points change;         ///< velocity change of a projection [m/s]
  Points p_unprojected;  ///< positions before SHAKE's fallback to full projection [m]
  Points zero;           ///< zeros: the velocities of position-only evaluations
};

/// What the step's checks and sub-steps carry from one step to the next (simulator.hpp).
struct StepControl
{
  /// The state the step being taken started from: its time only where no step is retaken
  /// (max_substeps = 1), the whole state otherwise.
  State start;
  Eigen::VectorXd stiffness;  ///< the stability estimate's workspace (n) [N/m]
  /// The largest violation at the last sub-step's end as its projection measured it [m]; -1
  /// where no projection ran (another stabilisation, an integrator holding the constraints)
  double end_position_error = -1.0;
  int rejection_substeps = 1;        ///< sub-steps the last rejection asked for; relaxes back
  int accepted_since_rejection = 0;  ///< steps accepted since it was last changed
  bool singular = false;             ///< the last accepted step had a singular solve
  bool multipliers_current = false;  ///< `multipliers` are of the last step's last stage
  double start_kinetic = 0.0;        ///< kinetic energy at `start` [J] (conservative scenes)
  double start_potential = 0.0;      ///< potential energy at `start` [J]
  double start_scale = 0.0;          ///< energyScale() at `start` [J]
  /// The last accepted step's end energies (kinetic, potential [J], scale [J]) are those of the
  /// current state and applied forces: the next step starts from them instead of a sweep. Cleared
  /// by anything that writes the state or the applied forces between steps.
  bool end_energies_current = false;
  double end_kinetic = 0.0, end_potential = 0.0, end_scale = 0.0;
  /// The residual the budget judged (Simulator::budgetResidual) and its scale
  /// (EnergyLedger::budgetScale) at the last step that overdrew it [J] (the fallback's warning's or
  /// the fault's message: the step itself is put back, and the ledger with it).
  double budget_failure_residual = 0.0, budget_failure_scale = 0.0;
  /// The method whose step overdrew it and handed the run to the fallback (the integrator, or
  /// the stiff-safe method where the stability estimate chose it for a stiff step)
  std::string budget_handed_by;
  /// The integrator overdrew the energy budget: the stiff-safe method (STIFF_FALLBACK) retook
  /// that step and takes every step until the ledger is opened again or the settings change.
  bool budget_fallback = false;
  /// The ledger's residual [J] and time [s] the energy budget judges from: 0 and t0 when the ledger
  /// opens; where the fallback took the run over, or new step settings took it from the fallback
  /// (setStepSettings), what the run had gained then: each method is judged by what it gains
  /// itself, a whole budget (Simulator::budgetResidual), not for what another gained before it
  double budget_base_residual = 0.0;
  double budget_base_time = 0.0;
  /// The contacts' modes at `start` (attempts start from them again)
  std::vector<ContactState> start_contacts;
  /// Each contact's normal force the last accepted step left [N] (its last stage's; velocity
  /// Verlet's and fast projection's, which solve no stages: its start's), which the next step's
  /// stick test reads (chooseContactModes): an evaluation between steps (forwardAtState, whenever
  /// a caller asks for forces) settles data.contacts anew and must not steer the motion
  std::vector<double> step_normal_forces;
  /// Energy the contacts' velocity jumps (impacts) took out in this attempt [J], for the ledger
  double contact_loss = 0.0;
  /// Energy the friction kicks of this attempt took out [J] (kickForces: velocity Verlet's and
  /// fast projection's friction, held over the step), booked as it is where `friction_kicked`
  bool friction_kicked = false;
  double friction_kick_loss = 0.0;
  /// A sub-step split at an impact (takeContactSubstep, contact.hpp): the state and contact modes
  /// the piece being taken started from, and the positions the time of impact is sought along
  /// (impactFraction, contact.hpp); sized once, with contacts only
  State piece_start;
  std::vector<ContactState> piece_contacts;
  Points impact_positions;
  /// The contact stage's last forward stage, at the state and time a step starts from
  /// (chooseContactModes, with the modes it chose): a step's first stage there finds its rows,
  /// multipliers, forces and Data::accelerations made, and solves nothing (counted as a reused
  /// factorisation). Valid while Data::stateVersion() is the one it was taken at (0: none), once.
  std::uint64_t forward_version = 0;
  double forward_time = 0.0;   ///< its time [s]
  SolveReport forward_report;  ///< its solve's report
  /// Friction fixed points stopped short (contactForceStage: stalled, or at
  /// MAX_FRICTION_ITERATIONS) since Simulator::step() last took them into
  /// StepStatistics::unconverged_friction (stalled ones too)
  long unconverged_friction = 0;
  double budget_fallback_time = 0.0;  ///< the start of the step it began with [s]
};

/// The run's energy account since t0, the last reset, setState, restoreState or change of the
/// scene's forces, constraints, surfaces or obstacles (Simulator::energyLedger()), kept on every
/// accepted step of every scene: residual() = E(t) - E(t0) - work_in + dissipated, zero for the
/// exact motion. The work of the non-conservative forces is booked by the trapezoidal rule over
/// each step (second order in dt; friction kicked from the step's start as the kick takes it:
/// StepControl::friction_kick_loss); the projections' velocity corrections and fast projection's
/// losses are not booked, so they show in the residual, as losses. docs/physics.md, "The energy
/// ledger".
struct EnergyLedger
{
  double t0 = 0.0;               ///< when it was opened [s]
  double initial_energy = 0.0;   ///< E(t0) = T + U [J]
  double initial_kinetic = 0.0;  ///< T(t0) [J]
  double scale = 0.0;            ///< energyScale() at t0 [J]: what the residual is measured in
  double kinetic = 0.0;          ///< T at the current state [J]
  double potential = 0.0;        ///< U of the conservative forces at the current state [J]
  /// integral of f . v of external forces, drags and driven anchors (their reactions) [J]
  double work_in = 0.0;
  /// -integral of f . v of damping, drag and friction, and the impacts' losses [J] (a lift out
  /// of a surface, booked with the impacts, lowers it)
  double dissipated = 0.0;
  double work_in_moved = 0.0;  ///< integral of |f . v| of the work-in forces [J], >= 0
  /// the most the motion has exchanged since t0, max |T - T(t0)| + |U - U(t0)| [J]: a bead
  /// released from rest has no scale of its own at t0
  double exchanged = 0.0;
  double power_in = 0.0;          ///< f . v of the work-in forces at the current state [W]
  double power_dissipated = 0.0;  ///< -f . v of damping and drag at the current state [W]
  double power_friction = 0.0;    ///< -f . v_slip of the contacts' friction now [W]

  /// E(t) - E(t0) - work_in + dissipated [J]
  double residual() const
  {
    return kinetic + potential - initial_energy - work_in + dissipated;
  }
  /// What the residual is measured against [J]: the scale at t0 plus the energy the motion has
  /// exchanged and that flowed in and out since, at least `floor`.
  double budgetScale(double floor) const
  {
    return std::max(scale + exchanged + work_in_moved + dissipated, floor);
  }
};

/// The last fused projection's factorisation of J W J^T, kept for the next forward stage at the
/// same positions and time (a step's first), which then solves with it instead of factorising
/// again. One rule keeps it honest (Drake's NoteContinuousStateChange): it is valid while
/// Data::stateVersion() is the one it was taken at; every write of the state outside the fused
/// stages bumps that (Data::setState, Data::noteStateChange), and the stage that takes it uses it
/// once.
struct FactorizationCache
{
  std::uint64_t state_version = 0;  ///< Data::stateVersion() it was taken at; 0: none kept
  double time = 0.0;                ///< its time [s] (eliminated motion imposed then)
  double min_pivot_ratio = 1.0;     ///< its smallest pivot / diagonal entry
};

/// An Anderson-accelerated fixed point's memory (fixed_point.hpp): the last iterate x and its
/// residual r = G(x) - x, and the differences of the last few of each (dimension x depth).
struct FixedPointHistory
{
  Eigen::VectorXd last_x, last_r;  ///< the iterate before and its residual
  Eigen::MatrixXd dx, dr;          ///< columns: x_{j+1} - x_j and r_{j+1} - r_j, a ring
  int count = 0;                   ///< columns held (<= depth)
  int head = 0;                    ///< the ring's column to write next
  bool has_last = false;           ///< last_x and last_r hold an iterate
};

/// The fused stages' buffers (chain_stages.cpp, tree_stages.cpp).
struct FusedWorkspace
{
  /// LDL^T of J W J^T: a chain's L sub-diagonal (m - 1) and, on both paths, D^-1 (m); the
  /// projection's J v, forward- then back-substituted in place (m). The solver's own
  /// factorisation is not updated by them.
  Eigen::VectorXd lower, inverse_pivots, velocity_rhs;
  /// A chain's Jacobian (m) [C]/m: each row's first block (a link's d, its second being -d; a
  /// surface row's one), row after row, where Data::rows.jacobian keeps the generic blocks.
  std::vector<Vec3> chain_jacobian;
  /// A chain projection's corrections waiting for a particle's other row (3 x n) [m] or [m/s].
  Points pending;
  /// A tree's LDL^T by place in Model::treeOrder(): each link's d (3 x m) [m], read by its
  /// later clique-mates and the down sweeps, and the cliques' L entries
  /// (Model::treeCliqueEntries()); D^-1 in inverse_pivots, the right-hand sides, then lambda or
  /// mu, in Data::rhs and velocity_rhs, by place too.
  Points tree_jacobian;
  std::vector<double> clique_lower;
  /// lower, inverse_pivots and chain_jacobian (a tree's clique_lower, inverse_pivots and
  /// tree_jacobian) when they are of the state's positions.
  FactorizationCache factorization;
};

/// Everything that changes. Made for one model (Data(model)); valid while that model lives.
class Data
{
public:
  explicit Data(const Model& model);
  ~Data();
  // the solver keeps the model and these rows by address: a Data stays where it was made
  Data(const Data&) = delete;
  Data& operator=(const Data&) = delete;

  /// Positions, velocities (3 x n), time, steps. The step's stages write it in place; every other
  /// write goes through setState() or is followed by noteStateChange().
  State state;
  /// Replaces the state (a reset, a put-back, ~set_state) and notes the change.
  void setState(const State& replacement)
  {
    state = replacement;
    noteStateChange();
  }
  /// What was computed from the state before (FusedWorkspace::factorization) is no longer of it.
  void noteStateChange()
  {
    ++state_version_;
  }
  /// Counts the state's changes outside the fused stages; starts at 1 (0 means "none").
  std::uint64_t stateVersion() const
  {
    return state_version_;
  }
  /// Rows at the last evaluated stage; after a fused chain's forward stage or projection
  /// (chain_stages.cpp) only a surface row's C, Jdot v, diagonal and violation, and (after a
  /// projection) max_violation are of that stage (the fused stages keep their Jacobian in
  /// fused.chain_jacobian or fused.tree_jacobian; a fused tree's forward stage writes none of the
  /// rows, its projection max_violation only; a contact tree's writes its contacts' and surface
  /// rows, and its projection max_violation too); the rest is of the last evaluation that stored it
  /// (a generic stage or projection, SHAKE, a generic fallback). Read what a fused stage did not
  /// store through evaluateRowRecords.
  RowData rows;
  RowData trial_rows;     ///< rows at SHAKE's trial positions
  Points applied_forces;  ///< f at the last stage [N] (3 x n)
  /// applied_forces hold m g of the scene's only force, gravity, with no perturbation: what every
  /// stage would assign again (appliedForceStage). free_accelerations is then g on every free
  /// particle, so J a0 of a row between two free particles is d.g + (-d).g = 0 exactly, which
  /// the fused chain stages take without reading a0.
  bool applied_forces_are_gravity = false;
  /// sum |m_i g| [N] while applied_forces_are_gravity, summed as stepCheckSums sums sum |f_i|:
  /// the energy check's scale reads it instead of a square root per particle
  double gravity_force_sum = 0.0;
  /// a0 = W f at the last stage [m/s^2] (3 x n): g itself on every free particle under gravity
  /// alone (W (m g) is g but for rounding), 0 on eliminated particles (W = 0). The rows read
  /// J a0 and the accelerations are a0 + W f_c (appliedForceStage sets it with applied_forces).
  Points free_accelerations;
  /// Forces from outside the model, set between steps (MuJoCo's xfrc_applied and mouse
  /// perturbation): a push, a grabbed particle's target spring. Evaluated after the model's
  /// forces, and counted with them, only while set (Simulator::setPerturbations).
  std::vector<Force> perturbations;
  Points constraint_forces;            ///< J^T lambda plus eliminated reactions [N] (3 x n)
  Points accelerations;                ///< a = a0 + W J^T lambda [m/s^2] (3 x n)
  std::vector<ImposedMotion> imposed;  ///< each eliminated record's motion at the stage's time (e)
  /// Each tracked record's path (Model::tracked(), t), written between steps by whoever samples
  /// its holder (Simulator::tracks()); each rests at its particle's start until then.
  std::vector<AnchorTrack> tracks;
  /// The carried shapes' paths, one per Model::carriers() entry, written by whoever samples their
  /// holders (Simulator::carriers()): the holder frame's origin and orientation in time. Each
  /// rests at the identity (its shape at its own pose, in the world frame) until then.
  std::vector<AnchorTrack> carriers;
  /// Each unilateral row's mode and forces (Model::numContacts(); contact.hpp)
  std::vector<ContactState> contacts;
  /// The contact stage's buffers: friction forces [N] and W times them [m/s^2] (3 x n), the
  /// frictionless multipliers, a solve's right-hand side and an impact's impulses along the rows
  /// [N s per unit of the row's J] (m); empty without contacts
  Points friction_forces, friction_accelerations;
  Eigen::VectorXd frictionless_multipliers, contact_rhs, impact_impulses;
  /// The friction iteration's iterate, its image and the next iterate mixed from the last few,
  /// each particle contact's force stacked (3 x Model::numParticleContacts()) [N], and its
  /// Anderson memory (contact.hpp, fixed_point.hpp)
  Eigen::VectorXd friction_iterate, friction_image, friction_mixed;
  FixedPointHistory friction_history;
  /// With carried shapes, per particle contact (3 x Model::numParticleContacts(), else empty):
  /// its particle's velocity relative to the obstacle's point under it [m/s] and that point's
  /// acceleration [m/s^2] at the contact stage's state, evaluated once per stage
  Points contact_relative_velocities, contact_surface_accelerations;
  Eigen::VectorXd multipliers;  ///< lambda (m), then each eliminated reaction [N] (3 e)
  /// Right-hand side, then solution, of a solve (m); the fused projections solve in place in
  /// it and fused.velocity_rhs, so after one it holds the last check's forward-substituted C
  /// (the fused tree and contact tree stages by place in Model::treeOrder(), not by row).
  Eigen::VectorXd rhs;
  /// The fused stages' own buffers (ForwardPath::FusedChain, FusedTree, FusedContactTree): their
  /// Jacobian layout
  /// and LDL^T of J W J^T, which the generic rows and the solver do not hold.
  FusedWorkspace fused;
  StageBuffers stages;        ///< the integrators' buffers
  EffectCounters counters;    ///< evaluations since this data was made
  StepStatistics statistics;  ///< of the batch being stepped
  StepControl control;        ///< the step checks' and sub-steps' memory
  EnergyLedger ledger;        ///< the energy account since t0 (Simulator::energyLedger)

  /// The factorisation of J W J^T (src/core/solvers).
  ConstraintSolver& solver()
  {
    return *solver_;
  }
  /// dopri5's workspace, made on its first use (src/core/integrators/dopri5.cpp).
  std::unique_ptr<Dopri5Workspace>& dopri5()
  {
    return dopri5_;
  }

private:
  std::uint64_t state_version_ = 1;
  std::unique_ptr<ConstraintSolver> solver_;
  std::unique_ptr<Dopri5Workspace> dopri5_;
};

}  // namespace constrained_particles
