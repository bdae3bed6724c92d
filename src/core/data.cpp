#include "constrained_particles/core/data.hpp"

#include <algorithm>

#include "contact.hpp"
#include "fixed_point.hpp"
#include "integrators/dopri5.hpp"
#include "solvers/solver.hpp"

namespace constrained_particles
{
void RowData::resize(const Model& model)
{
  const int m = model.numRows();
  value.setZero(m);
  jdot_v.setZero(m);
  violation.setZero(m);
  diagonal.setZero(m);
  velocity.setZero(m);
  time_rate.setZero(m);
  bias.setZero(m);
  jacobian.assign(model.numBlocks(), Vec3::Zero());
  max_violation = 0.0;
  // every contact starts off: the contact stage switches on those that touch (contact.hpp)
  inactive.assign(model.numContacts() > 0 ? m : 0, 0);
  for (const UnilateralRecord& record : model.unilateral())
    inactive[record.row] = 1;
}

Data::Data(const Model& model) : solver_(makeSolver(model))
{
  const int n = model.numParticles();
  state.positions.setZero(3, n);
  state.velocities.setZero(3, n);
  rows.resize(model);
  trial_rows.resize(model);
  applied_forces.setZero(3, n);
  free_accelerations.setZero(3, n);
  imposed.assign(model.eliminated().size(),
                 ImposedMotion{ Vec3::Zero(), Vec3::Zero(), Vec3::Zero() });
  tracks.assign(model.tracked().size(), AnchorTrack());
  carriers.assign(
      model.carriers().size(),
      AnchorTrack());  // at rest: each shape at its pose  // Simulator rests them at the start
  contacts.assign(model.numContacts(), ContactState{});
  control.start_contacts = contacts;
  control.step_normal_forces.assign(model.numContacts(), 0.0);
  const int contact_n = model.numContacts() > 0 ? n : 0;
  control.piece_contacts = contacts;
  control.piece_start.positions.setZero(3, contact_n);
  control.piece_start.velocities.setZero(3, contact_n);
  control.impact_positions.setZero(3, contact_n);
  friction_forces.setZero(3, contact_n);
  friction_accelerations.setZero(3, contact_n);
  frictionless_multipliers.setZero(model.numContacts() > 0 ? model.numRows() : 0);
  contact_rhs.setZero(model.numContacts() > 0 ? model.numRows() : 0);
  impact_impulses.setZero(model.numContacts() > 0 ? model.numRows() : 0);
  friction_iterate.setZero(3 * model.numParticleContacts());
  friction_image.setZero(3 * model.numParticleContacts());
  friction_mixed.setZero(3 * model.numParticleContacts());
  resizeHistory(friction_history, 3 * model.numParticleContacts(), FRICTION_HISTORY);
  const int carried_contacts = model.hasCarriers() ? model.numParticleContacts() : 0;
  contact_relative_velocities.setZero(3, carried_contacts);
  contact_surface_accelerations.setZero(3, carried_contacts);
  constraint_forces.setZero(3, n);
  accelerations.setZero(3, n);
  multipliers.setZero(model.numMultipliers());
  rhs.setZero(model.numRows());
  fused.lower.setZero(std::max(model.numRows() - 1, 0));
  fused.inverse_pivots.setZero(model.numRows());
  fused.velocity_rhs.setZero(model.numRows());
  fused.pending.setZero(3, model.fusedChain() ? n : 0);
  fused.chain_jacobian.assign(model.fusedChain() ? model.numRows() : 0, Vec3::Zero());
  const bool tree = !model.treeLinks().empty();  // fused trees and contact trees
  fused.tree_jacobian.setZero(3, tree ? model.numRows() : 0);
  fused.clique_lower.assign(tree ? model.treeCliqueEntries() : 0, 0.0);
  for (Points* buffer : { &stages.a_stage, &stages.a_midpoint, &stages.sum_p, &stages.sum_v,
                          &stages.p_stage, &stages.v_stage, &stages.p_start, &stages.correction,
                          &stages.change, &stages.p_unprojected, &stages.zero })
    buffer->setZero(3, n);
  statistics.solve.method = model.solveMethod();
  control.start = state;
  control.stiffness.setZero(n);
}

Data::~Data() = default;

}  // namespace constrained_particles
