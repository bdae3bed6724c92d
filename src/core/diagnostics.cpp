#include "constrained_particles/core/diagnostics.hpp"

#include "constrained_particles/core/constraint_solver.hpp"

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
bool Diagnostics::finite() const
{
  return std::isfinite(max_position_error) && std::isfinite(max_velocity_error) &&
         std::isfinite(kinetic_energy) && std::isfinite(potential_energy);
}

Diagnostics computeDiagnostics(const Model& model, const State& state)
{
  std::vector<ConstraintRow> rows;
  return computeDiagnostics(model, state, rows);
}

Diagnostics computeDiagnostics(const Model& model, const State& state,
                               std::vector<ConstraintRow>& rows)
{
  Diagnostics d;
  const Scene& scene = model.scene();
  evaluateRows(model, state.positions, state.velocities, rows);
  for (std::size_t r = 0; r < rows.size(); ++r)
  {
    d.max_position_error = worseError(d.max_position_error, rows[r].metric_error);
    d.max_velocity_error = worseError(
        d.max_velocity_error,
        metricRate(scene.constraints[model.rowConstraints()[r]], rows[r], state.velocities));
  }
  for (int k : model.pins())
  {
    const PinConstraint& pin = std::get<PinConstraint>(scene.constraints[k]);
    d.max_position_error =
        worseError(d.max_position_error, (state.positions.col(pin.particle) - pin.anchor).norm());
    d.max_velocity_error =
        worseError(d.max_velocity_error, state.velocities.col(pin.particle).norm());
  }
  for (int i = 0; i < model.numParticles(); ++i)
    d.kinetic_energy += 0.5 * scene.masses[i] * state.velocities.col(i).squaredNorm();
  for (const Force& force : scene.forces)
    d.potential_energy += potentialEnergy(force, scene.masses, state.positions);
  return d;
}

bool isFinite(const State& state)
{
  return state.positions.allFinite() && state.velocities.allFinite() && std::isfinite(state.time);
}

}  // namespace constrained_particles
