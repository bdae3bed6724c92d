/// @file same_motion.hpp
/// @brief The stage paths' equivalence check (test_stage_paths.cpp, test_contact_tree.cpp): a
/// scene stepped on the specialised stages and on the generic ones, compared as it goes.
#pragma once

#include "constrained_particles/core/simulator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace constrained_particles
{
namespace testing
{
struct Difference
{
  double positions = 0.0, velocities = 0.0;
};

inline Difference difference(const State& a, const State& b)
{
  return { (a.positions - b.positions).cwiseAbs().maxCoeff(),
           (a.velocities - b.velocities).cwiseAbs().maxCoeff() };
}

// Steps both ways in batches, comparing as they go; returns whether the fused path was taken.
inline bool expectSameMotion(const Scene& scene, const State& start, const StepSettings& settings,
                             SolveMethod method, const std::string& what, int steps = 1000,
                             bool* singular = nullptr, double* moved_out = nullptr,
                             long* reused_out = nullptr)
{
  Simulator fused(scene, start, settings, method, StagePaths::Specialized);
  Simulator generic(scene, start, settings, method, StagePaths::Generic);
  EXPECT_FALSE(generic.model().fusedChain()) << what;
  EXPECT_FALSE(generic.model().fusedTree()) << what;
  // the tree solve in row space (Model::solvesTreeByRows()) sums in another order than the particle
  // elimination: the same motion to rounding (1e-12 m and 1e-11 m/s, plus as much again per metre
  // moved: a tree falling freely for a second is 5 m away), pivot ratios of another
  // matrix, and no sparse fallback where the particle elimination breaks down
  const bool exact = !fused.model().solvesTreeByRows();
  long generic_fallbacks = 0;
  EXPECT_FALSE(generic.model().solvesTreeByRows()) << what;
  // the motion's size, so that agreement means the same motion and not two chains at rest
  double moved = 0.0;
  long reused = 0;
  for (int done = 0; done < steps; done += 100)
  {
    const StepStatistics a = fused.step(100);
    const StepStatistics b = generic.step(100);
    const Difference d = difference(fused.state(), generic.state());
    moved = std::max(moved, (fused.state().positions - start.positions).cwiseAbs().maxCoeff());
    const double close = exact ? 0.0 : 1e-12 * (1.0 + moved);
    const double close_velocity = exact ? 0.0 : 1e-11 * (1.0 + moved);
    // chains: the same sums in the same order, so the same values, not merely close ones
    EXPECT_LE(d.positions, close) << what << " after " << done + 100 << " steps";
    EXPECT_LE(d.velocities, close_velocity) << what << " after " << done + 100 << " steps";
    EXPECT_EQ(a.steps, b.steps) << what;
    EXPECT_EQ(a.substeps, b.substeps) << what;
    EXPECT_EQ(a.rejected_steps, b.rejected_steps) << what;
    EXPECT_EQ(a.stiff_steps, b.stiff_steps) << what;
    EXPECT_EQ(a.failed_check, b.failed_check) << what;
    // a fused step's first stage solves with its projection's factorisation; the generic
    // stages factorise again at the same positions, but in a contact scene, whose first stage
    // takes the active set's last solve on both paths (chooseContactModes)
    EXPECT_EQ(a.solve.factorizations + a.solve.reused_factorizations,
              b.solve.factorizations + b.solve.reused_factorizations)
        << what;
    EXPECT_EQ(b.solve.reused_factorizations,
              generic.model().numContacts() > 0 ? a.solve.reused_factorizations : 0)
        << what;
    reused += a.solve.reused_factorizations - b.solve.reused_factorizations;  // the fused path's
    EXPECT_EQ(a.solve.singular_count, b.solve.singular_count) << what;
    EXPECT_EQ(a.solve.singular, b.solve.singular) << what;
    if (exact)
      EXPECT_EQ(a.solve.min_pivot_ratio, b.solve.min_pivot_ratio) << what;
    else
      EXPECT_EQ(a.solve.fallbacks, 0) << what;
    generic_fallbacks += exact ? 0 : b.solve.fallbacks;
    EXPECT_EQ(a.solve.regularization, b.solve.regularization) << what;
    EXPECT_EQ(a.projection.projections, b.projection.projections) << what;
    EXPECT_EQ(a.projection.iterations, b.projection.iterations) << what;
    EXPECT_EQ(a.projection.singular, b.projection.singular) << what;
    EXPECT_EQ(a.projection.converged, b.projection.converged) << what;
    EXPECT_EQ(a.projection.max_iterations, b.projection.max_iterations) << what;
    EXPECT_LE(std::abs(a.projection.max_position_error - b.projection.max_position_error),
              exact ? 1e-15 : 1e-14)
        << what;
    // the reported constraint forces and multipliers, eliminated reactions included
    const Data& x = fused.data();
    const Data& y = generic.data();
    const double scale = 1.0 + y.constraint_forces.cwiseAbs().maxCoeff();
    EXPECT_LE((x.constraint_forces - y.constraint_forces).cwiseAbs().maxCoeff(), 1e-9 * scale)
        << what;
    if (y.multipliers.size() > 0)
    {
      EXPECT_LE((x.multipliers - y.multipliers).cwiseAbs().maxCoeff(),
                1e-9 * (1.0 + y.multipliers.cwiseAbs().maxCoeff()))
          << what;
    }
    if (singular)
      *singular = *singular || a.solve.singular;
    if (d.positions > close || d.velocities > close_velocity)
      break;  // one message is enough
  }
  const EffectCounters& a = fused.data().counters;
  const EffectCounters& b = generic.data().counters;
  EXPECT_EQ(a.forces, b.forces) << what;
  EXPECT_EQ(a.constraints, b.constraints) << what;
  // the reused factorisations are of the fused path's own method (tridiagonal or tree)
  const int fused_method = static_cast<int>(fused.model().solveMethod());
  const int sparse = static_cast<int>(SolveMethod::Sparse);
  for (int k = 0; k < NUM_SOLVE_METHODS; ++k)
    EXPECT_EQ(a.factorizations[k] + (k == fused_method ? reused : 0) +
                  (k == sparse ? generic_fallbacks : 0),
              b.factorizations[k])
        << what << ", method " << k;
  if (reused_out)
    *reused_out = reused;
  if (moved_out)
    *moved_out = moved;
  return fused.model().fusedChain();
}

}  // namespace testing
}  // namespace constrained_particles
