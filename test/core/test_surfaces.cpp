// Surface gradients and Hessians against central finite differences on random points.
#include "constrained_particles/core/surface.hpp"
#include "test_helpers.hpp"

#include <gtest/gtest.h>

using namespace constrained_particles;
using constrained_particles::testing::FD_STEP;
using constrained_particles::testing::Random;

namespace
{
// random, valid coefficients of moderate size for each type
Surface randomSurface(SurfaceType type, Random& random)
{
  switch (type)
  {
    case SurfaceType::Plane:
      return makeSurface(type,
                         { random.uniform(-2, 2), random.uniform(-2, 2), random.uniform(-1, 1) });
    case SurfaceType::Bowl:
    case SurfaceType::Saddle:
      return makeSurface(type, { random.uniform(0.1, 3), random.uniform(0.1, 3) });
    case SurfaceType::Waves:
      return makeSurface(type,
                         { random.uniform(-1, 1), random.uniform(0.5, 4), random.uniform(0.5, 4) });
    case SurfaceType::Gaussian:
      return makeSurface(type, { random.uniform(-1, 1), random.uniform(0.3, 2),
                                 random.uniform(-1, 1), random.uniform(-1, 1) });
    case SurfaceType::Expression:  // has no coefficients: test_surface_expression covers it
      break;
  }
  return Surface{};
}

class SurfaceDerivatives : public ::testing::TestWithParam<SurfaceType>
{
};

}  // namespace

TEST_P(SurfaceDerivatives, GradientAndHessianMatchCentralDifferences)
{
  Random random(static_cast<unsigned>(GetParam()) + 1);
  for (int trial = 0; trial < 200; ++trial)
  {
    const Surface surface = randomSurface(GetParam(), random);
    const double x = random.uniform(-2, 2), y = random.uniform(-2, 2);
    const double h = FD_STEP;
    const SurfaceSample s = evaluateSurface(surface, x, y);
    const SurfaceSample xp = evaluateSurface(surface, x + h, y),
                        xm = evaluateSurface(surface, x - h, y);
    const SurfaceSample yp = evaluateSurface(surface, x, y + h),
                        ym = evaluateSurface(surface, x, y - h);
    const double scale = 1.0 + std::abs(s.z) + std::abs(s.zx) + std::abs(s.zy);
    EXPECT_NEAR(s.zx, (xp.z - xm.z) / (2 * h), 1e-7 * scale) << surfaceTypeName(GetParam());
    EXPECT_NEAR(s.zy, (yp.z - ym.z) / (2 * h), 1e-7 * scale) << surfaceTypeName(GetParam());
    const double hessian_scale = 1.0 + std::abs(s.zxx) + std::abs(s.zxy) + std::abs(s.zyy);
    EXPECT_NEAR(s.zxx, (xp.zx - xm.zx) / (2 * h), 1e-6 * hessian_scale);
    EXPECT_NEAR(s.zxy, (yp.zx - ym.zx) / (2 * h), 1e-6 * hessian_scale);
    EXPECT_NEAR(s.zxy, (xp.zy - xm.zy) / (2 * h), 1e-6 * hessian_scale);
    EXPECT_NEAR(s.zyy, (yp.zy - ym.zy) / (2 * h), 1e-6 * hessian_scale);
  }
}

INSTANTIATE_TEST_SUITE_P(AllSurfaces, SurfaceDerivatives,
                         ::testing::Values(SurfaceType::Plane, SurfaceType::Bowl,
                                           SurfaceType::Saddle, SurfaceType::Waves,
                                           SurfaceType::Gaussian),
                         [](const ::testing::TestParamInfo<SurfaceType>& info)
                         { return std::string(surfaceTypeName(info.param)); });

TEST(Surface, FormulasAtKnownPoints)
{
  EXPECT_DOUBLE_EQ(evaluateSurface(makeSurface("plane", { 0.5, -1.0, 2.0 }), 2.0, 3.0).z, 0.0);
  EXPECT_DOUBLE_EQ(evaluateSurface(makeSurface("bowl", { 2.0, 4.0 }), 1.0, 1.0).z, 3.0);
  EXPECT_DOUBLE_EQ(evaluateSurface(makeSurface("saddle", { 2.0, 4.0 }), 1.0, 1.0).z, -1.0);
  EXPECT_NEAR(evaluateSurface(makeSurface("waves", { 0.5, M_PI, 0.0 }), 0.5, 7.0).z, 0.5, 1e-15);
  EXPECT_DOUBLE_EQ(evaluateSurface(makeSurface("gaussian", { 2.0, 1.0, 1.0, -1.0 }), 1.0, -1.0).z,
                   2.0);
}

TEST(Surface, DefaultsFillMissingCoefficients)
{
  const Surface bowl = makeSurface("bowl", {});
  EXPECT_EQ(bowl.type, SurfaceType::Bowl);
  EXPECT_DOUBLE_EQ(bowl.coefficients[0], 1.0);
  EXPECT_DOUBLE_EQ(bowl.coefficients[1], 1.0);
  const Surface gaussian = makeSurface("gaussian", { 1.5 });
  EXPECT_DOUBLE_EQ(gaussian.coefficients[0], 1.5);
  EXPECT_DOUBLE_EQ(gaussian.coefficients[1], 0.5);
}
