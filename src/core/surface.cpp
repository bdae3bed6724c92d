#include "constrained_particles/core/surface.hpp"

#include "surface_expression.hpp"
#include "constrained_particles/core/limits.hpp"
#include "constrained_particles/core/types.hpp"

#include <cmath>
#include <limits>
#include <sstream>

namespace constrained_particles
{
namespace
{
constexpr double INF = std::numeric_limits<double>::infinity();

// formulas, in enum order, for help texts
const char* const SURFACE_FORMULAS[] = {
  "Z = slope_x*x + slope_y*y + height",
  "Z = (curvature_x*x^2 + curvature_y*y^2)/2",
  "Z = (curvature_x*x^2 - curvature_y*y^2)/2",
  "Z = amplitude*sin(wavenumber_x*x)*cos(wavenumber_y*y)",
  "Z = height*exp(-((x-center_x)^2 + (y-center_y)^2)/(2*width^2))",
  "Z = a formula in x and y, e.g. 0.3*sin(2*x)*cos(y)",
};

const char* const SURFACE_NAMES[] = {
  "plane", "bowl", "saddle", "waves", "gaussian", "expression"
};
constexpr int NUM_SURFACE_TYPES = 6;

}  // namespace

SurfaceSample evaluateSurface(const Surface& surface, double x, double y)
{
  const auto& c = surface.coefficients;
  SurfaceSample s;
  switch (surface.type)
  {
    case SurfaceType::Plane:
      s.z = c[0] * x + c[1] * y + c[2];
      s.zx = c[0];
      s.zy = c[1];
      break;
    case SurfaceType::Bowl:
      s.z = 0.5 * (c[0] * x * x + c[1] * y * y);
      s.zx = c[0] * x;
      s.zy = c[1] * y;
      s.zxx = c[0];
      s.zyy = c[1];
      break;
    case SurfaceType::Saddle:
      s.z = 0.5 * (c[0] * x * x - c[1] * y * y);
      s.zx = c[0] * x;
      s.zy = -c[1] * y;
      s.zxx = c[0];
      s.zyy = -c[1];
      break;
    case SurfaceType::Waves:
    {
      const double sx = std::sin(c[1] * x), cx = std::cos(c[1] * x);
      const double sy = std::sin(c[2] * y), cy = std::cos(c[2] * y);
      s.z = c[0] * sx * cy;
      s.zx = c[0] * c[1] * cx * cy;
      s.zy = -c[0] * c[2] * sx * sy;
      s.zxx = -c[0] * c[1] * c[1] * sx * cy;
      s.zxy = -c[0] * c[1] * c[2] * cx * sy;
      s.zyy = -c[0] * c[2] * c[2] * sx * cy;
      break;
    }
    case SurfaceType::Gaussian:
    {
      // Z = h e, e = exp(-r^2 / (2 w^2)); dZ/dx = -Z dx / w^2
      const double inv_w2 = 1.0 / (c[1] * c[1]);
      const double dx = x - c[2], dy = y - c[3];
      const double z = c[0] * std::exp(-0.5 * (dx * dx + dy * dy) * inv_w2);
      s.z = z;
      s.zx = -z * dx * inv_w2;
      s.zy = -z * dy * inv_w2;
      s.zxx = z * (dx * dx * inv_w2 - 1.0) * inv_w2;
      s.zxy = z * dx * dy * inv_w2 * inv_w2;
      s.zyy = z * (dy * dy * inv_w2 - 1.0) * inv_w2;
      break;
    }
    case SurfaceType::Expression:
      return surface.expression->evaluate(x, y);
  }
  return s;
}

const char* surfaceTypeName(SurfaceType type)
{
  return SURFACE_NAMES[static_cast<int>(type)];
}

std::vector<std::string> surfaceTypeNames()
{
  return std::vector<std::string>(SURFACE_NAMES, SURFACE_NAMES + NUM_SURFACE_TYPES);
}

SurfaceType parseSurfaceType(const std::string& name, const std::string& field)
{
  for (int i = 0; i < NUM_SURFACE_TYPES; ++i)
    if (name == SURFACE_NAMES[i])
      return static_cast<SurfaceType>(i);
  std::string valid;
  for (int i = 0; i < NUM_SURFACE_TYPES; ++i)
    valid += std::string(i ? ", " : "") + SURFACE_NAMES[i];
  throw InvalidInput(field, "= '" + name + "' is not a surface type; valid: " + valid);
}

const std::vector<CoefficientSpec>& surfaceCoefficientSpecs(SurfaceType type)
{
  // the ranges are limits.hpp's, which says why each is bounded
  static const std::vector<CoefficientSpec> PLANE = {
    { "slope_x", 0.3, limits::SURFACE_SLOPE },
    { "slope_y", 0.0, limits::SURFACE_SLOPE },
    { "height", 0.0, limits::SURFACE_OFFSET },
  };
  static const std::vector<CoefficientSpec> BOWL = {
    { "curvature_x", 1.0, limits::SURFACE_CURVATURE },
    { "curvature_y", 1.0, limits::SURFACE_CURVATURE },
  };
  static const std::vector<CoefficientSpec> SADDLE = BOWL;
  static const std::vector<CoefficientSpec> WAVES = {
    { "amplitude", 0.2, limits::SURFACE_AMPLITUDE },
    { "wavenumber_x", 2.0, limits::SURFACE_WAVENUMBER },
    { "wavenumber_y", 1.0, limits::SURFACE_WAVENUMBER },
  };
  static const std::vector<CoefficientSpec> NONE = {};
  static const std::vector<CoefficientSpec> GAUSSIAN = {
    { "height", 0.5, limits::SURFACE_AMPLITUDE },
    { "width", 0.5, limits::SURFACE_WIDTH },
    { "center_x", 0.0, limits::SURFACE_OFFSET },
    { "center_y", 0.0, limits::SURFACE_OFFSET },
  };
  switch (type)
  {
    case SurfaceType::Plane:
      return PLANE;
    case SurfaceType::Bowl:
      return BOWL;
    case SurfaceType::Saddle:
      return SADDLE;
    case SurfaceType::Waves:
      return WAVES;
    case SurfaceType::Gaussian:
      return GAUSSIAN;
    case SurfaceType::Expression:
      return NONE;
  }
  throw InvalidInput("surface.type", "is not a known surface type");
}

Surface makeSurface(SurfaceType type, const std::vector<double>& coefficients,
                    const std::string& field)
{
  if (type == SurfaceType::Expression)
    throw InvalidInput(field,
                       "cannot define surface 'expression': it takes a formula, not "
                       "coefficients");
  const auto& specs = surfaceCoefficientSpecs(type);
  if (coefficients.size() > specs.size())
  {
    throw InvalidInput(field, "has " + std::to_string(coefficients.size()) + " values; surface '" +
                                  surfaceTypeName(type) + "' takes at most " +
                                  std::to_string(specs.size()) + " (" + describeSurfaceTypes() +
                                  ")");
  }
  Surface surface;
  surface.type = type;
  surface.coefficients.fill(0.0);
  for (std::size_t i = 0; i < specs.size(); ++i)
  {
    const CoefficientSpec& spec = specs[i];
    const double value = i < coefficients.size() ? coefficients[i] : spec.default_value;
    if (!spec.range.contains(value))
    {
      throw InvalidInput(field + "[" + std::to_string(i) + "] (" + spec.name + ")",
                         "= " + formatValue(value) + ", must be in " + spec.range.text() +
                             " for surface '" + surfaceTypeName(type) + "'");
    }
    surface.coefficients[i] = value;
  }
  return surface;
}

Surface makeSurface(const std::string& type_name, const std::vector<double>& coefficients)
{
  return makeSurface(parseSurfaceType(type_name), coefficients);
}

Surface makeExpressionSurface(const std::string& formula, const std::string& field)
{
  Surface surface;
  surface.type = SurfaceType::Expression;
  surface.coefficients.fill(0.0);
  surface.expression = SurfaceExpression::parse(formula, field);
  return surface;
}

void validateSurface(const Surface& surface, const std::string& field)
{
  if (surface.type == SurfaceType::Expression)
  {
    if (!surface.expression)
      throw InvalidInput(field + ".expression", "is missing for surface type 'expression'");
    return;
  }
  const auto& specs = surfaceCoefficientSpecs(surface.type);
  std::vector<double> coefficients(surface.coefficients.begin(),
                                   surface.coefficients.begin() + specs.size());
  makeSurface(surface.type, coefficients, field + ".coefficients");
}

std::string describeSurfaceTypes()
{
  std::ostringstream out;
  for (int i = 0; i < NUM_SURFACE_TYPES; ++i)
  {
    out << (i ? "; " : "") << SURFACE_NAMES[i] << ": " << SURFACE_FORMULAS[i] << ", coefficients [";
    const auto& specs = surfaceCoefficientSpecs(static_cast<SurfaceType>(i));
    for (std::size_t k = 0; k < specs.size(); ++k)
      out << (k ? ", " : "") << specs[k].name << " [" << specs[k].range.unit << "]";
    out << "]";
  }
  return out.str();
}

}  // namespace constrained_particles
