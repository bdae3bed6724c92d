#include "constrained_particles/core/model.hpp"

#include <cstdlib>
#include <string>

namespace constrained_particles
{
namespace
{
void requireParticle(const std::string& field, int index, int num_particles)
{
  if (index < 0 || index >= num_particles)
  {
    throw InvalidInput(field, "= " + std::to_string(index) + ", must be a particle index in [0, " +
                                  std::to_string(num_particles - 1) + "]");
  }
}

// rows touching one particle in one slot, for structure checks
int rowParticle(const Scene& scene, int constraint, int slot)
{
  const Constraint& c = scene.constraints[constraint];
  if (const auto* surface = std::get_if<SurfaceConstraint>(&c))
    return slot == 0 ? surface->particle : -1;
  if (const auto* link = std::get_if<LinkConstraint>(&c))
    return slot == 0 ? link->first : link->second;
  return -1;
}

}  // namespace

const char* solveMethodName(SolveMethod method)
{
  switch (method)
  {
    case SolveMethod::Automatic:
      return "automatic";
    case SolveMethod::Tridiagonal:
      return "tridiagonal";
    case SolveMethod::Sparse:
      return "sparse";
    case SolveMethod::Dense:
      return "dense";
    case SolveMethod::None:
      return "none";
  }
  return "unknown";
}

Model Model::compile(const Scene& scene, SolveMethod method)
{
  const int n = static_cast<int>(scene.masses.size());
  if (n == 0)
    throw InvalidInput("masses", "is empty: a scene needs at least 1 particle");
  for (int i = 0; i < n; ++i)
    requirePositive("masses[" + std::to_string(i) + "]", scene.masses[i], "[kg]");
  for (std::size_t k = 0; k < scene.surfaces.size(); ++k)
    validateSurface(scene.surfaces[k], "surfaces[" + std::to_string(k) + "]");
  for (std::size_t k = 0; k < scene.forces.size(); ++k)
    validateForce(scene.forces[k], n, "forces[" + std::to_string(k) + "]");

  Model model;
  model.scene_ = scene;
  model.inverse_masses_.resize(n);
  for (int i = 0; i < n; ++i)
    model.inverse_masses_[i] = 1.0 / scene.masses[i];

  std::vector<bool> pinned(n, false);
  for (std::size_t k = 0; k < scene.constraints.size(); ++k)
  {
    const std::string field = "constraints[" + std::to_string(k) + "]";
    const Constraint& c = scene.constraints[k];
    if (const auto* surface = std::get_if<SurfaceConstraint>(&c))
    {
      requireParticle(field + ".particle", surface->particle, n);
      if (surface->surface < 0 || surface->surface >= static_cast<int>(scene.surfaces.size()))
      {
        throw InvalidInput(field + ".surface",
                           "= " + std::to_string(surface->surface) + ", must index one of the " +
                               std::to_string(scene.surfaces.size()) + " surfaces");
      }
      model.row_constraint_.push_back(static_cast<int>(k));
    }
    else if (const auto* link = std::get_if<LinkConstraint>(&c))
    {
      requireParticle(field + ".first", link->first, n);
      requireParticle(field + ".second", link->second, n);
      if (link->first == link->second)
        throw InvalidInput(field + ".second",
                           "= " + std::to_string(link->second) + ", must differ from first");
      requirePositive(field + ".length", link->length, "[m]");
      model.row_constraint_.push_back(static_cast<int>(k));
    }
    else if (const auto* pin = std::get_if<PinConstraint>(&c))
    {
      requireParticle(field + ".particle", pin->particle, n);
      requireFinite(field + ".anchor", pin->anchor, "[m]");
      if (pinned[pin->particle])
        throw InvalidInput(field + ".particle",
                           "= " + std::to_string(pin->particle) + " is already pinned");
      pinned[pin->particle] = true;
      model.inverse_masses_[pin->particle] = 0.0;
      model.pins_.push_back(static_cast<int>(k));
    }
  }

  for (const Force& force : scene.forces)
    if (std::holds_alternative<GravityForce>(force))
      model.has_potential_ = true;

  // incidence of rows on free particles, in CSR form
  std::vector<int> count(n + 1, 0);
  for (int r = 0; r < model.numRows(); ++r)
    for (int slot = 0; slot < 2; ++slot)
    {
      const int i = rowParticle(scene, model.row_constraint_[r], slot);
      if (i >= 0 && !pinned[i])
        ++count[i + 1];
    }
  model.incidence_start_.assign(n + 1, 0);
  for (int i = 0; i < n; ++i)
    model.incidence_start_[i + 1] = model.incidence_start_[i] + count[i + 1];
  model.incidence_.resize(model.incidence_start_[n]);
  std::vector<int> fill(model.incidence_start_.begin(), model.incidence_start_.end() - 1);
  for (int r = 0; r < model.numRows(); ++r)
    for (int slot = 0; slot < 2; ++slot)
    {
      const int i = rowParticle(scene, model.row_constraint_[r], slot);
      if (i >= 0 && !pinned[i])
        model.incidence_[fill[i]++] = RowIncidence{ r, slot };
    }

  const bool tridiagonal = isTridiagonal(model);
  if (model.numRows() == 0)
    model.method_ = SolveMethod::None;
  else if (method == SolveMethod::Automatic)
    model.method_ = tridiagonal ? SolveMethod::Tridiagonal : SolveMethod::Sparse;
  else if (method == SolveMethod::Tridiagonal && !tridiagonal)
    throw InvalidInput("solve_method",
                       "= tridiagonal, but the constraint rows of this scene do "
                       "not form a chain; use automatic, sparse or dense");
  else if (method == SolveMethod::None)
    throw InvalidInput("solve_method", "= none, but the scene has constraint rows");
  else
    model.method_ = method;
  return model;
}

bool isTridiagonal(const Model& model)
{
  const auto& start = model.incidenceStart();
  const auto& incidence = model.incidence();
  for (int i = 0; i < model.numParticles(); ++i)
  {
    const int touches = start[i + 1] - start[i];
    if (touches > 2)
      return false;
    if (touches == 2 && std::abs(incidence[start[i]].row - incidence[start[i] + 1].row) != 1)
      return false;
  }
  return true;
}

void Model::validateState(const State& state, const std::string& field) const
{
  const int n = numParticles();
  const std::string prefix = field.empty() ? "" : field + ".";
  if (state.positions.cols() != n)
    throw InvalidInput(prefix + "positions", "has " + std::to_string(state.positions.cols()) +
                                                 " entries, must have one per particle (" +
                                                 std::to_string(n) + ")");
  if (state.velocities.cols() != n)
    throw InvalidInput(prefix + "velocities", "has " + std::to_string(state.velocities.cols()) +
                                                  " entries, must have one per particle (" +
                                                  std::to_string(n) + ")");
  for (int i = 0; i < n; ++i)
  {
    requireFinite(prefix + "positions[" + std::to_string(i) + "]", Vec3(state.positions.col(i)),
                  "[m]");
    requireFinite(prefix + "velocities[" + std::to_string(i) + "]", Vec3(state.velocities.col(i)),
                  "[m/s]");
  }
  requireFinite(prefix + "time", state.time, "[s]");
}

}  // namespace constrained_particles
