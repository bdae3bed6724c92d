#include "constrained_particles/core/model.hpp"
#include "constrained_particles/core/self_collision.hpp"

#include "model_structure.hpp"

#include "constrained_particles/core/limits.hpp"

#include <algorithm>
#include <cassert>
#include <cstdlib>
#include <string>
#include <type_traits>
#include <utility>

namespace constrained_particles
{
namespace
{
const SolveMethod ALL_METHODS[] = { SolveMethod::Automatic, SolveMethod::Tridiagonal,
                                    SolveMethod::Sparse,    SolveMethod::Dense,
                                    SolveMethod::None,      SolveMethod::Single,
                                    SolveMethod::Tree };
}

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
    case SolveMethod::Single:
      return "single";
    case SolveMethod::Tree:
      return "tree";
  }
  return "unknown";
}

std::string solveAlgorithmName(const Model& model)
{
  if (model.solveMethod() != SolveMethod::Tree)
    return solveMethodName(model.solveMethod());
  return model.solvesTreeByRows() ? "tree (by rows)" : "tree (by particles)";
}

SolveMethod parseSolveMethod(const std::string& name, const std::string& field)
{
  // none and single are what a structure resolves to, not requests
  std::string valid;
  for (SolveMethod method : ALL_METHODS)
  {
    if (method == SolveMethod::None || method == SolveMethod::Single)
      continue;
    if (name == solveMethodName(method))
      return method;
    valid += std::string(valid.empty() ? "" : ", ") + solveMethodName(method);
  }
  throw InvalidInput(field, "= '" + name + "' is unknown; valid: " + valid);
}

const char* forwardPathName(ForwardPath path)
{
  switch (path)
  {
    case ForwardPath::FusedChain:
      return "fused_chain";
    case ForwardPath::FusedTree:
      return "fused_tree";
    case ForwardPath::FusedContactTree:
      return "fused_contact_tree";
    case ForwardPath::Generic:
      break;
  }
  return "generic";
}

Model Model::compile(const Scene& scene, SolveMethod method, StagePaths paths)
{
  using namespace model_structure;  // the structure passes (model_structure.hpp)
  const int n = static_cast<int>(scene.masses.size());
  if (n == 0)
    throw InvalidInput("masses", "is empty: a scene needs at least 1 particle");
  if (!limits::PARTICLES.contains(n))
    throw InvalidInput(
        "masses", "has " + std::to_string(n) + " particles, must have " + limits::PARTICLES.text());
  for (int i = 0; i < n; ++i)
    requireInRange("masses[" + std::to_string(i) + "]", scene.masses[i], limits::MASS);
  for (std::size_t k = 0; k < scene.surfaces.size(); ++k)
    validateSurface(scene.surfaces[k], "surfaces[" + std::to_string(k) + "]");
  for (std::size_t k = 0; k < scene.forces.size(); ++k)
    validateForce(scene.forces[k], n, "forces[" + std::to_string(k) + "]");
  validateSelfCollisions(scene);
  // a rope's link pairs join links far apart along it: a cycle of rows, made as the rope moves
  if (!scene.self_collisions.empty() && method != SolveMethod::Automatic &&
      method != SolveMethod::Sparse && method != SolveMethod::Dense)
    throw InvalidInput("solve_method",
                       std::string("= ") + solveMethodName(method) +
                           ", but the scene has self_collisions, whose link pair rows close "
                           "cycles as the rope moves; use automatic, sparse or dense");

  Model model;
  model.scene_ = scene;
  model.inverse_masses_.resize(n);
  for (int i = 0; i < n; ++i)
  {
    model.inverse_masses_[i] = 1.0 / scene.masses[i];
    model.total_mass_ += scene.masses[i];
  }
  auto galilean = [](const auto& effect)
  {
    return std::visit([](const auto& e) { return std::decay_t<decltype(e)>::GALILEAN_INVARIANT; },
                      effect);
  };
  model.isolated_ = std::all_of(scene.forces.begin(), scene.forces.end(), galilean) &&
                    std::all_of(scene.constraints.begin(), scene.constraints.end(), galilean);

  // rows in scene order, each record's blocks row-major; eliminated particles get W = 0
  const int num_surfaces = static_cast<int>(scene.surfaces.size());
  std::vector<int> held_by(n, -1);
  for (std::size_t k = 0; k < scene.constraints.size(); ++k)
  {
    const std::string field = "constraints[" + std::to_string(k) + "]";
    const Constraint& c = scene.constraints[k];
    validateConstraint(c, n, num_surfaces, field);
    if (isEliminated(c))
    {
      const int i = eliminatedParticle(c);
      if (held_by[i] >= 0)
        throw InvalidInput(field + ".particle", "= " + std::to_string(i) +
                                                    " is already pinned (held by constraints[" +
                                                    std::to_string(held_by[i]) + "], a " +
                                                    kindOf(scene.constraints[held_by[i]]) + ")");
      held_by[i] = static_cast<int>(k);
      // a tracked kind's motion is Data::tracks[track]: numbered in scene order
      std::visit(
          [&model](auto& record)
          {
            if constexpr (IsTracked<std::decay_t<decltype(record)>>::value)
              record.track = static_cast<int>(model.tracked_.size());
          },
          model.scene_.constraints[k]);
      if (isTracked(c))
        model.tracked_.push_back(static_cast<int>(k));
      model.inverse_masses_[i] = 0.0;
      model.addToKindTable(model.scene_.constraints[k], static_cast<int>(k),
                           static_cast<int>(model.eliminated_.size()), i);
      model.eliminated_.push_back(static_cast<int>(k));
      model.eliminated_particles_.push_back(i);
      continue;
    }
    // a carried shape's contacts (particle and segment) share its track,
    // Data::carriers[carrier]: numbered by name
    std::visit(
        [&model](auto& record)
        {
          using Kind = std::decay_t<decltype(record)>;
          if constexpr (std::is_same_v<Kind, ShapeContact> || std::is_same_v<Kind, SegmentContact>)
          {
            record.carrier = -1;  // a fixed shape's, whatever the record held
            if (!record.shape.carried())
              return;
            auto same = [&record](const Shape& s) { return s.name == record.shape.name; };
            const auto found = std::find_if(model.carriers_.begin(), model.carriers_.end(), same);
            record.carrier = static_cast<int>(found - model.carriers_.begin());
            if (found == model.carriers_.end())
              model.carriers_.push_back(record.shape);
          }
        },
        model.scene_.constraints[k]);
    int particles[MAX_ROW_PARTICLES];
    const int count = rowParticles(c, particles);
    RowRecord record{ static_cast<int>(k), model.numRows(), rowCount(c), model.numBlocks(), count };
    model.addToKindTable(model.scene_.constraints[k], record.constraint, record.first_row,
                         record.first_block);
    for (int r = 0; r < record.rows; ++r)
    {
      for (int p = 0; p < count; ++p)
      {
        model.block_particle_.push_back(particles[p]);
        model.block_row_.push_back(record.first_row + r);
      }
      model.row_start_.push_back(model.numBlocks());
    }
    model.row_records_.push_back(record);
  }
  // blocks on held particles: their imposed accelerations enter the right-hand side
  std::vector<int> eliminated_index(n, -1);
  for (std::size_t e = 0; e < model.eliminated_particles_.size(); ++e)
    eliminated_index[model.eliminated_particles_[e]] = static_cast<int>(e);
  for (int b = 0; b < model.numBlocks(); ++b)
    if (eliminated_index[model.block_particle_[b]] >= 0)
      model.eliminated_blocks_.push_back(
          EliminatedBlock{ b, eliminated_index[model.block_particle_[b]] });

  // incidence of rows on free particles, in CSR form
  const std::vector<double>& w = model.inverse_masses_;
  std::vector<int> count(n + 1, 0);
  for (int b = 0; b < model.numBlocks(); ++b)
    if (w[model.block_particle_[b]] > 0.0)
      ++count[model.block_particle_[b] + 1];
  model.incidence_start_.assign(n + 1, 0);
  for (int i = 0; i < n; ++i)
    model.incidence_start_[i + 1] = model.incidence_start_[i] + count[i + 1];
  model.incidence_.resize(model.incidence_start_[n]);
  std::vector<int> fill(model.incidence_start_.begin(), model.incidence_start_.end() - 1);
  for (int r = 0; r < model.numRows(); ++r)
    for (int b = model.row_start_[r]; b < model.row_start_[r + 1]; ++b)
    {
      const int i = model.block_particle_[b];
      if (w[i] > 0.0)
        model.incidence_[fill[i]++] = RowIncidence{ r, b };
    }

  const bool tridiagonal = isTridiagonal(model);
  // the particle contacts first, kind by kind in registry order, then the slack links, then the
  // segment contacts, then the link pairs
  std::apply(
      [&](const auto&... tables)
      {
        auto add = [&](const auto& table)
        {
          using Kind = typename std::decay_t<decltype(table)>::value_type::KindType;
          if constexpr (IsParticleContact<Kind>::value)
            for (std::size_t k = 0; k < table.size(); ++k)
              model.unilateral_.push_back(
                  UnilateralRecord{ table[k].first_row,
                                    table[k].first_block,
                                    static_cast<int>(k),
                                    table[k].constraint,
                                    UnilateralKind::ParticleContact,
                                    { table[k].record.particle, table[k].record.particle },
                                    table[k].record.friction,
                                    table[k].record.restitution,
                                    1 });
        };
        (add(tables), ...);
      },
      model.kind_tables_);
  model.num_particle_contacts_ = static_cast<int>(model.unilateral_.size());
  const auto& slack_table = std::get<std::vector<KindRecord<SlackLink>>>(model.kind_tables_);
  for (std::size_t k = 0; k < slack_table.size(); ++k)
    model.unilateral_.push_back(
        UnilateralRecord{ slack_table[k].first_row,
                          slack_table[k].first_block,
                          static_cast<int>(k),
                          slack_table[k].constraint,
                          UnilateralKind::SlackLink,
                          { slack_table[k].record.first, slack_table[k].record.second } });
  const auto& segment_table = std::get<std::vector<KindRecord<SegmentContact>>>(model.kind_tables_);
  for (std::size_t k = 0; k < segment_table.size(); ++k)
    model.unilateral_.push_back(
        UnilateralRecord{ segment_table[k].first_row,
                          segment_table[k].first_block,
                          static_cast<int>(k),
                          segment_table[k].constraint,
                          UnilateralKind::SegmentContact,
                          { segment_table[k].record.first, segment_table[k].record.second },
                          0.0,
                          segment_table[k].record.restitution });
  const auto& pair_table = std::get<std::vector<KindRecord<LinkPairContact>>>(model.kind_tables_);
  for (std::size_t k = 0; k < pair_table.size(); ++k)
  {
    const LinkPairContact& pair = pair_table[k].record;
    model.unilateral_.push_back(
        UnilateralRecord{ pair_table[k].first_row,
                          pair_table[k].first_block,
                          static_cast<int>(k),
                          pair_table[k].constraint,
                          UnilateralKind::LinkPairContact,
                          { pair.first_a, pair.second_a, pair.first_b, pair.second_b },
                          0.0,
                          0.0,
                          4 });
  }
  // two contacts of one particle with one obstacle: identical rows, J W J^T singular (sorted by
  // particle, each particle's few contacts compared: O(n log n))
  const auto& shape_table = std::get<std::vector<KindRecord<ShapeContact>>>(model.kind_tables_);
  std::vector<std::size_t> order(shape_table.size());
  for (std::size_t k = 0; k < order.size(); ++k)
    order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b)
                   { return shape_table[a].record.particle < shape_table[b].record.particle; });
  for (std::size_t first = 0; first < order.size();)
  {
    std::size_t last = first;
    while (last < order.size() &&
           shape_table[order[last]].record.particle == shape_table[order[first]].record.particle)
      ++last;
    for (std::size_t k = first + 1; k < last; ++k)
      for (std::size_t earlier = first; earlier < k; ++earlier)
      {
        const auto& a = shape_table[order[earlier]];
        const auto& b = shape_table[order[k]];
        if (a.record.shape.name == b.record.shape.name)
          throw InvalidInput(
              "constraints[" + std::to_string(std::max(a.constraint, b.constraint)) + "].shape",
              "= " + b.record.shape.name + " keeps particle " + std::to_string(b.record.particle) +
                  " out already (constraints[" +
                  std::to_string(std::min(a.constraint, b.constraint)) +
                  "]): a second contact with it is redundant");
      }
    first = last;
  }
  // two capsules of one link against one obstacle: identical rows (sorted by link: O(n log n))
  std::vector<std::size_t> links(segment_table.size());
  for (std::size_t k = 0; k < links.size(); ++k)
    links[k] = k;
  auto linkOf = [&](std::size_t k)
  {
    const SegmentContact& c = segment_table[k].record;
    return std::make_pair(std::min(c.first, c.second), std::max(c.first, c.second));
  };
  std::stable_sort(links.begin(), links.end(),
                   [&](std::size_t a, std::size_t b) { return linkOf(a) < linkOf(b); });
  for (std::size_t k = 1; k < links.size(); ++k)
    for (std::size_t earlier = k; earlier-- > 0 && linkOf(links[earlier]) == linkOf(links[k]);)
    {
      const auto& a = segment_table[links[earlier]];
      const auto& b = segment_table[links[k]];
      if (a.record.shape.name == b.record.shape.name)
        throw InvalidInput(
            "constraints[" + std::to_string(std::max(a.constraint, b.constraint)) + "].shape",
            "= " + b.record.shape.name + " keeps the link " + std::to_string(b.record.first) + "-" +
                std::to_string(b.record.second) + " out already (constraints[" +
                std::to_string(std::min(a.constraint, b.constraint)) +
                "]): a second segment_contact with it is redundant");
    }
  for (const auto& contact : std::get<std::vector<KindRecord<SurfaceContact>>>(model.kind_tables_))
  {
    for (const auto& row : std::get<std::vector<KindRecord<SurfaceConstraint>>>(model.kind_tables_))
      if (row.record.particle == contact.record.particle &&
          row.record.surface == contact.record.surface)
        throw InvalidInput("constraints[" + std::to_string(contact.constraint) + "].particle",
                           "= " + std::to_string(contact.record.particle) + " slides on surface " +
                               std::to_string(row.record.surface) + " already (constraints[" +
                               std::to_string(row.constraint) +
                               "] holds it both ways): a contact with it too is redundant");
  }
  if (model.numRows() == 0)
    model.method_ = SolveMethod::None;  // nothing to solve, whatever was asked
  else if (model.numContacts() > 0 && method == SolveMethod::Automatic)
  {
    // rows switching on and off (an inactive one an identity row, RowData::inactive): a contact
    // touches one particle, so a chain or tree with contacts is still a forest of particles and
    // rows, and the tree solve keeps it O(n) (Baraff 1996); the tridiagonal and single-row
    // solves are for fixed row patterns
    model.method_ = isForest(model) ? SolveMethod::Tree : SolveMethod::Sparse;
  }
  else if (model.numContacts() > 0 && method != SolveMethod::Tree &&
           method != SolveMethod::Sparse && method != SolveMethod::Dense)
    throw InvalidInput("solve_method",
                       std::string("= ") + solveMethodName(method) +
                           ", but the scene has contact, segment_contact or slack_link rows, "
                           "which switch on and off; use automatic, tree, sparse or dense");
  else if (method == SolveMethod::Automatic)
  {
    if (model.numRows() == 1)
      model.method_ = SolveMethod::Single;
    else if (tridiagonal)
      model.method_ = SolveMethod::Tridiagonal;
    else if (isForest(model))
      model.method_ = SolveMethod::Tree;
    else
      model.method_ = SolveMethod::Sparse;
  }
  else if (method == SolveMethod::Tridiagonal && !tridiagonal)
    throw InvalidInput("solve_method",
                       "= tridiagonal, but the constraint rows of this scene do "
                       "not form a chain; use automatic, tree, sparse or dense");
  else if (method == SolveMethod::Tree && !isForest(model))
    throw InvalidInput("solve_method",
                       "= tree, but the constraint rows of this scene form a cycle; use "
                       "automatic, sparse or dense");
  else if (method == SolveMethod::Single && model.numRows() != 1)
    throw InvalidInput("solve_method", "= single, but the scene has " +
                                           std::to_string(model.numRows()) + " constraint rows");
  else if (method == SolveMethod::None)
    throw InvalidInput("solve_method", "= none, but the scene has constraint rows");
  else
    model.method_ = method;
  model.tree_rows_ =
      paths == StagePaths::Specialized && model.method_ == SolveMethod::Tree && fitsTreeRows(model);
  std::string tree_why_not, chain_why_not;
  if (model.tree_rows_)
  {
    model.tree_clique_entries_ = planTreeElimination(
        model, model.tree_order_, model.tree_eliminated_in_, model.tree_cliques_);
    model.tree_links_ = findTreeLinks(model, model.tree_unlinked_, tree_why_not);
  }
  if (paths == StagePaths::Specialized)
    model.chain_rows_ = findChainRows(model, model.chain_unlinked_, model.chain_surface_rows_,
                                      model.chain_surface_records_, chain_why_not);
  model.path_ = choosePathOf(model, paths, chain_why_not, tree_why_not);
  return model;
}

void Model::addToKindTable(const Constraint& constraint, int index, int first_row, int first_block)
{
  std::visit(
      [&](const auto& record)
      {
        using Kind = std::decay_t<decltype(record)>;
        std::get<std::vector<KindRecord<Kind>>>(kind_tables_)
            .push_back(KindRecord<Kind>{ record, index, first_row, first_block });
      },
      constraint);
}

std::vector<SharedParticle> sharedParticles(const Model& model)
{
  std::vector<SharedParticle> shared;
  const auto& start = model.incidenceStart();
  const auto& incidence = model.incidence();
  for (int i = 0; i < model.numParticles(); ++i)
    if (start[i + 1] - start[i] == 2)
    {
      RowIncidence a = incidence[start[i]], b = incidence[start[i] + 1];
      if (a.row > b.row)
        std::swap(a, b);
      shared.push_back(SharedParticle{ i, a, b });
    }
  return shared;
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

bool isForest(const Model& model)
{
  // union-find over free particles [0, n) and rows [n, n + m): a second path between two
  // nodes closes a cycle
  const int n = model.numParticles();
  std::vector<int> root(n + model.numRows());
  for (std::size_t k = 0; k < root.size(); ++k)
    root[k] = static_cast<int>(k);
  auto find = [&root](int k)
  {
    while (root[k] != k)
      k = root[k] = root[root[k]];
    return k;
  };
  const auto& start = model.incidenceStart();
  const auto& incidence = model.incidence();
  for (int i = 0; i < n; ++i)
    for (int a = start[i]; a < start[i + 1]; ++a)
    {
      const int x = find(i), y = find(n + incidence[a].row);
      if (x == y)
        return false;
      root[x] = y;
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

ContactFrame contactFrame(const Model& model, const UnilateralRecord& record,
                          const EffectContext& context, const Points& p, const Points& v)
{
  return std::visit(
      [&](const auto& contact) -> ContactFrame
      {
        if constexpr (IsParticleContact<std::decay_t<decltype(contact)>>::value)
          return contactFrame(contact, context, p, v);
        else
          return ContactFrame{ Vec3::Zero() };  // not a particle contact: no frame
      },
      model.scene().constraints[record.constraint]);
}

double penetration(const Model& model, const UnilateralRecord& record, const EffectContext& context,
                   const Points& p)
{
  return std::visit(
      [&](const auto& contact)
      {
        if constexpr (IsParticleContact<std::decay_t<decltype(contact)>>::value)
          return penetration(contact, context, p);
        else
          return 0.0;
      },
      model.scene().constraints[record.constraint]);
}

}  // namespace constrained_particles
