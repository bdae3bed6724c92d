/// @file surface.hpp
/// @brief Height-field surfaces z = Z(x, y) with analytic gradient and Hessian.
#pragma once

#include "constrained_particles/core/limits.hpp"

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace constrained_particles
{
/// Kinds of height field. Coefficients are listed in surfaceCoefficientSpecs().
enum class SurfaceType
{
  Plane,       ///< Z = slope_x x + slope_y y + height
  Bowl,        ///< Z = (curvature_x x^2 + curvature_y y^2) / 2   (paraboloid)
  Saddle,      ///< Z = (curvature_x x^2 - curvature_y y^2) / 2
  Waves,       ///< Z = amplitude sin(wavenumber_x x) cos(wavenumber_y y)
  Gaussian,    ///< Z = height exp(-((x - center_x)^2 + (y - center_y)^2) / (2 width^2))
  Expression,  ///< Z = a formula in x and y (surface_expression.hpp); no coefficients
};

class SurfaceExpression;

/// Maximum number of coefficients of any surface type.
constexpr int MAX_SURFACE_COEFFICIENTS = 4;

/// A height field: a type tag and its coefficients (order as in surfaceCoefficientSpecs()).
struct Surface
{
  SurfaceType type = SurfaceType::Bowl;
  std::array<double, MAX_SURFACE_COEFFICIENTS> coefficients{ { 1.0, 1.0, 0.0, 0.0 } };
  std::shared_ptr<const SurfaceExpression> expression;  ///< the formula, for Expression only
};

/// Z and its first and second partial derivatives at one (x, y).
struct SurfaceSample
{
  double z = 0;    ///< Z(x, y) [m]
  double zx = 0;   ///< dZ/dx [1]
  double zy = 0;   ///< dZ/dy [1]
  double zxx = 0;  ///< d2Z/dx2 [1/m]
  double zxy = 0;  ///< d2Z/dxdy [1/m]
  double zyy = 0;  ///< d2Z/dy2 [1/m]
};

/// Description of one coefficient: its name, default and valid range (with its unit).
struct CoefficientSpec
{
  const char* name;
  double default_value;
  Range range;
};

/// Evaluates Z, gradient and Hessian of a surface at (x, y) [m]. Stateless; no allocation.
SurfaceSample evaluateSurface(const Surface& surface, double x, double y);

/// Name of a surface type as used in parameters and services ("plane", "bowl", ...).
const char* surfaceTypeName(SurfaceType type);

/// Names of every surface type, in enum order.
std::vector<std::string> surfaceTypeNames();

/// Parses a surface type name. @throws InvalidInput naming field and the valid names.
SurfaceType parseSurfaceType(const std::string& name, const std::string& field = "surface.type");

/// The coefficients of a surface type, in order.
const std::vector<CoefficientSpec>& surfaceCoefficientSpecs(SurfaceType type);

/// Builds a validated surface. An empty coefficient list takes every default; a shorter list
/// fills the rest with defaults.
/// @throws InvalidInput naming the coefficient, its value and valid range.
Surface makeSurface(SurfaceType type, const std::vector<double>& coefficients,
                    const std::string& field = "surface.coefficients");

/// makeSurface() from a type name. @throws InvalidInput for an unknown name or bad coefficient.
Surface makeSurface(const std::string& type_name, const std::vector<double>& coefficients);

/// A surface Z = formula(x, y), e.g. "0.3*sin(2*x)*cos(y)".
/// @throws InvalidInput naming `field` and the position of the first error in the formula
Surface makeExpressionSurface(const std::string& formula, const std::string& field = "expression");

/// Throws InvalidInput unless the surface is valid (coefficients in range, or a parsed formula).
void validateSurface(const Surface& surface, const std::string& field);

/// One line per type: its formula and coefficients with units and ranges (for help texts).
std::string describeSurfaceTypes();

}  // namespace constrained_particles
