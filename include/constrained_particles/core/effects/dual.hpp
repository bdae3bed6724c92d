/// @file dual.hpp
/// @brief Dual numbers a + b eps (eps^2 = 0): forward-mode differentiation of a kind's Jacobian
/// along the velocity, which gives Jdot v = d/de [J(p + e v) v] exactly, without finite
/// differences.
#pragma once

#include <cmath>

namespace constrained_particles
{
/// a + b eps: value and derivative along one direction.
struct Dual
{
  double value = 0.0;
  double derivative = 0.0;
};

inline Dual operator+(Dual a, Dual b)
{
  return { a.value + b.value, a.derivative + b.derivative };
}
inline Dual operator-(Dual a, Dual b)
{
  return { a.value - b.value, a.derivative - b.derivative };
}
inline Dual operator-(Dual a)
{
  return { -a.value, -a.derivative };
}
inline Dual operator*(Dual a, Dual b)
{
  return { a.value * b.value, a.derivative * b.value + a.value * b.derivative };
}
inline Dual operator/(Dual a, Dual b)
{
  return { a.value / b.value,
           (a.derivative * b.value - a.value * b.derivative) / (b.value * b.value) };
}
inline Dual sqrt(Dual a)
{
  const double root = std::sqrt(a.value);
  return { root, a.derivative / (2.0 * root) };
}

/// A 3-vector of duals: a position and its rate along the direction.
struct Dual3
{
  Dual x, y, z;
};

inline Dual3 operator+(const Dual3& a, const Dual3& b)
{
  return { a.x + b.x, a.y + b.y, a.z + b.z };
}
inline Dual3 operator-(const Dual3& a, const Dual3& b)
{
  return { a.x - b.x, a.y - b.y, a.z - b.z };
}
inline Dual3 operator*(Dual s, const Dual3& a)
{
  return { s * a.x, s * a.y, s * a.z };
}
inline Dual dot(const Dual3& a, const Dual3& b)
{
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

}  // namespace constrained_particles
