/// @file types.hpp
/// @brief Basic types of the ROS-free core: vectors, particle arrays, and the input error.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <stdexcept>
#include <string>

namespace constrained_particles
{
/// A 3-vector: a position [m], velocity [m/s], force [N] or acceleration [m/s^2].
using Vec3 = Eigen::Vector3d;

/// One 3-vector per particle, stored column-wise (column i is particle i): shape 3 x n.
using Points = Eigen::Matrix3Xd;

/// Rejected input: names the offending field, its value and its valid range.
class InvalidInput : public std::invalid_argument
{
public:
  /// @param field dotted name of the offending field, e.g. "chain.link_length"
  /// @param reason what is wrong and what is valid, e.g. "= -1, must be in (0, 1000] [m]"
  InvalidInput(const std::string& field, const std::string& reason)
    : std::invalid_argument(field + " " + reason), field_(field)
  {
  }

  /// Name of the offending field.
  const std::string& field() const
  {
    return field_;
  }

private:
  std::string field_;
};

/// The larger of two errors, a NaN counting as infinitely large (std::max would drop it).
inline double worseError(double current, double value)
{
  if (std::isnan(value))
    return INFINITY;
  return value > current ? value : current;
}

/// Formats a double the way error messages quote values (shortest round-trip form).
std::string formatValue(double value);

/// Throws InvalidInput unless value is finite.
void requireFinite(const std::string& field, double value, const std::string& unit);

/// Throws InvalidInput naming `field.x`, `.y` or `.z` unless every component is finite.
void requireFinite(const std::string& field, const Vec3& value, const std::string& unit);

}  // namespace constrained_particles
