#include "constrained_particles/core/diagnostics.hpp"

#include "stages.hpp"

#include <cmath>

namespace constrained_particles
{
bool Diagnostics::finite() const
{
  return std::isfinite(max_position_error) && std::isfinite(max_velocity_error) &&
         std::isfinite(kinetic_energy) && std::isfinite(potential_energy);
}

bool isFinite(const State& state)
{
  return state.positions.allFinite() && state.velocities.allFinite() && std::isfinite(state.time);
}

double kineticEnergy(const Model& model, const State& state)
{
  double kinetic = 0.0;
  const std::vector<double>& masses = model.scene().masses;
  for (int i = 0; i < model.numParticles(); ++i)
    kinetic += 0.5 * masses[i] * state.velocities.col(i).squaredNorm();
  return kinetic;
}

double potentialEnergy(const Model& model, const State& state)
{
  double energy = 0.0;
  for (const Force& force : model.scene().forces)
    energy += potentialEnergy(force, model.scene().masses, state.positions);
  return energy;
}

double energyScale(const Model& model, const State& state, const Points& forces)
{
  return energyScale(model, state, forces, kineticEnergy(model, state));
}

double energyScale(const Model& model, const State& state, const Points& forces, double kinetic)
{
  if (model.numParticles() == 0)
    return 0.0;
  const Vec3 extent = state.positions.rowwise().maxCoeff() - state.positions.rowwise().minCoeff();
  double force = 0.0;
  for (int i = 0; i < model.numParticles(); ++i)
    force += forces.col(i).norm();
  return kinetic + force * extent.norm();
}

Diagnostics computeDiagnostics(const Model& model, const State& state)
{
  RowData rows;
  rows.resize(model);
  Eigen::VectorXd rates;
  return computeDiagnostics(model, state, rows, rates);
}

Diagnostics computeDiagnostics(const Model& model, const State& state, RowData& rows,
                               Eigen::VectorXd& rates)
{
  Diagnostics d;
  const Scene& scene = model.scene();
  const EffectContext context{ scene.surfaces, state.time };
  evaluateRowRecords(model, state.time, state.positions, state.velocities, rows, nullptr);
  d.max_position_error = rows.max_violation;
  rates.resize(model.numRows());
  for (const RowRecord& record : model.rowRecords())
    violationRates(scene.constraints[record.constraint], context, state.positions, state.velocities,
                   rates.data() + record.first_row);
  for (int r = 0; r < model.numRows(); ++r)
    d.max_velocity_error = worseError(d.max_velocity_error, rates[r]);
  for (int k : model.eliminated())
  {
    const Constraint& constraint = scene.constraints[k];
    const int i = eliminatedParticle(constraint);
    const ImposedMotion motion = imposedMotion(constraint, state.time);
    d.max_position_error =
        worseError(d.max_position_error, (state.positions.col(i) - motion.position).norm());
    d.max_velocity_error =
        worseError(d.max_velocity_error, (state.velocities.col(i) - motion.velocity).norm());
  }
  d.kinetic_energy = kineticEnergy(model, state);
  d.potential_energy = potentialEnergy(model, state);
  return d;
}

}  // namespace constrained_particles
