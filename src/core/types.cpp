#include "constrained_particles/core/limits.hpp"
#include "constrained_particles/core/types.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace constrained_particles
{
std::string formatValue(double value)
{
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  // prefer the short form when it round-trips, and whole numbers written out when no longer
  // (1000, not 1e+03; but 1e+06)
  for (int precision = 1; precision < 17; ++precision)
  {
    char shorter[32];
    std::snprintf(shorter, sizeof(shorter), "%.*g", precision, value);
    if (std::strtod(shorter, nullptr) == value || std::isnan(value))
    {
      if (std::isfinite(value) && value == std::floor(value) && std::abs(value) < 1e15)
      {
        char whole[32];
        std::snprintf(whole, sizeof(whole), "%.0f", value);
        if (std::strlen(whole) <= std::strlen(shorter))
          return whole;
      }
      return shorter;
    }
  }
  return buffer;
}

void requireFinite(const std::string& field, double value, const std::string& unit)
{
  if (!std::isfinite(value))
    throw InvalidInput(field, "= " + formatValue(value) + ", must be a finite number " + unit);
}

namespace
{
const char* const AXIS_NAMES[] = { "x", "y", "z" };
}

void requireFinite(const std::string& field, const Vec3& value, const std::string& unit)
{
  for (int axis = 0; axis < 3; ++axis)
    requireFinite(field + "." + AXIS_NAMES[axis], value[axis], unit);
}

bool Range::contains(double value) const
{
  if (!std::isfinite(value) || value > high || (low_open ? !(value > low) : !(value >= low)))
    return false;
  return !integer || value == std::floor(value);
}

std::string Range::interval() const
{
  return std::string(low_open ? "(" : "[") + formatValue(low) + ", " + formatValue(high) + "]";
}

std::string Range::text() const
{
  return interval() + " [" + unit + "]";
}

void requireInRange(const std::string& field, double value, const Range& range)
{
  if (!range.contains(value))
    throw InvalidInput(field, "= " + formatValue(value) + ", must be in " + range.text() +
                                  (range.integer ? " (a whole number)" : ""));
}

void requireInRange(const std::string& field, const Vec3& value, const Range& range)
{
  for (int axis = 0; axis < 3; ++axis)
    requireInRange(field + "." + AXIS_NAMES[axis], value[axis], range);
}

}  // namespace constrained_particles
