// Device-to-world mapping: axis order parsing (with exact messages), the
// mapping as a signed permutation, and the clutch (no jump on release).

#include "haptics/device_mapping.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace palpa::haptics {
namespace {

void expect_message(const std::function<void()>& f, const std::string& message) {
  try {
    f();
    FAIL() << "expected an exception: " << message;
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), message);
  }
}

TEST(AxisMap, ParsesSignedPermutations) {
  const AxisMap m = AxisMap::parse("x, -z ,y");
  EXPECT_EQ(m.axis, (std::array<int, 3>{0, 2, 1}));
  EXPECT_EQ(m.sign, (std::array<double, 3>{1, -1, 1}));
  EXPECT_EQ(m.to_string(), "x,-z,y");
  // Device (1, 2, 3): world x = dx, world y = -dz, world z = dy.
  EXPECT_EQ(m.to_world(Vec3(1, 2, 3)), Vec3(1, -3, 2));
}

TEST(AxisMap, ToDeviceInvertsToWorldForEveryPermutation) {
  const char* all[] = {"x,y,z", "x,z,y", "y,x,z", "y,z,x", "z,x,y", "z,y,x", "-x,-y,-z", "-y,z,-x"};
  const Vec3 v(0.3, -1.7, 2.9);
  for (const char* text : all) {
    const AxisMap m = AxisMap::parse(text);
    EXPECT_EQ(m.to_device(m.to_world(v)), v) << text;
    EXPECT_DOUBLE_EQ(m.to_world(v).norm(), v.norm()) << text;
  }
}

TEST(AxisMap, BadTextGivesItsOwnMessage) {
  struct Case {
    const char* text;
    const char* message;
  } cases[] = {
      {"x,y", "axis order 'x,y': expected three entries like x,-z,y"},
      {"x,y,z,x", "axis order 'x,y,z,x': expected three entries like x,-z,y"},
      {"x,x,z", "axis order 'x,x,z': axis x is used twice"},
      {"x,w,z", "axis order 'x,w,z': 'w' is not x, y or z"},
      {"x,,z", "axis order 'x,,z': '' is not x, y or z"},
      {"x,--y,z", "axis order 'x,--y,z': '-y' is not x, y or z"},
  };
  for (const auto& c : cases) expect_message([&] { AxisMap::parse(c.text); }, c.message);
}

TEST(DeviceMapping, ScaleOffsetAndForceDirection) {
  DeviceMapping m;
  m.scale = 2.0;
  m.offset = {0.1, 0.2, 0.3};
  m.axes = AxisMap::parse("-y,x,z");
  // World = offset + 2 * (-dy, dx, dz).
  EXPECT_TRUE(m.to_world(Vec3(0.01, 0.02, 0.03)).isApprox(Vec3(0.1 - 0.04, 0.2 + 0.02, 0.3 + 0.06)));
  // A world force along +x pushes the device along -y.
  EXPECT_EQ(m.force_to_device(Vec3(1, 0, 0)), Vec3(0, -1, 0));
  m.force_scale = 0.5;
  EXPECT_EQ(m.force_to_device(Vec3(0, 0, 4)), Vec3(0, 0, 2));
  EXPECT_EQ(m.force_to_world(m.force_to_device(Vec3(1, 2, 3))), Vec3(1, 2, 3));
}

TEST(DeviceMapping, ValidationNamesTheDeviceAndField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  DeviceMapping m;
  m.scale = nan;
  expect_message([&] { m.validate("falcon"); }, "mapping of falcon: scale must be a positive finite number, got nan");
  m = DeviceMapping{};
  m.scale = -1;
  expect_message([&] { m.validate("falcon"); }, "mapping of falcon: scale must be a positive finite number, got -1");
  m = DeviceMapping{};
  m.offset[1] = INFINITY;
  expect_message([&] { m.validate("a"); }, "mapping of a: offset must be finite, got inf");
  m = DeviceMapping{};
  m.force_scale = -0.5;
  expect_message([&] { m.validate("a"); }, "mapping of a: force_scale must be a finite number >= 0, got -0.5");
  m = DeviceMapping{};
  m.axes.axis = {0, 0, 2};
  expect_message([&] { m.validate("a"); }, "mapping of a: axis order must use each device axis exactly once");
  m = DeviceMapping{};
  m.axes.sign[2] = 0.5;
  expect_message([&] { m.validate("a"); }, "mapping of a: axis signs must be +1 or -1");
  m = DeviceMapping{};
  m.clutch_button = 40;
  expect_message([&] { m.validate("a"); }, "mapping of a: clutch_button must be -1 (none) or 0 .. 31, got 40");
}

TEST(ClutchedMapping, ProbeStaysWhileEngagedAndContinuesWithoutJump) {
  DeviceMapping m;
  m.scale = 3.0;
  m.axes = AxisMap::parse("z,x,y");
  ClutchedMapping c(m);
  const Vec3 d0(0.01, 0.02, 0.03);
  const Vec3 w0 = c.update(d0, false);
  EXPECT_TRUE(w0.isApprox(m.to_world(d0)));

  // Engaged (at d0): the device moves, the probe does not.
  EXPECT_EQ(c.update(d0, true), w0);
  EXPECT_EQ(c.update(d0 + Vec3(0.05, 0, 0), true), w0);
  EXPECT_EQ(c.update(d0 + Vec3(0.05, -0.04, 0.02), true), w0);
  EXPECT_TRUE(c.engaged());

  // Released at d1: the probe is where it was, then follows device motion
  // with the same scale and axes.
  const Vec3 d1 = d0 + Vec3(0.05, -0.04, 0.02);
  EXPECT_EQ(c.update(d1, false), w0);
  const Vec3 w2 = c.update(d1 + Vec3(0.001, 0, 0), false);
  EXPECT_TRUE((w2 - w0).isApprox(3.0 * m.axes.to_world(Vec3(0.001, 0, 0))));
  // The offset absorbed the clutched motion: -scale * A * (d1 - d0).
  const Vec3 shift = Vec3(c.mapping().offset[0], c.mapping().offset[1], c.mapping().offset[2]);
  EXPECT_TRUE(shift.isApprox(-3.0 * m.axes.to_world(d1 - d0)));
}

TEST(ClutchedMapping, NonFiniteDevicePositionsDoNotMoveTheAnchor) {
  ClutchedMapping c{DeviceMapping{}};
  const Vec3 w0 = c.update(Vec3(0.1, 0.2, 0.3), true);
  EXPECT_EQ(c.update(Vec3(NAN, 0, 0), true), w0);
  // A NaN reading cannot release the clutch either.
  EXPECT_EQ(c.update(Vec3(NAN, 0, 0), false), w0);
  EXPECT_TRUE(c.engaged());
  EXPECT_EQ(c.update(Vec3(0.1, 0.2, 0.3), false), w0);
}

}  // namespace
}  // namespace palpa::haptics
