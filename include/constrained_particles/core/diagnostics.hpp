/// @file diagnostics.hpp
/// @brief Constraint errors and energies of a state.
#pragma once

#include "constrained_particles/core/data.hpp"
#include "constrained_particles/core/model.hpp"

namespace constrained_particles
{
/// How far a state is from its constraints, and its energy.
struct Diagnostics
{
  double max_position_error = 0;  ///< max over rows' metric errors and |p_i - p_imposed| [m]
  double max_velocity_error = 0;  ///< max over rows' metric rates and |v_i - v_imposed| [m/s]
  double kinetic_energy = 0;      ///< sum 1/2 m |v|^2 [J]
  double potential_energy = 0;    ///< sum of the conservative forces' potentials [J]

  double totalEnergy() const
  {
    return kinetic_energy + potential_energy;
  }
  /// True if every value is finite.
  bool finite() const;
};

/// Sum 1/2 m |v|^2 [J].
double kineticEnergy(const Model& model, const State& state);

/// Sum of the conservative forces' potentials at a state [J], without the rows (cheap: one pass
/// over the forces).
double potentialEnergy(const Model& model, const State& state);

/// The energy a step could move about [J]: kinetic energy plus sum |f_i| D, the applied forces
/// `forces` (3 x n) [N] times the diagonal D of the particles' bounding box [m] (for gravity
/// M |g| D, the potential energy the scene could turn into motion). In an isolated scene
/// (Model::isolated()) the kinetic energy is that about the centre of mass, T - |P|^2 / 2M:
/// the centre's free fall exchanges nothing with the rest. The step checks' scale.
double energyScale(const Model& model, const State& state, const Points& forces);

/// What the step checks read of a state, from one sweep over its particles instead of three.
struct StepCheckSums
{
  bool finite = true;    ///< isFinite(state)
  double kinetic = 0.0;  ///< kineticEnergy(state) [J]
  double scale = 0.0;    ///< energyScale(state, forces) [J]; meaningless unless finite
};
/// isFinite, kineticEnergy and energyScale of `state` with the applied `forces` (3 x n) [N], the
/// same sums in the same order (so the same values) as those three give. `force_sum`: sum |f_i|
/// [N] if the caller knows it (Data::gravity_force_sum), else summed here.
StepCheckSums stepCheckSums(const Model& model, const State& state, const Points& forces,
                            const double* force_sum = nullptr);

/// sum |f_i| [N] of `forces` (3 x n), in energyScale's order.
double forceNormSum(const Points& forces);

/// Evaluates the diagnostics of a state of the model. Allocates its row workspace. Tracked
/// records (frame anchors) are measured against `tracks` (Data::tracks; none: not measured);
/// carried shapes are where `carriers` puts them (Data::carriers; none: at their own poses).
Diagnostics computeDiagnostics(const Model& model, const State& state,
                               const std::vector<AnchorTrack>* tracks = nullptr,
                               const std::vector<AnchorTrack>* carriers = nullptr);

/// As above, evaluating the rows into `rows` (sized for the model: no allocation) and the
/// rates into `rates` (m, resized once).
Diagnostics computeDiagnostics(const Model& model, const State& state, RowData& rows,
                               Eigen::VectorXd& rates,
                               const std::vector<AnchorTrack>* tracks = nullptr,
                               const std::vector<AnchorTrack>* carriers = nullptr);

}  // namespace constrained_particles
