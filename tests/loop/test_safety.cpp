// The safety filter against closed forms: clamp keeps the direction, the ramp
// is linear in time, the change per tick is bounded, stops are immediate,
// faults latch until enable().

#include "haptics/safety.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace palpa::haptics {
namespace {

constexpr double kPeriod = 1e-3;

SafetyLimits limits(double max_force = 5.0, double rate = 1e9, double ramp = 0.0) {
  SafetyLimits l;
  l.max_force = max_force;
  l.max_force_rate = rate;
  l.ramp_time = ramp;
  return l;
}

TEST(Safety, DisabledUntilEnabled) {
  SafetyFilter f(limits(), kPeriod);
  std::uint32_t flags = 0;
  EXPECT_EQ(f.apply(Vec3(1, 0, 0), 0, 0.0, flags), Vec3::Zero());
  EXPECT_TRUE(flags & kSafetyDisabled);
  f.enable(0.0);
  EXPECT_EQ(f.apply(Vec3(1, 0, 0), 0, 0.001, flags), Vec3(1, 0, 0));
  EXPECT_EQ(flags, 0u);
}

TEST(Safety, ClampScalesTheVectorAndKeepsItsDirection) {
  SafetyFilter f(limits(5.0), kPeriod);
  f.enable(0.0);
  std::uint32_t flags = 0;
  const Vec3 in(30, -40, 0);  // |in| = 50
  const Vec3 out = f.apply(in, 0, 0.0, flags);
  EXPECT_TRUE(flags & kSafetyClamped);
  EXPECT_LE(out.norm(), 5.0);
  EXPECT_NEAR(out.norm(), 5.0, 1e-9);
  EXPECT_NEAR(out.normalized().dot(in.normalized()), 1.0, 1e-15);
}

TEST(Safety, RampInIsLinearInTime) {
  SafetyFilter f(limits(10.0, 1e9, 0.5), kPeriod);
  f.enable(2.0);
  std::uint32_t flags = 0;
  const Vec3 in(0, 4, 0);
  for (double s : {0.0, 0.1, 0.25, 0.6, 0.99}) {
    const Vec3 out = f.apply(in, 0, 2.0 + s * 0.5, flags);
    EXPECT_NEAR(out[1], 4.0 * s, 1e-12) << s;
    EXPECT_TRUE(flags & kSafetyRamping);
  }
  EXPECT_EQ(f.apply(in, 0, 2.5, flags), in);
  EXPECT_FALSE(flags & kSafetyRamping);
}

TEST(Safety, ChangePerTickIsBoundedBothWays) {
  const double rate = 200.0;  // N/s -> 0.2 N per 1 ms tick
  SafetyFilter f(limits(10.0, rate), kPeriod);
  f.enable(0.0);
  ASSERT_NEAR(f.max_step(), 0.2, 1e-15);
  std::uint32_t flags = 0;
  Vec3 prev = Vec3::Zero();
  // A step to 3 N takes 3 / 0.2 = 15 ticks (indices 0 .. 14), each at most 0.2 N.
  int ticks = 0;
  for (; ticks < 100; ++ticks) {
    const Vec3 out = f.apply(Vec3(0, 0, 3), 0, ticks * kPeriod, flags);
    EXPECT_LE((out - prev).norm(), 0.2);
    prev = out;
    if ((out - Vec3(0, 0, 3)).norm() < 1e-9) break;
  }
  EXPECT_EQ(ticks, 14);
  // Release: the force also decays at most 0.2 N per tick.
  const Vec3 down = f.apply(Vec3::Zero(), 0, 1.0, flags);
  EXPECT_NEAR(down[2], 2.8, 1e-9);
  EXPECT_TRUE(flags & kSafetyRateLimited);
}

TEST(Safety, HoldConditionsZeroAtOnceAndRampInAgain) {
  for (std::uint32_t hold : {kSafetyNotReady, kSafetyStale, kSafetyBadInput, kSafetyLoopLate, kSafetyModelLate,
                             kSafetyClutch, kSafetyJump}) {
    SafetyFilter f(limits(10.0, 1e9, 0.1), kPeriod);
    f.enable(0.0);
    std::uint32_t flags = 0;
    EXPECT_EQ(f.apply(Vec3(0, 0, 4), 0, 1.0, flags), Vec3(0, 0, 4));
    EXPECT_EQ(f.apply(Vec3(0, 0, 4), hold, 1.001, flags), Vec3::Zero()) << hold;
    EXPECT_TRUE(flags & hold);
    EXPECT_TRUE(f.enabled());  // not latched
    // Cleared at t = 1.002: ramp from there over 0.1 s.
    EXPECT_NEAR(f.apply(Vec3(0, 0, 4), 0, 1.002, flags)[2], 0.0, 1e-12);
    EXPECT_NEAR(f.apply(Vec3(0, 0, 4), 0, 1.052, flags)[2], 2.0, 1e-9);
  }
}

TEST(Safety, DeviceFaultLatchesUntilEnable) {
  SafetyFilter f(limits(), kPeriod);
  f.enable(0.0);
  std::uint32_t flags = 0;
  EXPECT_EQ(f.apply(Vec3(1, 1, 1), 0, 0.0, flags), Vec3(1, 1, 1));
  EXPECT_EQ(f.apply(Vec3(1, 1, 1), kSafetyDeviceFault, 0.001, flags), Vec3::Zero());
  EXPECT_EQ(f.fault(), SafetyFault::Device);
  // The device recovers, the fault stays.
  EXPECT_EQ(f.apply(Vec3(1, 1, 1), 0, 0.002, flags), Vec3::Zero());
  EXPECT_TRUE(flags & kSafetyFaultLatched);
  EXPECT_TRUE(flags & kSafetyDisabled);
  f.enable(0.003);
  EXPECT_EQ(f.fault(), SafetyFault::None);
  EXPECT_EQ(f.apply(Vec3(1, 1, 1), 0, 0.003, flags), Vec3(1, 1, 1));
}

TEST(Safety, NonFiniteModelForceLatchesAndNeverLeaves) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const Vec3& bad : {Vec3(nan, 0, 0), Vec3(0, INFINITY, 0), Vec3(0, 0, -INFINITY)}) {
    SafetyFilter f(limits(), kPeriod);
    f.enable(0.0);
    std::uint32_t flags = 0;
    const Vec3 out = f.apply(bad, 0, 0.0, flags);
    EXPECT_EQ(out, Vec3::Zero());
    EXPECT_TRUE(flags & kSafetyNonFiniteForce);
    EXPECT_EQ(f.fault(), SafetyFault::NonFiniteForce);
    EXPECT_EQ(f.apply(Vec3(1, 0, 0), 0, 0.001, flags), Vec3::Zero());
  }
}

TEST(Safety, LimitsValidationMessages) {
  auto message = [](SafetyLimits l) {
    try {
      l.validate("falcon");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  SafetyLimits l = limits();
  EXPECT_EQ(message(l), "no error");
  l.max_force = -1;
  EXPECT_EQ(message(l), "safety limits of falcon: max_force must be a positive finite number, got -1");
  l = limits();
  l.max_force_rate = 0;
  EXPECT_EQ(message(l), "safety limits of falcon: max_force_rate must be a positive finite number, got 0");
  l = limits();
  l.ramp_time = NAN;
  EXPECT_EQ(message(l), "safety limits of falcon: ramp_time must be a finite number >= 0, got nan");
  l = limits();
  l.max_jump = INFINITY;
  EXPECT_EQ(message(l), "safety limits of falcon: max_jump must be a positive finite number, got inf");
}

}  // namespace
}  // namespace palpa::haptics
