#include "constrained_particles/core/stability.hpp"

#include "stages.hpp"

#include "constrained_particles/core/constraints.hpp"
#include "constrained_particles/core/forces.hpp"

#include <cmath>
#include <tuple>
#include <type_traits>

namespace constrained_particles
{
double estimateMaxFrequency(const Model& model, const Eigen::VectorXd& multipliers,
                            const Points& positions, double time, Eigen::VectorXd& stiffness,
                            const std::vector<Force>& perturbations,
                            const std::vector<AnchorTrack>* carriers)
{
  const Scene& scene = model.scene();
  const EffectContext context{ scene.surfaces, time, nullptr, carriers };
  stiffness.setZero(model.numParticles());
  // kind by kind through the model's tables (no variant dispatch per record: at 10 particles
  // that dispatch was half the estimate's cost); a particle's terms are summed by kind
  forEachRowTable(model,
                  [&](const auto& table)
                  {
                    for (const auto& entry : table)
                      addGeometricStiffness(entry.record, context, positions,
                                            multipliers.data() + entry.first_row, stiffness.data());
                  });
  // position-dependent forces (springs), the model's and those applied from outside
  for (const std::vector<Force>* forces : { &scene.forces, &perturbations })
    for (const Force& force : *forces)
      addForceStiffness(force, stiffness.data());
  const auto& w = model.inverseMasses();
  double squared = 0.0;
  // a NaN stiffness (non-finite state) is skipped here: the step's checks see that state
  for (int i = 0; i < model.numParticles(); ++i)
    squared = std::max(squared, w[i] * stiffness[i]);
  return std::sqrt(squared);
}

int stabilitySubsteps(double omega, double dt, double stability_limit, int max_substeps)
{
  const double allowed = STABILITY_SAFETY * stability_limit;
  int substeps = 1;
  // a NaN omega asks for nothing: the step's checks see what went wrong
  while (substeps < max_substeps && omega * dt > allowed * substeps)
    substeps *= 2;
  return std::min(substeps, max_substeps);
}

}  // namespace constrained_particles
