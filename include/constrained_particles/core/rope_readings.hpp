/// @file rope_readings.hpp
/// @brief What a rope user reads off a state (issue 49): each link's tension and each bend's
/// moment, from the multipliers and positions the node publishes. docs/physics.md, "Constraint
/// forces" and "Applied forces".
#pragma once

#include "constrained_particles/core/model.hpp"

#include <vector>

namespace constrained_particles
{
/// A link's (or slack link's) tension.
struct LinkTension
{
  int first = 0, second = 0;  ///< its particles i, j
  double tension = 0;         ///< [N], > 0 pulling i and j together, < 0 pushing them apart
};

/// Each link and slack link of the model, in the scene's constraint order, with its tension at
/// `positions` [m] (3 x n) under `multipliers` (Data::multipliers' layout: one per row, then
/// the eliminated particles'). A link's row C = (|d|^2 - l^2) / 2 pulls i with lambda d, d =
/// p_i - p_j, so T = -lambda |d|; a slack link's turned row, T = lambda |d| (0 while slack).
/// @throws std::invalid_argument if `multipliers` is shorter than the model's rows
std::vector<LinkTension> linkTensions(const Model& model, const Points& positions,
                                      const Eigen::VectorXd& multipliers);

/// A bend's moment.
struct JointMoment
{
  int particle = 0;   ///< the joint's particle (BendingForce::middle)
  double moment = 0;  ///< [N m], >= 0 (bendingMoment)
};

/// Each bend record of the model (BendingForce: a chain's bend_stiffness, or a scene's own), in
/// the scene's force order, with its moment at
/// `positions` [m] (3 x n).
std::vector<JointMoment> bendingMoments(const Model& model, const Points& positions);

}  // namespace constrained_particles
