/// @file dual.hpp
/// @brief Dual numbers a + b eps (eps^2 = 0): forward-mode differentiation of a kind's Jacobian
/// along the velocity, which gives Jdot v = d/de [J(p + e v) v] exactly, without finite
/// differences.
#pragma once

#include "constrained_particles/core/types.hpp"

#include <cmath>

namespace constrained_particles
{
/// In a namespace of its own so that sqrt(Dual) does not hide sqrt(double) from unqualified
/// calls elsewhere in the core; the operators are found by argument-dependent lookup.
namespace dual
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
inline Dual3 cross(const Dual3& a, const Dual3& b)
{
  return { a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x };
}
inline Dual norm(const Dual3& a)
{
  return sqrt(dot(a, a));
}

/// A position [m] moving at a rate [m/s]: value + rate eps.
inline Dual3 moving(const Vec3& value, const Vec3& rate)
{
  return { { value.x(), rate.x() }, { value.y(), rate.y() }, { value.z(), rate.z() } };
}
/// A constant vector: its rate is zero.
inline Dual3 constant(const Vec3& value)
{
  return moving(value, Vec3::Zero());
}
/// The value parts.
inline Vec3 valueOf(const Dual3& a)
{
  return Vec3(a.x.value, a.y.value, a.z.value);
}
/// The derivative parts: the rate along the direction.
inline Vec3 rateOf(const Dual3& a)
{
  return Vec3(a.x.derivative, a.y.derivative, a.z.derivative);
}

}  // namespace dual
}  // namespace constrained_particles
