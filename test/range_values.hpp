// Values a range must refuse and values it must keep exactly, shared by the entry-point tests of
// the core (test/core) and of the node (test/ros).
#pragma once

#include "constrained_particles/core/limits.hpp"

#include <cmath>
#include <limits>
#include <vector>

namespace constrained_particles
{
namespace testing
{
/// NaN, the infinities, the nearest doubles outside each end (for counts: one past each end,
/// and a fraction).
inline std::vector<double> badValues(const Range& range)
{
  constexpr double INF = std::numeric_limits<double>::infinity();
  std::vector<double> bad{ NAN, INF, -INF };
  if (range.integer)
  {
    bad.push_back(range.low - 1);
    bad.push_back(range.high + 1);
    bad.push_back(range.low + 0.5);
  }
  else
  {
    bad.push_back(range.low_open ? range.low : std::nextafter(range.low, -INF));
    bad.push_back(std::nextafter(range.high, INF));
  }
  return bad;
}

/// The range's edges (the nearest double inside an open end) and its middle.
inline std::vector<double> goodValues(const Range& range)
{
  constexpr double INF = std::numeric_limits<double>::infinity();
  const double low = range.low_open ? std::nextafter(range.low, INF) : range.low;
  double middle = 0.5 * (low + range.high);
  if (range.integer)
    middle = std::floor(middle);
  return { low, middle, range.high };
}

}  // namespace testing
}  // namespace constrained_particles
