// Model::compile's structure passes: which fused path the rows allow (a chain, a tree of links)
// and the tree solve's elimination plan (src/core/model_structure.hpp).
#include "model_structure.hpp"

#include <algorithm>
#include <cassert>
#include <string>
#include <type_traits>
#include <utility>

namespace constrained_particles
{
namespace model_structure
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

// The fused tree stages' rows (Model::fusedTree(), fusedContactTree()) in treeOrder(), or none
// unless every row of a solvesTreeByRows() model is a link between particles not both held or a
// surface contact (and no shape is carried); `unlinked` gets the particles no row touches.
std::vector<TreeLink> findTreeLinks(const Model& model, std::vector<int>& unlinked,
                                    std::string& why_not)
{
  const int m = model.numRows();
  if (!model.solvesTreeByRows() || m < 1)
    return {};
  const bool only_links = rowsOnlyOfKinds<LinkConstraint, SurfaceContact, SurfaceConstraint>(model);
  const auto& links = std::get<std::vector<KindRecord<LinkConstraint>>>(model.kindTables());
  const auto& contacts = std::get<std::vector<KindRecord<SurfaceContact>>>(model.kindTables());
  const auto& surfaces = std::get<std::vector<KindRecord<SurfaceConstraint>>>(model.kindTables());
  // surface rows ride with contacts only: a tree of links and surface rows alone keeps the
  // generic stages and the solve by rows (the fused tree's sweeps know links only)
  if (!surfaces.empty() && contacts.empty())
  {
    why_not = "surface rows without contacts (the fused tree's sweeps take links only)";
    return {};
  }
  if (!only_links || static_cast<int>(links.size() + contacts.size() + surfaces.size()) != m)
  {
    why_not =
        "a row that is not a link or a surface contact (only a tree of those, with surface "
        "rows beside contacts, has fused sweeps)";
    return {};
  }
  if (!contacts.empty() && model.hasCarriers())
  {
    why_not = "a carried shape (its contacts' slip is relative to it: the generic friction)";
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
  const auto& unilateral = model.unilateral();
  for (int k = 0; k < static_cast<int>(unilateral.size()); ++k)
  {
    // a contact's row: one block, its particle's (a held one's row stays off: contact.hpp)
    const UnilateralRecord& record = unilateral[k];
    TreeLink& row = rows[position[record.row]];
    row.row = record.row;
    row.block = record.block;
    row.first = row.second = record.particles[0];
    row.w_first = w[row.first];
    row.held_first = held[record.block];
    row.contact = k;
  }
  for (int k = 0; k < static_cast<int>(surfaces.size()); ++k)
  {
    // a surface row: one block, always acting (seed problem 3's first particle)
    TreeLink& row = rows[position[surfaces[k].first_row]];
    row.row = surfaces[k].first_row;
    row.block = surfaces[k].first_block;
    row.first = row.second = surfaces[k].record.particle;
    row.w_first = w[row.first];
    row.surface = k;
    if (row.w_first == 0.0)
    {
      why_not =
          "a held particle on a surface (its row is always singular: the generic solve regularises "
          "it)";
      return {};
    }
  }
  const auto& cliques = model.treeCliques();
  for (int c = 0; c < static_cast<int>(cliques.size()); ++c)
    for (int a = 0; a < cliques[c].size; ++a)
    {
      TreeLink& row = rows[cliques[c].positions[a]];
      if (row.first == cliques[c].particle)  // a contact's too: its one particle
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
  if (!model.treeLinks().empty() && model.numContacts() > 0)
    return { ForwardPath::FusedContactTree,
             "links and surface contacts, with any surface rows (" + rows +
                 "), form a tree with at most " + std::to_string(Model::TREE_ROWS_PER_PARTICLE) +
                 " rows on a particle: each stage and projection in two sweeps, leaves first, a "
                 "contact's row one more row on its particle (a stage whose friction must be "
                 "solved for: the generic stages)" };
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
                 solveMethodName(model.solveMethod()) + " solve" +
                 (tree_why_not.empty() ? "" : " (not a contact tree: " + tree_why_not + ")") };
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

}  // namespace model_structure
}  // namespace constrained_particles
