#include "constrained_particles/core/model.hpp"

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
    case ForwardPath::Generic:
      break;
  }
  return "generic";
}

namespace
{
// Model::solvesTreeByRows()'s structure: few rows on every free particle.
bool fitsTreeRows(const Model& model)
{
  const auto& start = model.incidenceStart();
  for (int i = 0; i < model.numParticles(); ++i)
    if (start[i + 1] - start[i] > Model::TREE_ROWS_PER_PARTICLE)
      return false;
  return true;
}

// True if every row-kind record is of one of the kinds `Allowed` (eliminated kinds make no rows).
template <typename... Allowed>
bool rowsOnlyOfKinds(const Model& model)
{
  bool only = true;
  std::apply(
      [&](const auto&... tables)
      {
        (
            [&](const auto& table)
            {
              using Kind = typename std::decay_t<decltype(table)>::value_type::KindType;
              if constexpr (!Kind::ELIMINATED && !(std::is_same_v<Kind, Allowed> || ...))
                only = only && table.empty();
            }(tables),
            ...);
      },
      model.kindTables());
  return only;
}

// Where each particle's constraint force starts and ends in a fused down sweep (rows, or places,
// m-1 to 0): the lowest and the highest index of a row touching it (m and -1 if none).
template <typename Row>
void sweepSpans(const std::vector<Row>& rows, int n, std::vector<int>& lowest,
                std::vector<int>& highest)
{
  const int m = static_cast<int>(rows.size());
  lowest.assign(n, m);
  highest.assign(n, -1);
  for (int k = 0; k < m; ++k)
    for (int i : { rows[k].first, rows[k].second })
    {
      lowest[i] = std::min(lowest[i], k);
      highest[i] = std::max(highest[i], k);
    }
}

// Model::solvesTreeByRows()'s elimination order and cliques (its docs and TreeClique's): returns
// the scalars the cliques' triangles take.
int planTreeElimination(const Model& model, std::vector<int>& order,
                        std::vector<TreePlace>& eliminated_in, std::vector<TreeClique>& cliques)
{
  const int n = model.numParticles();
  const int m = model.numRows();
  const auto& start = model.incidenceStart();
  const auto& incidence = model.incidence();
  const auto& row_start = model.rowStart();
  const auto& block_particle = model.blockParticle();
  const auto& w = model.inverseMasses();
  // breadth-first from a particle of each tree: a row's parent particle is the one it is reached
  // from; its other free particle (if any) is reached through it, so hangs below it
  std::vector<int> parent_particle(m, -1);
  std::vector<char> seen_particle(n, 0), seen_row(m, 0);
  std::vector<int> queue, reached;
  queue.reserve(n);
  reached.reserve(m);
  for (int root = 0; root < n; ++root)
  {
    if (seen_particle[root] || w[root] == 0.0)
      continue;
    seen_particle[root] = 1;
    queue.assign(1, root);
    for (std::size_t head = 0; head < queue.size(); ++head)
    {
      const int p = queue[head];
      for (int a = start[p]; a < start[p + 1]; ++a)
      {
        const int r = incidence[a].row;
        if (seen_row[r])
          continue;
        seen_row[r] = 1;
        parent_particle[r] = p;
        reached.push_back(r);
        for (int b = row_start[r]; b < row_start[r + 1]; ++b)
        {
          const int i = block_particle[b];
          if (w[i] > 0.0 && !seen_particle[i])  // a forest: an unseen particle hangs below
          {
            seen_particle[i] = 1;
            queue.push_back(i);
          }
        }
      }
    }
  }
  // reversed, every row comes after the rows below it; rows touching no free particle last
  order.assign(reached.rbegin(), reached.rend());
  for (int r = 0; r < m; ++r)
    if (!seen_row[r])
      order.push_back(r);
  std::vector<int> position(m);
  for (int k = 0; k < m; ++k)
    position[order[k]] = k;
  // a clique per particle with two or more rows, in elimination order
  eliminated_in.assign(m, TreePlace{});
  cliques.clear();
  int offset = 0;
  std::vector<RowIncidence> touches;
  for (int p = 0; p < n; ++p)
  {
    const int d = start[p + 1] - start[p];
    if (d < 2)
      continue;
    assert(d <= TREE_ROWS_PER_PARTICLE);  // Model::solvesTreeByRows()
    TreeClique clique;
    clique.particle = p;
    clique.size = d;
    clique.offset = offset;
    touches.assign(incidence.begin() + start[p], incidence.begin() + start[p + 1]);
    std::sort(touches.begin(), touches.end(),
              [&](const RowIncidence& x, const RowIncidence& y)
              { return position[x.row] < position[y.row]; });
    for (int a = 0; a < d; ++a)
    {
      clique.rows[a] = touches[a].row;
      clique.blocks[a] = touches[a].block;
      clique.positions[a] = position[touches[a].row];
      clique.signs[a] = touches[a].block == row_start[touches[a].row] ? 1.0 : -1.0;
      if (parent_particle[touches[a].row] == p)
        eliminated_in[clique.positions[a]] = TreePlace{ static_cast<int>(cliques.size()), a };
    }
    cliques.push_back(clique);
    offset += d * (d - 1) / 2;
  }
  return offset;
}

// The fused tree stages' links (Model::fusedTree()) in treeOrder(), or none unless every row of
// a solvesTreeByRows() model is a link between particles not both held; `unlinked` gets the
// particles no link touches.
std::vector<TreeLink> findTreeLinks(const Model& model, std::vector<int>& unlinked,
                                    std::string& why_not)
{
  const int m = model.numRows();
  if (!model.solvesTreeByRows() || m < 1)
    return {};
  const bool only_links = rowsOnlyOfKinds<LinkConstraint>(model);
  const auto& links = std::get<std::vector<KindRecord<LinkConstraint>>>(model.kindTables());
  if (!only_links || static_cast<int>(links.size()) != m)
  {
    why_not = "a row that is not a link (only a tree of links has fused sweeps)";
    return {};
  }
  std::vector<int> held(model.numBlocks(), -1);
  for (const EliminatedBlock& block : model.eliminatedBlocks())
    held[block.block] = block.eliminated;
  const auto& w = model.inverseMasses();
  const auto& order = model.treeOrder();
  std::vector<int> position(m);
  for (int k = 0; k < m; ++k)
    position[order[k]] = k;
  std::vector<TreeLink> rows(m);
  for (const KindRecord<LinkConstraint>& entry : links)
  {
    const LinkConstraint& link = entry.record;
    TreeLink& row = rows[position[entry.first_row]];
    row.row = entry.first_row;
    row.block = entry.first_block;
    row.first = link.first;
    row.second = link.second;
    row.length = link.length;
    row.w_first = w[link.first];
    row.w_second = w[link.second];
    row.held_first = held[entry.first_block];
    row.held_second = held[entry.first_block + 1];
    if (row.w_first == 0.0 && row.w_second == 0.0)
    {
      why_not =
          "a link between two held particles (always singular: the generic solve regularises it)";
      return {};
    }
  }
  const auto& cliques = model.treeCliques();
  for (int c = 0; c < static_cast<int>(cliques.size()); ++c)
    for (int a = 0; a < cliques[c].size; ++a)
    {
      TreeLink& row = rows[cliques[c].positions[a]];
      if (row.first == cliques[c].particle)
      {
        row.clique_first = c;
        row.index_first = static_cast<std::int8_t>(a);
      }
      else
      {
        row.clique_second = c;
        row.index_second = static_cast<std::int8_t>(a);
      }
    }
  std::vector<int> lowest, highest;
  sweepSpans(rows, model.numParticles(), lowest, highest);
  for (int k = 0; k < m; ++k)
  {
    TreeLink& row = rows[k];
    row.first_opens = highest[row.first] == k;
    row.first_closes = lowest[row.first] == k;
    row.second_opens = highest[row.second] == k;
    row.second_closes = lowest[row.second] == k;
  }
  unlinked.clear();
  for (int i = 0; i < model.numParticles(); ++i)
    if (highest[i] < 0)
      unlinked.push_back(i);
  return rows;
}

// The fused chain stages' rows (Model::fusedChain()), or none if the model has another structure:
// links and surface rows (chains whose particles slide on height fields), in any order the
// tridiagonal solve takes; `surface_rows` counts the surface rows and `surface_records` gives
// each row's index in the surface kind table (-1 for a link; empty without surface rows).
std::vector<ChainRow> findChainRows(const Model& model, std::vector<int>& unlinked,
                                    int& surface_rows, std::vector<int>& surface_records,
                                    std::string& why_not)
{
  surface_rows = 0;
  surface_records.clear();
  const int m = model.numRows();
  if (model.solveMethod() != SolveMethod::Tridiagonal || m < 1)
    return {};
  const bool only_links = rowsOnlyOfKinds<LinkConstraint, SurfaceConstraint>(model);
  const auto& links = std::get<std::vector<KindRecord<LinkConstraint>>>(model.kindTables());
  const auto& surfaces = std::get<std::vector<KindRecord<SurfaceConstraint>>>(model.kindTables());
  const int s = static_cast<int>(surfaces.size());
  if (!only_links || static_cast<int>(links.size()) + s != m)
  {
    why_not = "a row that is not a link or a surface row (only those have fused sweeps)";
    return {};
  }
  // each row's kind: a surface row is one row of one block, a link one row of two
  std::vector<int> surface_of(m, -1);
  for (int j = 0; j < s; ++j)
    surface_of[surfaces[j].first_row] = j;
  const auto& row_start = model.rowStart();
  for (int k = 0; k < m; ++k)
    if (row_start[k + 1] - row_start[k] != (surface_of[k] >= 0 ? 1 : 2))
    {
      why_not = "a row whose blocks are not a link's or a surface row's";
      return {};
    }
  std::vector<int> held(model.numBlocks(), -1);
  std::vector<int> held_blocks(model.numParticles(), 0);
  for (const EliminatedBlock& block : model.eliminatedBlocks())
  {
    held[block.block] = block.eliminated;
    // J^T lambda is summed down the chain: beyond two rows on one held particle its force would
    // be summed in another order than the generic stages' (not the motion; the reported force)
    if (++held_blocks[model.blockParticle()[block.block]] > 2)
    {
      why_not =
          "more than two rows on one held particle (its reaction is summed in the generic order)";
      return {};
    }
  }
  const auto& w = model.inverseMasses();
  std::vector<ChainRow> rows(m);
  for (const KindRecord<SurfaceConstraint>& surface : surfaces)
  {
    // its particle in `first` (and `second`, for the sweeps' bookkeeping)
    ChainRow& row = rows[surface.first_row];
    row.first = row.second = surface.record.particle;
    row.w_first = w[row.first];
    if (row.w_first == 0.0)
    {
      why_not =
          "a held particle on a surface (its row is always singular: the generic solve regularises "
          "it)";
      return {};
    }
  }
  for (int j = 0; j < static_cast<int>(links.size()); ++j)
  {
    const int k = links[j].first_row, block = links[j].first_block;
    const LinkConstraint& link = links[j].record;
    ChainRow& row = rows[k];
    row.first = link.first;
    row.second = link.second;
    row.length = link.length;
    row.w_first = w[link.first];
    row.w_second = w[link.second];
    row.held_first = held[block];
    row.held_second = held[block + 1];
    if (row.w_first == 0.0 && row.w_second == 0.0)
    {
      why_not =
          "a link between two held particles (always singular: the generic solve regularises it)";
      return {};
    }
  }
  // a block's sign against the vector the sweeps carry: a link's first block is d, its second
  // -d; a surface row's is its Jacobian itself
  const auto& block_row = model.blockRow();
  auto sign = [&](int block)
  {
    const int r = block_row[block];
    return surface_of[r] >= 0 || block == row_start[r] ? 1.0 : -1.0;
  };
  for (const SharedParticle& shared : sharedParticles(model))
  {
    ChainRow& row = rows[shared.later.row];
    if (row.coupling >= 0)
    {
      why_not = "two links between the same two particles (the generic solve sums them)";
      return {};
    }
    row.coupling = shared.particle;
    // multiplying by -1 is exact, so the signs give the same sum
    row.w_coupling_signed =
        sign(shared.earlier.block) * sign(shared.later.block) * w[shared.particle];
  }
  std::vector<int> lowest, highest;
  sweepSpans(rows, model.numParticles(), lowest, highest);
  for (int k = 0; k < m; ++k)
  {
    ChainRow& row = rows[k];
    // the generic stages add a particle's shares by kind, surface rows first, then in row order:
    // this row's last only where it is a link above the surface row that opened the particle
    auto closes = [&](int i)
    {
      if (lowest[i] != k)
        return std::uint8_t{ 0 };
      return surface_of[k] < 0 && highest[i] != k && surface_of[highest[i]] >= 0
                 ? ChainRow::CLOSES_OWN_LAST
                 : ChainRow::CLOSES_OWN_FIRST;
    };
    row.first_opens = highest[row.first] == k;
    row.first_closes = closes(row.first);
    row.second_opens = highest[row.second] == k;
    row.second_closes = closes(row.second);
  }
  surface_rows = s;
  if (s > 0)
    surface_records = surface_of;
  unlinked.clear();
  for (int i = 0; i < model.numParticles(); ++i)
    if (highest[i] < 0)
      unlinked.push_back(i);
  return rows;
}

// Model::path(): the fused path the structure allows, or the generic stages and why.
PathChoice choosePathOf(const Model& model, StagePaths paths, const std::string& chain_why_not,
                        const std::string& tree_why_not)
{
  const int m = model.numRows();
  const std::string rows = std::to_string(m) + (m == 1 ? " row" : " rows");
  if (!model.chainRows().empty())
    return { ForwardPath::FusedChain,
             rows + " (" + std::to_string(model.chainSurfaceRows()) +
                 " on surfaces) form a chain: J W J^T is tridiagonal, so rows, solve and "
                 "accelerations run in two sweeps along it" };
  if (!model.treeLinks().empty())
    return { ForwardPath::FusedTree, rows + " are links forming a tree with at most " +
                                         std::to_string(Model::TREE_ROWS_PER_PARTICLE) +
                                         " on a particle: two sweeps, leaves first" };
  if (paths == StagePaths::Generic)
    return { ForwardPath::Generic, "StagePaths::Generic asks for the generic stages" };
  if (m == 0)
    return { ForwardPath::Generic, "no constraint rows to solve" };
  if (model.numContacts() > 0)
    return { ForwardPath::Generic,
             std::string(
                 "surface_contact, shape_contact or slack_link rows switch on and off: the generic "
                 "stages and the ") +
                 solveMethodName(model.solveMethod()) + " solve" };
  if (model.solveMethod() == SolveMethod::Tridiagonal)
    return { ForwardPath::Generic, "a chain, but " + chain_why_not };
  if (model.solveMethod() == SolveMethod::Tree && !model.solvesTreeByRows())
    return { ForwardPath::Generic,
             "a tree with more than " + std::to_string(Model::TREE_ROWS_PER_PARTICLE) +
                 " rows on one particle (its solve eliminates particles, not rows)" };
  if (model.solveMethod() == SolveMethod::Tree)
    return { ForwardPath::Generic, "a tree, but " + tree_why_not };
  return { ForwardPath::Generic, std::string("solve method ") +
                                     solveMethodName(model.solveMethod()) +
                                     ": only a chain (tridiagonal) or a tree of links has "
                                     "fused sweeps" };
}
}  // namespace

Model Model::compile(const Scene& scene, SolveMethod method, StagePaths paths)
{
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
    // a carried shape's contacts share its track, Data::carriers[carrier]: numbered by name
    if (auto* contact = std::get_if<ShapeContact>(&model.scene_.constraints[k]); contact)
      contact->carrier = -1;  // a fixed shape's, whatever the record held
    if (auto* contact = std::get_if<ShapeContact>(&model.scene_.constraints[k]);
        contact && contact->shape.carried())
    {
      auto same = [contact](const Shape& s) { return s.name == contact->shape.name; };
      const auto found = std::find_if(model.carriers_.begin(), model.carriers_.end(), same);
      contact->carrier = static_cast<int>(found - model.carriers_.begin());
      if (found == model.carriers_.end())
        model.carriers_.push_back(contact->shape);
    }
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
  // the particle contacts first, kind by kind in registry order, then the slack links
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
                                    false,
                                    { table[k].record.particle, table[k].record.particle },
                                    table[k].record.friction,
                                    table[k].record.restitution });
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
                          true,
                          { slack_table[k].record.first, slack_table[k].record.second } });
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
                           ", but the scene has contact or slack_link rows, which "
                           "switch on and off; use automatic, tree, sparse or dense");
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
