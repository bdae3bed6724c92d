/// @file model_structure.hpp
/// @brief Model::compile's structure passes, each a function of the model compiled so far (its
/// rows and incidence): whether the tree solve can work by rows and its elimination plan, the
/// fused tree's links, the fused chain's rows, and the forward path they allow with the reason.
/// Private to the core.
#pragma once

#include "constrained_particles/core/model.hpp"

#include <string>
#include <vector>

namespace constrained_particles
{
namespace model_structure
{
/// Model::solvesTreeByRows()'s structure: at most Model::TREE_ROWS_PER_PARTICLE rows on every
/// free particle.
bool fitsTreeRows(const Model& model);

/// Model::solvesTreeByRows()'s elimination order and cliques (its docs and TreeClique's): returns
/// the scalars the cliques' triangles take.
int planTreeElimination(const Model& model, std::vector<int>& order,
                        std::vector<TreePlace>& eliminated_in, std::vector<TreeClique>& cliques);

/// The fused tree stages' rows (Model::fusedTree(), fusedContactTree()) in treeOrder(), or none
/// (`why_not` says why) unless every row of a solvesTreeByRows() model is a link between
/// particles not both held or a surface contact (no shape carried); `unlinked` gets the
/// particles no row touches.
std::vector<TreeLink> findTreeLinks(const Model& model, std::vector<int>& unlinked,
                                    std::string& why_not);

/// The fused chain's rows (Model::fusedChain()): links and surface rows in an order the
/// tridiagonal solve takes, or none (`why_not` says why); `surface_rows` counts the surface rows,
/// `surface_records` gives each row's index in the surface kind table (-1 for a link).
std::vector<ChainRow> findChainRows(const Model& model, std::vector<int>& unlinked,
                                    int& surface_rows, std::vector<int>& surface_records,
                                    std::string& why_not);

/// Model::path(): the fused path the structure allows, or the generic stages and why.
PathChoice choosePathOf(const Model& model, StagePaths paths, const std::string& chain_why_not,
                        const std::string& tree_why_not);

}  // namespace model_structure
}  // namespace constrained_particles
