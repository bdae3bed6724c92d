/// @file diagnostics.hpp
/// @brief Constraint errors and energies of a state.
#pragma once

#include "constrained_particles/core/model.hpp"

namespace constrained_particles
{
/// How far a state is from its constraints, and its energy.
struct Diagnostics
{
  double max_position_error =
      0;  ///< max over constraints of ||p_i - p_j| - l|, |Z - z|, |p - a| [m]
  double max_velocity_error = 0;  ///< max over constraints of |dC/dt| in metric form [m/s]
  double kinetic_energy = 0;      ///< sum 1/2 m |v|^2 [J]
  double potential_energy = 0;    ///< sum -m g.p over gravity forces [J]

  double totalEnergy() const
  {
    return kinetic_energy + potential_energy;
  }
  /// True if every value is finite.
  bool finite() const;
};

/// Evaluates the diagnostics of a state of the model. Stateless.
Diagnostics computeDiagnostics(const Model& model, const State& state);

/// As above, evaluating the rows into `rows` (a workspace reused across calls: no allocation).
Diagnostics computeDiagnostics(const Model& model, const State& state,
                               std::vector<ConstraintRow>& rows);

/// True if every position and velocity is finite.
bool isFinite(const State& state);

}  // namespace constrained_particles
