/// @file contact_phase.cpp
/// @brief Contact as a phase of the step (contact.hpp): the step's start, an attempt's start and
/// a step put back, and the contacts' part of the energy ledger. Each is a no-op without
/// contacts, so Simulator calls them unconditionally.
#include "contact.hpp"

#include "stages.hpp"

#include "constrained_particles/core/constraints.hpp"

namespace constrained_particles
{
void startContactStep(const Model& model, Data& data, const StepSettings& settings)
{
  if (model.numContacts() == 0)
    return;
  // the active set at the step's start; stopping a sticking contact's slide is dissipation
  data.ledger.dissipated += chooseContactModes(model, data, settings);
  // its last solve is the state's (forwardAtState's), unless a stick changed the velocities
  data.control.multipliers_current = data.control.forward_version == data.stateVersion();
  data.control.end_energies_current = false;
}

void restoreStartContacts(const Model& model, Data& data)
{
  if (model.numContacts() == 0)
    return;
  data.contacts = data.control.start_contacts;
  writeContactRows(model, data);
  data.control.contact_loss = data.control.friction_kick_loss = 0.0;
  data.control.friction_kicked = false;
}

void addContactPowers(const Model& model, const Data& data, const State& x, double& in,
                      double& friction)
{
  // friction, at its last stage's value (contact.hpp; the step start's under velocity Verlet and
  // fast projection; a contact off holds none): it only dissipates, against the slip
  const auto& contacts = model.unilateral();
  const EffectContext context = contextAt(model, data, x.time);
  for (int k = 0; k < model.numParticleContacts(); ++k)
  {
    const ContactState& contact = data.contacts[k];
    const Vec3 v = x.velocities.col(contacts[k].particles[0]);
    if (!model.hasCarriers() || contact.mode == ContactMode::Separated)
    {
      friction -= contact.friction_force.dot(v);
      continue;
    }
    // on a moving obstacle the slip is relative to its point, and the contact force (normal and
    // friction) does work through that point's motion: the obstacle's holder puts it in
    const ContactFrame frame = contactFrame(model, contacts[k], context, x.positions, x.velocities);
    const Vec3 force = contact.normal_force * frame.normal.normalized() + contact.friction_force;
    friction -= contact.friction_force.dot(frame.relative(v));
    in += force.dot(frame.surface_velocity);
  }
  // a segment's normal force on a moving obstacle likewise (frictionless)
  for (int k = model.numParticleContacts(); model.hasCarriers() && k < model.numContacts(); ++k)
  {
    if (contacts[k].kind != UnilateralKind::SegmentContact ||
        data.contacts[k].mode == ContactMode::Separated)
      continue;
    const SegmentFrame s = segmentFrame(unilateralRecord<SegmentContact>(model, contacts[k]),
                                        context, x.positions, x.velocities);
    in += data.contacts[k].normal_force * s.frame.normal.dot(s.frame.surface_velocity);
  }
}

}  // namespace constrained_particles
