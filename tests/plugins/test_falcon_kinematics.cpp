// Falcon kinematics: encoder scale, inverse kinematics against the
// tangent-half-angle form of the same leg equations (Stamper), the angle
// Jacobian against finite differences, forward = inverse^-1, and
// Jacobian-transpose torques against virtual work.

#include "falcon_kinematics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace palpa::plugins::falcon {
namespace {

constexpr double kDeg = std::numbers::pi / 180;

// theta1 of one leg by the quadratic in t = tan(theta1 / 2) (the form the
// Falcon literature uses), written independently of Kinematics::inverse.
double theta1_half_angle(const Geometry& g, const Vec3& p, int i) {
  const double cp = std::cos(g.phi[i]), sp = std::sin(g.phi[i]);
  const double pu = cp * p[0] + sp * p[1] - g.r;
  const double pv = -sp * p[0] + cp * p[1] - g.s;
  const double pw = p[2];
  const double s3 = std::sin(std::acos((pv + g.f) / g.b));
  const double common = pw * pw + pu * pu + 2 * g.c * pu + g.a * g.a + g.c * g.c - g.d * g.d - g.e * g.e -
                        g.b * g.b * s3 * s3 - 2 * g.b * g.e * s3 - 2 * g.b * g.d * s3 - 2 * g.d * g.e;
  const double l0 = common - 2 * g.a * pu - 2 * g.a * g.c;
  const double l1 = -4 * g.a * pw;
  const double l2 = common + 2 * g.a * pu + 2 * g.a * g.c;
  const double t = (-l1 - std::sqrt(l1 * l1 - 4 * l0 * l2)) / (2 * l2);
  return 2 * std::atan(t);
}

std::vector<Vec3> workspace_points(int n) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> xy(-0.04, 0.04), z(0.09, 0.16);
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) out.emplace_back(xy(rng), xy(rng), z(rng));
  return out;
}

TEST(FalconEncoders, ScaleAndOffset) {
  EXPECT_DOUBLE_EQ(encoder_to_angle(0), 35 * kDeg);
  // 320 slots x 4 counts per motor turn; capstan 14.25 mm on a 110 mm drum.
  const double per_count = 14.25 / (320 * 4 * 110.0) * 2 * std::numbers::pi;
  EXPECT_NEAR(encoder_to_angle(1000) - encoder_to_angle(0), 1000 * per_count, 1e-15);
  for (int c = -3000; c <= 3000; c += 7)
    EXPECT_EQ(angle_to_encoder(encoder_to_angle(static_cast<std::int16_t>(c))), c);
  EXPECT_EQ(angle_to_encoder(1e9), 32767);
  EXPECT_EQ(angle_to_encoder(-1e9), -32768);
}

TEST(FalconKinematics, InverseMatchesTheHalfAngleForm) {
  const Kinematics k;
  for (const Vec3& p : workspace_points(500)) {
    Vec3 a;
    ASSERT_TRUE(k.inverse(p, a));
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(a[i], theta1_half_angle(k.geometry(), p, i), 1e-10) << p.transpose();
  }
}

TEST(FalconKinematics, SymmetricPosesGiveEqualAngles) {
  const Kinematics k;
  Vec3 a;
  ASSERT_TRUE(k.inverse(Vec3(0, 0, 0.11), a));
  EXPECT_NEAR(a[0], a[1], 1e-13);
  EXPECT_NEAR(a[1], a[2], 1e-13);
  // Further out means larger motor angles (the arms open).
  Vec3 b;
  ASSERT_TRUE(k.inverse(Vec3(0, 0, 0.15), b));
  EXPECT_GT(b[0], a[0]);
}

TEST(FalconKinematics, OutOfReachIsReported) {
  const Kinematics k;
  Vec3 a;
  EXPECT_FALSE(k.inverse(Vec3(0, 0, 0.5), a));
  EXPECT_FALSE(k.inverse(Vec3(0.3, 0, 0.1), a));
  EXPECT_FALSE(k.inverse(Vec3(NAN, 0, 0.1), a));
  Vec3 p(0, 0, 0.11);
  EXPECT_FALSE(k.forward(Vec3(NAN, 0, 0), p));
}

TEST(FalconKinematics, AngleJacobianMatchesFiniteDifferences) {
  const Kinematics k;
  const double h = 1e-6;
  for (const Vec3& p : workspace_points(100)) {
    Mat3 A;
    ASSERT_TRUE(k.angle_jacobian(p, A));
    for (int j = 0; j < 3; ++j) {
      Vec3 plus, minus;
      ASSERT_TRUE(k.inverse(p + h * Vec3::Unit(j), plus));
      ASSERT_TRUE(k.inverse(p - h * Vec3::Unit(j), minus));
      const Vec3 fd = (plus - minus) / (2 * h);
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(A(i, j), fd[i], 1e-6 * (1 + std::abs(fd[i]))) << i << j;
    }
  }
}

TEST(FalconKinematics, ForwardInvertsInverse) {
  const Kinematics k;
  for (const Vec3& p : workspace_points(300)) {
    Vec3 a;
    ASSERT_TRUE(k.inverse(p, a));
    Vec3 q(0, 0, 0.11);  // a far guess
    ASSERT_TRUE(k.forward(a, q)) << p.transpose();
    EXPECT_LT((q - p).norm(), 1e-9) << p.transpose();
  }
}

TEST(FalconKinematics, TorquesObeyVirtualWork) {
  const Kinematics k;
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  for (const Vec3& p : workspace_points(100)) {
    const Vec3 F(n(rng), n(rng), n(rng));
    Vec3 tau;
    ASSERT_TRUE(k.torques(p, F, tau));
    // tau . dtheta = F . dp for any small displacement.
    Mat3 A;
    ASSERT_TRUE(k.angle_jacobian(p, A));
    for (int trial = 0; trial < 3; ++trial) {
      const Vec3 dp(n(rng), n(rng), n(rng));
      EXPECT_NEAR(tau.dot(A * dp), F.dot(dp), 1e-9 * (1 + std::abs(F.dot(dp))));
    }
    // Torques are N m: a few newtons on ~6 cm arms give a fraction of a N m.
    EXPECT_LT(tau.norm(), 10 * F.norm());
  }
}

}  // namespace
}  // namespace palpa::plugins::falcon
