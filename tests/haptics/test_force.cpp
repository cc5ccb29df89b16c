// eq. (4) and the force clamp against hand-computed values.

#include "haptics/force.h"
#include "common/test_support.h"

#include <cmath>
#include <limits>

namespace palpa::haptics {
namespace {

void expect_vec_near(const Vec3& got, const Vec3& want, double tol) {
  EXPECT_LE((got - want).norm(), tol) << "got " << got.transpose() << ", want " << want.transpose();
}

TEST(ContactForce, PureNormalAtRest) {
  ForceParams p;
  const Vec3 n = Vec3(1, 2, 2) / 3;
  expect_vec_near(contact_force(2.5, n, Vec3::Zero(), p), 2.5 * n, 1e-15);
  // Moving only along the normal: no tangential part, no friction.
  expect_vec_near(contact_force(2.5, n, -0.3 * n, p), 2.5 * n, 1e-12);
}

TEST(ContactForce, FrictionOpposesSlidingAboveSlipSpeed) {
  // N = +z, Fn = 2 N, K = 0.3, sliding at 0.1 m/s along +x (with a normal
  // component that must not matter): F = (-0.3 * 2, 0, 2).
  ForceParams p;
  p.friction = 0.3;
  p.slip_speed = 1e-3;
  expect_vec_near(contact_force(2.0, Vec3::UnitZ(), Vec3(0.1, 0, 0), p), Vec3(-0.6, 0, 2), 1e-15);
  expect_vec_near(contact_force(2.0, Vec3::UnitZ(), Vec3(0.1, 0, -0.5), p), Vec3(-0.6, 0, 2), 1e-15);
  // Any sliding direction: tangential magnitude K Fn, opposite the velocity.
  const Vec3 v(0.03, -0.04, 0.2);
  const Vec3 f = contact_force(4.0, Vec3::UnitZ(), v, p);
  expect_vec_near(f, Vec3(-1.2 * 0.6, 1.2 * 0.8, 4.0), 1e-14);
}

TEST(ContactForce, FrictionLinearBelowSlipSpeed) {
  // |T| = 0.5 mm/s < slip 1 mm/s: friction K Fn |T| / slip = 0.3 * 2 * 0.5.
  ForceParams p;
  p.friction = 0.3;
  p.slip_speed = 1e-3;
  expect_vec_near(contact_force(2.0, Vec3::UnitZ(), Vec3(0, 5e-4, 0), p), Vec3(0, -0.3, 2), 1e-15);
  // Doubling a slow speed doubles the friction.
  const Vec3 f1 = contact_force(2.0, Vec3::UnitZ(), Vec3(1e-4, 0, 0), p);
  const Vec3 f2 = contact_force(2.0, Vec3::UnitZ(), Vec3(2e-4, 0, 0), p);
  EXPECT_NEAR(f2.x(), 2 * f1.x(), 1e-15);
  EXPECT_NEAR(f1.x(), -0.3 * 2 * 0.1, 1e-15);
}

TEST(ContactForce, NoNormalReactionNoForce) {
  ForceParams p;
  EXPECT_EQ(contact_force(0.0, Vec3::UnitZ(), Vec3(1, 1, 1), p), Vec3::Zero());
}

TEST(ClampForce, KeepsDirectionAndBoundsMagnitude) {
  expect_vec_near(clamp_force(Vec3(30, 40, 0), 10), Vec3(6, 8, 0), 1e-14);
  // Within the limit: unchanged.
  EXPECT_EQ(clamp_force(Vec3(3, 4, 0), 10), Vec3(3, 4, 0));
  EXPECT_EQ(clamp_force(Vec3(6, 8, 0), 10), Vec3(6, 8, 0));
  // Huge but finite components (|f| overflows): still scaled, not zeroed.
  const double big = std::numeric_limits<double>::max();
  expect_vec_near(clamp_force(Vec3(big, big, 0), 10), Vec3(1, 1, 0) * (10 / std::sqrt(2.0)), 1e-13);
  EXPECT_EQ(clamp_force(Vec3(1, 2, 3), 0), Vec3::Zero());
}

TEST(ClampForce, NonFiniteGivesZero) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(clamp_force(Vec3(nan, 0, 0), 10), Vec3::Zero());
  EXPECT_EQ(clamp_force(Vec3(0, inf, 0), 10), Vec3::Zero());
  EXPECT_EQ(clamp_force(Vec3(0, 0, -inf), 10), Vec3::Zero());
  EXPECT_EQ(clamp_force(Vec3(1, 0, 0), nan), Vec3::Zero());
  EXPECT_EQ(clamp_force(Vec3(1, 0, 0), -1), Vec3::Zero());
  // A NaN normal reaction through eq. (4) and the clamp: zero.
  EXPECT_EQ(clamp_force(contact_force(nan, Vec3::UnitZ(), Vec3::Zero(), ForceParams{}), 10), Vec3::Zero());
}

}  // namespace
}  // namespace palpa::haptics
