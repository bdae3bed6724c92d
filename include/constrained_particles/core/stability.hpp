/// @file stability.hpp
/// @brief The stability estimate: the highest frequency the constraint forces (and springs) give
/// the scene at a state, and the sub-steps an explicit method needs to stay stable at it.
///
/// A chain under tension T with masses m and links l has transverse modes up to
/// omega_max ~= 2 sqrt(T / (m l)); an explicit method blows up once omega_max dt passes its
/// stability limit (integrators.hpp). In general the linearised motion about a state is
/// xddot = -W K x with K = sum_r lambda_r Hess(C_r) (the geometric stiffness; Hairer, Lubich,
/// Wanner, Geometric Numerical Integration, VII.1) plus the springs' 2 k, and by Gershgorin's
/// theorem
///   omega_max^2 <= max_i w_i sum_r |lambda_r| rowsum_i |Hess(C_r)|  (+ 2 k per spring at i).
/// For a uniform chain this is exactly 4 T / (m l) (each particle's two links, 2 |lambda| each,
/// |lambda| = T / l). Each row kind gives its row sums (addGeometricStiffness in its header).
/// docs/physics.md, "Step checks and sub-steps".
#pragma once

#include "constrained_particles/core/forces.hpp"
#include "constrained_particles/core/model.hpp"

#include <Eigen/Core>

namespace constrained_particles
{
/// The estimate keeps omega_max dt_sub under this fraction of the method's stability limit.
constexpr double STABILITY_SAFETY = 0.9;

/// Upper bound on the highest frequency omega_max [rad/s] of the linearised motion at
/// `positions` and `time` with the row multipliers `multipliers` (m, then eliminated reactions,
/// as Data::multipliers holds them), with the springs among the model's forces and among
/// `perturbations` (Data::perturbations). `stiffness` is a workspace, resized to n. No
/// allocation once sized. Carried obstacles are where `carriers` (Data::carriers) has them.
double estimateMaxFrequency(const Model& model, const Eigen::VectorXd& multipliers,
                            const Points& positions, double time, Eigen::VectorXd& stiffness,
                            const std::vector<Force>& perturbations = {},
                            const std::vector<AnchorTrack>* carriers = nullptr);

/// The fewest sub-steps, a power of two, that keep omega dt / substeps <= STABILITY_SAFETY
/// stability_limit, capped at max_substeps (>= 1). omega [rad/s], dt [s].
int stabilitySubsteps(double omega, double dt, double stability_limit, int max_substeps);

}  // namespace constrained_particles
