/// @file row_block.hpp
/// @brief What a constraint kind reads and writes when it evaluates its rows: the context
/// (surfaces, time), a view of its rows' slots in Data, and the motion an eliminated kind
/// imposes.
#pragma once

#include "constrained_particles/core/surface.hpp"
#include "constrained_particles/core/types.hpp"

#include <vector>

namespace constrained_particles
{
class AnchorTrack;

/// What row evaluation may read besides the state.
struct EffectContext
{
  const std::vector<Surface>& surfaces;  ///< the scene's height fields
  double time;                           ///< simulated time [s]
  /// Positions a kind that picks a frame by position (collinear) picks it at, so that rows
  /// evaluated at trial positions stay in the frame of their reference Jacobian (SHAKE);
  /// nullptr: the positions being evaluated.
  const Points* frame_positions = nullptr;
  /// The carried shapes' tracks (Data::carriers, Model::carriers() order); nullptr: every shape
  /// at its own pose, at rest.
  const std::vector<AnchorTrack>* carriers = nullptr;
};

/// Where an eliminated kind holds its particle at a time t: exactly, not as rows.
struct ImposedMotion
{
  Vec3 position;      ///< [m]
  Vec3 velocity;      ///< [m/s]
  Vec3 acceleration;  ///< [m/s^2]
};

/// The rows of one constraint record, as its kind fills them: ROWS rows, each touching the
/// record's PARTICLES particles (rowParticles order), so ROWS x PARTICLES Jacobian blocks,
/// row-major.
struct RowBlock
{
  double* value;      ///< C, one per row (the kind's unit)
  double* jdot_v;     ///< Jdot v, one per row
  double* violation;  ///< metric position error of each row [m], >= 0
  Vec3* jacobian;     ///< dC/dp_k of row r at jacobian[r * PARTICLES + k]
  /// dC/dt at fixed positions, one per row, for rows on a moving body (a carried shape's
  /// contact): Cdot = J v + dC/dt. nullptr where the caller does not read it; kinds whose rows do
  /// not move leave it untouched (Data keeps it 0).
  double* time_rate = nullptr;
};

}  // namespace constrained_particles
