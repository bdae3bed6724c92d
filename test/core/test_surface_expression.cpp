// Surfaces from a formula: automatic derivatives against closed forms and central differences,
// parse errors with their position, and the same motion as the built-in surface it spells out.
#include "constrained_particles/core/simulator.hpp"
#include "surface_expression.hpp"  // private to the core: these tests read its internals
#include "test_helpers.hpp"

#include <gtest/gtest.h>

using namespace constrained_particles;
using constrained_particles::testing::beadScene;
using constrained_particles::testing::Random;

namespace
{
void expectSameSample(const SurfaceSample& a, const SurfaceSample& b, double tolerance)
{
  EXPECT_NEAR(a.z, b.z, tolerance);
  EXPECT_NEAR(a.zx, b.zx, tolerance);
  EXPECT_NEAR(a.zy, b.zy, tolerance);
  EXPECT_NEAR(a.zxx, b.zxx, tolerance);
  EXPECT_NEAR(a.zxy, b.zxy, tolerance);
  EXPECT_NEAR(a.zyy, b.zyy, tolerance);
}

std::string refusal(const std::string& formula)
{
  try
  {
    makeExpressionSurface(formula);
  }
  catch (const InvalidInput& e)
  {
    EXPECT_EQ(e.field(), "expression");
    return e.what();
  }
  ADD_FAILURE() << "accepted '" << formula << "'";
  return "";
}

}  // namespace

TEST(SurfaceExpression, MatchesBuiltInSurfaces)
{
  Random random(31);
  const std::vector<std::pair<std::string, Surface>> pairs = {
    { "0.3*sin(2*x)*cos(y)", makeSurface("waves", { 0.3, 2.0, 1.0 }) },
    { "(1.5*x^2 + 0.5*y^2)/2", makeSurface("bowl", { 1.5, 0.5 }) },
    { "0.5*x*x - 0.25 * y^2", makeSurface("saddle", { 1.0, 0.5 }) },
    { "0.4*x - 0.2*y + 1", makeSurface("plane", { 0.4, -0.2, 1.0 }) },
    { "0.5*exp(-((x-0.1)^2 + (y+0.2)^2)/(2*0.3^2))",
      makeSurface("gaussian", { 0.5, 0.3, 0.1, -0.2 }) },
  };
  for (const auto& [formula, builtin] : pairs)
  {
    const Surface expression = makeExpressionSurface(formula);
    for (int trial = 0; trial < 50; ++trial)
    {
      const double x = random.uniform(-2, 2), y = random.uniform(-2, 2);
      expectSameSample(evaluateSurface(expression, x, y), evaluateSurface(builtin, x, y), 1e-13);
    }
  }
}

TEST(SurfaceExpression, DerivativesMatchCentralDifferences)
{
  const Surface surface = makeExpressionSurface(
      "exp(-x^2 - y^2)*sin(3*x*y) + sqrt(1 + x^2) - log(2 + cos(y)) + tanh(x/2) + 2^x + x^y "
      "+ tan(0.3*y) + abs(x - 5) + pi*e/10");
  Random random(32);
  const double h = 1e-6;
  for (int trial = 0; trial < 200; ++trial)
  {
    const double x = random.uniform(0.5, 1.5), y = random.uniform(-1, 1);
    const SurfaceSample s = evaluateSurface(surface, x, y);
    const SurfaceSample xp = evaluateSurface(surface, x + h, y),
                        xm = evaluateSurface(surface, x - h, y);
    const SurfaceSample yp = evaluateSurface(surface, x, y + h),
                        ym = evaluateSurface(surface, x, y - h);
    EXPECT_NEAR(s.zx, (xp.z - xm.z) / (2 * h), 1e-7);
    EXPECT_NEAR(s.zy, (yp.z - ym.z) / (2 * h), 1e-7);
    EXPECT_NEAR(s.zxx, (xp.zx - xm.zx) / (2 * h), 1e-6);
    EXPECT_NEAR(s.zxy, (yp.zx - ym.zx) / (2 * h), 1e-6);
    EXPECT_NEAR(s.zxy, (xp.zy - xm.zy) / (2 * h), 1e-6);
    EXPECT_NEAR(s.zyy, (yp.zy - ym.zy) / (2 * h), 1e-6);
  }
}

TEST(SurfaceExpression, PrecedenceAndAssociativity)
{
  auto z = [](const std::string& formula, double x = 2.0, double y = 3.0)
  { return evaluateSurface(makeExpressionSurface(formula), x, y).z; };
  EXPECT_DOUBLE_EQ(z("1 + 2*3"), 7.0);
  EXPECT_DOUBLE_EQ(z("2^3^2"), 512.0);  // right-associative
  EXPECT_DOUBLE_EQ(z("-x^2"), -4.0);    // unary minus binds looser than ^
  EXPECT_DOUBLE_EQ(z("2^-x"), 0.25);
  EXPECT_DOUBLE_EQ(z("-(-y)"), 3.0);
  EXPECT_DOUBLE_EQ(z("x - y - 1"), -2.0);
  EXPECT_DOUBLE_EQ(z("12 / x / y"), 2.0);
  EXPECT_DOUBLE_EQ(z("1.5e2 + .5"), 150.5);
}

TEST(SurfaceExpression, BadFormulasAreRefusedWithThePosition)
{
  EXPECT_NE(refusal("0.3*sin(2*x").find("at position 12, expected ')'"), std::string::npos);
  EXPECT_NE(refusal("x + * y").find("at position 5"), std::string::npos);
  EXPECT_NE(refusal("foo(x)").find("at position 1, unknown name 'foo'"), std::string::npos);
  EXPECT_NE(refusal("").find("at position 1"), std::string::npos);
  EXPECT_NE(refusal("x y").find("at position 3, expected an operator"), std::string::npos);
  EXPECT_NE(refusal("sin x").find("at position 5, expected '(' after sin"), std::string::npos);
  EXPECT_NE(refusal(std::string(2000, '(')).find("at most 1000"), std::string::npos);
  EXPECT_THROW(makeSurface("expression", {}), InvalidInput);
}

TEST(SurfaceExpression, BeadMovesAsOnTheBuiltInSurface)
{
  auto run = [](const Surface& surface)
  {
    const Scene scene = beadScene(surface);
    State start;
    start.positions = Vec3(0.5, 0.0, evaluateSurface(surface, 0.5, 0.0).z);
    start.velocities = Vec3(0.0, 0.8, 0.0);
    StepSettings settings;
    settings.dt = 1e-3;
    Simulator simulator(scene, start, settings);
    simulator.step(2000);
    return Points(simulator.state().positions);
  };
  const Points expression = run(makeExpressionSurface("0.3*sin(2*x)*cos(y)"));
  const Points builtin = run(makeSurface("waves", { 0.3, 2.0, 1.0 }));
  EXPECT_LE((expression - builtin).norm(), 1e-10);
}
