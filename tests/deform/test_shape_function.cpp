// Shape functions (section III.B): closed-form values, analytic derivatives
// against finite differences, compact support and the zero plane integral of
// the volume-conserving shape.

#include "deform/shape_function.h"

#include <gtest/gtest.h>

#include <cmath>

namespace palpa::deform {
namespace {

constexpr ShapeKind kKinds[] = {ShapeKind::Gaussian, ShapeKind::Wendland, ShapeKind::VolumeConserving};

TEST(ShapeFunction, ClosedFormValues) {
  const double R = 0.02;
  const ShapeFunction g{ShapeKind::Gaussian, R};
  const ShapeFunction w{ShapeKind::Wendland, R};
  const ShapeFunction v{ShapeKind::VolumeConserving, R};
  // S(0) = 1 for every kind.
  for (ShapeKind k : kKinds) EXPECT_DOUBLE_EQ((ShapeFunction{k, R}.value(0.0)), 1.0);
  // Gaussian at r = sigma = R/4: exp(-1/2); at r = R/2: exp(-2).
  EXPECT_NEAR(g.value(R / 4), std::exp(-0.5), 1e-15);
  EXPECT_NEAR(g.value(R / 2), std::exp(-2.0), 1e-15);
  // Wendland at u = 1/2: (1/2)^4 * 3 = 3/16.
  EXPECT_NEAR(w.value(R / 2), 3.0 / 16.0, 1e-15);
  // Volume conserving at u = 1/2: (1 - 5/4)(3/4)^3 = -27/256; zero at u = 1/sqrt(5).
  EXPECT_NEAR(v.value(R / 2), -27.0 / 256.0, 1e-15);
  EXPECT_NEAR(v.value(R / std::sqrt(5.0)), 0.0, 1e-15);
  EXPECT_GT(v.value(0.99 * R / std::sqrt(5.0)), 0.0);
  EXPECT_LT(v.value(1.01 * R / std::sqrt(5.0)), 0.0);
}

TEST(ShapeFunction, CompactSupport) {
  const double R = 0.03;
  for (ShapeKind k : kKinds) {
    const ShapeFunction s{k, R};
    EXPECT_EQ(s.value(R), 0.0);
    EXPECT_EQ(s.value(2 * R), 0.0);
    EXPECT_EQ(s.derivative(R), 0.0);
    EXPECT_EQ(s.derivative(5 * R), 0.0);
  }
  // Wendland and VolumeConserving are C2 at the support: value and slope vanish continuously.
  for (ShapeKind k : {ShapeKind::Wendland, ShapeKind::VolumeConserving}) {
    const ShapeFunction s{k, R};
    const double r = R * (1 - 1e-4);
    EXPECT_LT(std::abs(s.value(r)), 1e-10);
    EXPECT_LT(std::abs(s.derivative(r)) * R, 1e-6);
  }
  // A non-positive radius has no support at all.
  EXPECT_EQ((ShapeFunction{ShapeKind::Wendland, 0.0}.value(0.0)), 0.0);
}

TEST(ShapeFunction, DerivativeMatchesCentralDifferences) {
  const double R = 0.025;
  for (ShapeKind k : kKinds) {
    SCOPED_TRACE(static_cast<int>(k));
    const ShapeFunction s{k, R};
    // Stay clear of r = 0 (where |r| has a kink) and of the Gaussian's cut at R.
    for (int j = 1; j < 99; ++j) {
      const double r = R * j / 100.0;
      const double e = 1e-7 * R;
      const double fd = (s.value(r + e) - s.value(r - e)) / (2 * e);
      EXPECT_NEAR(s.derivative(r), fd, 1e-6 / R) << "r = " << r;
    }
    EXPECT_EQ(s.derivative(0.0), 0.0);
  }
}

TEST(ShapeFunction, VolumeConservingIntegratesToZeroOverAPlane) {
  // 2 pi int_0^R S(r) r dr by composite Simpson: zero for VolumeConserving,
  // while the pushed-in part alone is clearly not.
  const double R = 0.04;
  const ShapeFunction s{ShapeKind::VolumeConserving, R};
  const int n = 20000;
  const double h = R / n;
  double total = 0, pushed = 0;
  for (int i = 0; i <= n; ++i) {
    const double r = i * h;
    const double w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
    const double f = s.value(r) * r;
    total += w * f;
    if (f > 0) pushed += w * f;
  }
  total *= 2 * M_PI * h / 3;
  pushed *= 2 * M_PI * h / 3;
  // Closed form of the pushed-in part: pi R^2 int_0^{1/5} (1-5w)(1-w)^3 dw = pi R^2 256/3125.
  EXPECT_NEAR(pushed, M_PI * R * R * 256.0 / 3125.0, 1e-6 * pushed);
  EXPECT_LT(std::abs(total), 1e-10 * pushed);
}

TEST(ShapeFunction, EvaluateGivesValueAndDerivativeBits) {
  // evaluate() is what the force fields call: the same bits as the two
  // separate functions, inside, at and beyond the support, for r < 0 too;
  // also with the inverse radius the field computes once (radii whose
  // inverse is not exact in binary).
  for (ShapeKind kind : {ShapeKind::Gaussian, ShapeKind::Wendland, ShapeKind::VolumeConserving}) {
    for (double radius : {0.02, 0.015, 0.0123}) {
      const ShapeFunction s{kind, radius};
      for (double f : {0.0, 5e-8, 0.15, 0.355, 0.999995, 1.0, 1.5, -0.2}) {
        const double r = f * radius;
        double value = -1, slope = -1;
        s.evaluate(r, value, slope);
        EXPECT_EQ(value, s.value(r)) << "r " << r;
        EXPECT_EQ(slope, s.derivative(r)) << "r " << r;
        double value2 = -1, slope2 = -1;
        s.evaluate(r, 1.0 / radius, value2, slope2);
        EXPECT_EQ(value2, value) << "r " << r;
        EXPECT_EQ(slope2, slope) << "r " << r;
      }
    }
  }
}

}  // namespace
}  // namespace palpa::deform
