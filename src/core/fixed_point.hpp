/// @file fixed_point.hpp
/// @brief Anderson acceleration of a fixed-point iteration x = G(x) (Anderson 1965; Walker and
/// Ni 2011, "Anderson acceleration for fixed-point iterations", SIAM J. Numer. Anal. 49(4), type
/// II): the next iterate mixes the last few images so that their residuals' combination is least
/// in the 2-norm. On a linear G, with its whole history and no regularisation, it is GMRES's
/// iterate (Walker and Ni, section 2.3); the friction iteration (contact.hpp) is linear between
/// its cone clamps, where the plain iteration only shrinks its change by about 0.75 a solve.
/// Private to the core.
#pragma once

#include "constrained_particles/core/data.hpp"

#include <Eigen/Core>

namespace constrained_particles
{
/// The most differences a history holds (the fit's normal equations are fixed-size at this).
constexpr int MAX_ANDERSON_DEPTH = 8;

/// Sizes the history for iterates of `dimension` and up to `depth` (>= 1) differences, empty.
void resizeHistory(FixedPointHistory& history, int dimension, int depth);

/// Forgets every difference (the next step is a plain one, next = G(x)).
inline void clearHistory(FixedPointHistory& history)
{
  history.count = 0;
  history.head = 0;
  history.has_last = false;
}

/// The next iterate from x and its image g = G(x) (each `dimension`): g - (dX + dR) gamma, gamma
/// the least-squares fit of r = g - x by the held residual differences dR (normal equations of
/// at most depth x depth, with no heap allocation). With no history, or a fit that is not finite,
/// it is g (a plain step). Records x and r for the next call. `next` may not alias x or g.
/// Its normal equations are fixed-size: depth at most MAX_ANDERSON_DEPTH.
void andersonStep(FixedPointHistory& history, const Eigen::VectorXd& x, const Eigen::VectorXd& g,
                  Eigen::VectorXd& next);

}  // namespace constrained_particles
