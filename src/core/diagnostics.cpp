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
  Diagnostics d;
  const Scene& scene = model.scene();
  std::vector<ConstraintRow> rows;
  evaluateRows(model, state.positions, state.velocities, rows);
  // std::max would drop a NaN: keep it visible
  auto worst = [](double current, double value)
  { return (std::isnan(value) || value > current) ? value : current; };
  for (const ConstraintRow& row : rows)
  {
    d.max_position_error = worst(d.max_position_error, row.metric_error);
    d.max_velocity_error = worst(d.max_velocity_error, row.metric_rate);
  }
  for (int k : model.pins())
  {
    const PinConstraint& pin = std::get<PinConstraint>(scene.constraints[k]);
    d.max_position_error =
        worst(d.max_position_error, (state.positions.col(pin.particle) - pin.anchor).norm());
    d.max_velocity_error = worst(d.max_velocity_error, state.velocities.col(pin.particle).norm());
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
