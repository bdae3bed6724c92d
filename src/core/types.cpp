#include "constrained_particles/core/types.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace constrained_particles
{
std::string formatValue(double value)
{
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  // prefer the short form when it round-trips
  for (int precision = 1; precision < 17; ++precision)
  {
    char shorter[32];
    std::snprintf(shorter, sizeof(shorter), "%.*g", precision, value);
    if (std::strtod(shorter, nullptr) == value || std::isnan(value))
      return shorter;
  }
  return buffer;
}

void requireFinite(const std::string& field, double value, const std::string& unit)
{
  if (!std::isfinite(value))
    throw InvalidInput(field, "= " + formatValue(value) + ", must be a finite number " + unit);
}

void requirePositive(const std::string& field, double value, const std::string& unit)
{
  if (!std::isfinite(value) || value <= 0.0)
    throw InvalidInput(field, "= " + formatValue(value) + ", must be finite and > 0 " + unit);
}

void requireNonNegative(const std::string& field, double value, const std::string& unit)
{
  if (!std::isfinite(value) || value < 0.0)
    throw InvalidInput(field, "= " + formatValue(value) + ", must be finite and >= 0 " + unit);
}

void requireFinite(const std::string& field, const Vec3& value, const std::string& unit)
{
  for (int axis = 0; axis < 3; ++axis)
  {
    static const char* const AXIS_NAMES[] = { "x", "y", "z" };
    requireFinite(field + "." + AXIS_NAMES[axis], value[axis], unit);
  }
}

}  // namespace constrained_particles
