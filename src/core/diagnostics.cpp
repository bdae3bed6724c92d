#include "constrained_particles/core/diagnostics.hpp"

#include "stages.hpp"

#include <algorithm>
#include <cmath>

namespace constrained_particles
{
namespace
{
// |f_i|, one term of sum |f_i|: forceNormSum and stepCheckSums sum the same terms in the same
// order, so the sum kept under gravity alone is the one the check would sweep
inline double forceNorm(const double* fi)
{
  return std::sqrt(fi[0] * fi[0] + fi[1] * fi[1] + fi[2] * fi[2]);
}
}  // namespace

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
  return stepCheckSums(model, state, forces).scale;
}

double forceNormSum(const Points& forces)
{
  double sum = 0.0;
  const double* f = forces.data();
  for (Eigen::Index i = 0; i < forces.cols(); ++i)
    sum += forceNorm(f + 3 * i);
  return sum;
}

StepCheckSums stepCheckSums(const Model& model, const State& state, const Points& forces,
                            const double* force_sum)
{
  StepCheckSums sums;
  const int n = model.numParticles();
  const double* masses = model.scene().masses.data();
  const double* p = state.positions.data();
  const double* v = state.velocities.data();
  const double* f = forces.data();
  // x - x is 0 for a finite x and NaN otherwise: a probe is NaN if any value is not finite (so
  // never build this with -ffast-math or -ffinite-math-only, which may fold it to 0)
  double probe_p = state.time - state.time, probe_v = 0.0;
  double kinetic = 0.0, force = 0.0, momentum[3] = { 0.0, 0.0, 0.0 };
  const bool isolated = model.isolated();
  double low[3] = { 0.0, 0.0, 0.0 }, high[3] = { 0.0, 0.0, 0.0 };
  if (n > 0)
    for (int c = 0; c < 3; ++c)
      low[c] = high[c] = p[c];
  const bool sum_forces = force_sum == nullptr;
  for (int i = 0; i < n; ++i)
  {
    const double *pi = p + 3 * i, *vi = v + 3 * i, *fi = f + 3 * i;
    probe_p += (pi[0] - pi[0]) + (pi[1] - pi[1]) + (pi[2] - pi[2]);
    probe_v += (vi[0] - vi[0]) + (vi[1] - vi[1]) + (vi[2] - vi[2]);
    // kineticEnergy's and energyScale's sums, term for term
    kinetic += 0.5 * masses[i] * (vi[0] * vi[0] + vi[1] * vi[1] + vi[2] * vi[2]);
    if (sum_forces)  // forceNormSum's terms, in its order
      force += forceNorm(fi);
    if (isolated)
      for (int c = 0; c < 3; ++c)
        momentum[c] += masses[i] * vi[c];
    for (int c = 0; c < 3; ++c)
    {
      low[c] = pi[c] < low[c] ? pi[c] : low[c];
      high[c] = pi[c] > high[c] ? pi[c] : high[c];
    }
  }
  if (!sum_forces)
    force = *force_sum;
  sums.finite = probe_p == 0.0 && probe_v == 0.0;
  sums.kinetic = kinetic;
  const double dx = high[0] - low[0], dy = high[1] - low[1], dz = high[2] - low[2];
  // an isolated scene's centre of mass falls freely: its |P|^2 / 2M is no energy the motion
  // about it can exchange (at 8 m of fall it made the tolerance 80 times that motion's)
  const double centre =
      isolated
          ? (momentum[0] * momentum[0] + momentum[1] * momentum[1] + momentum[2] * momentum[2]) /
                (2.0 * model.totalMass())
          : 0.0;
  // >= 0 but for rounding; 1e-9 of the centre's kept, so T's own rounding (about n 1e-16 of it)
  // stays inside the tolerance of a scene that only drifts
  const double internal = std::max(kinetic - centre, 0.0) + 1e-9 * centre;
  sums.scale = n > 0 ? internal + force * std::sqrt(dx * dx + dy * dy + dz * dz) : 0.0;
  return sums;
}

Diagnostics computeDiagnostics(const Model& model, const State& state,
                               const std::vector<AnchorTrack>* tracks,
                               const std::vector<AnchorTrack>* carriers)
{
  RowData rows;
  rows.resize(model);
  Eigen::VectorXd rates;
  return computeDiagnostics(model, state, rows, rates, tracks, carriers);
}

Diagnostics computeDiagnostics(const Model& model, const State& state, RowData& rows,
                               Eigen::VectorXd& rates, const std::vector<AnchorTrack>* tracks,
                               const std::vector<AnchorTrack>* carriers)
{
  Diagnostics d;
  const Scene& scene = model.scene();
  const EffectContext context{ scene.surfaces, state.time, nullptr, carriers };
  evaluateRowRecords(model, state.time, state.positions, state.velocities, rows, nullptr, true,
                     nullptr, carriers);
  d.max_position_error = rows.max_violation;
  // a contact's error is how far below its surface it is, whether its row acts or not
  const auto& unilateral = model.unilateral();
  for (int k = 0; k < model.numParticleContacts(); ++k)
    d.max_position_error = worseError(d.max_position_error,
                                      penetration(model, unilateral[k], context, state.positions));
  // a link's capsule's, how far inside its obstacle it is
  for (const auto& segment : std::get<std::vector<KindRecord<SegmentContact>>>(model.kindTables()))
    d.max_position_error =
        worseError(d.max_position_error, penetration(segment.record, context, state.positions));
  // two links' capsules', how deep in each other they are
  for (const auto& pair : std::get<std::vector<KindRecord<LinkPairContact>>>(model.kindTables()))
    d.max_position_error =
        worseError(d.max_position_error, penetration(pair.record, state.positions));
  // a slack link's, how far over its length it is, taut or slack
  for (const auto& link : std::get<std::vector<KindRecord<SlackLink>>>(model.kindTables()))
    d.max_position_error =
        worseError(d.max_position_error, overstretch(link.record, state.positions));
  rates.resize(model.numRows());
  for (const RowRecord& record : model.rowRecords())
    violationRates(scene.constraints[record.constraint], context, state.positions, state.velocities,
                   rates.data() + record.first_row);
  for (int r = 0; r < model.numRows(); ++r)
    d.max_velocity_error = worseError(d.max_velocity_error, rates[r]);
  for (int k : model.eliminated())
  {
    const Constraint& constraint = scene.constraints[k];
    if (!tracks && isTracked(constraint))
      continue;  // its path is not known here: imposed exactly at every stage all the same
    const int i = eliminatedParticle(constraint);
    static const std::vector<AnchorTrack> NO_TRACKS;  // an lvalue: the tracks are not copied
    const ImposedMotion motion =
        imposedMotion(constraint, state.time, tracks ? *tracks : NO_TRACKS);
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
