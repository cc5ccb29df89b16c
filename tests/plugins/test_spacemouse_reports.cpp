// SpaceMouse HID reports on byte vectors (every report kind, every malformed
// length) and the rate control's closed form.

#include "spacemouse_reports.h"

#include <gtest/gtest.h>

#include <vector>

namespace palpa::plugins::spacemouse {
namespace {

Report apply(std::vector<std::uint8_t> bytes, AxisState& s) { return apply_report(bytes, s); }

TEST(SpaceMouseReports, TranslationRotationAndButtons) {
  AxisState s;
  // ID 1: TX = 350 (0x015e), TY = -350 (0xfea2), TZ = 1.
  EXPECT_EQ(apply({1, 0x5e, 0x01, 0xa2, 0xfe, 0x01, 0x00}, s), Report::Translation);
  EXPECT_EQ(s.translation, (std::array<std::int16_t, 3>{350, -350, 1}));
  // ID 2: RX = -1, RY = 0x7fff, RZ = -32768.
  EXPECT_EQ(apply({2, 0xff, 0xff, 0xff, 0x7f, 0x00, 0x80}, s), Report::Rotation);
  EXPECT_EQ(s.rotation, (std::array<std::int16_t, 3>{-1, 32767, -32768}));
  EXPECT_EQ(s.translation[0], 350);  // untouched
  // ID 1 with 13 bytes: translation and rotation together (newer devices).
  EXPECT_EQ(apply({1, 1, 0, 2, 0, 3, 0, 4, 0, 5, 0, 6, 0}, s), Report::TranslationRotation);
  EXPECT_EQ(s.translation, (std::array<std::int16_t, 3>{1, 2, 3}));
  EXPECT_EQ(s.rotation, (std::array<std::int16_t, 3>{4, 5, 6}));
  // ID 3: buttons, little-endian mask of 1 to 4 bytes.
  EXPECT_EQ(apply({3, 0x03}, s), Report::Buttons);
  EXPECT_EQ(s.buttons, 3u);
  EXPECT_EQ(apply({3, 0x01, 0x02, 0x00, 0x80}, s), Report::Buttons);
  EXPECT_EQ(s.buttons, 0x80000201u);
}

TEST(SpaceMouseReports, MalformedAndUnknownReportsChangeNothing) {
  AxisState s;
  apply({1, 10, 0, 20, 0, 30, 0}, s);
  apply({3, 1}, s);
  const AxisState before = s;
  const std::vector<std::vector<std::uint8_t>> malformed = {
      {},                         // empty
      {1},                        // ID only
      {1, 1, 0, 2, 0, 3},         // translation one byte short
      {1, 1, 0, 2, 0, 3, 0, 4},   // one byte too many
      {1, 1, 0, 2, 0, 3, 0, 4, 0, 5, 0, 6},  // 12 bytes
      {2, 1, 0, 2, 0, 3},         // rotation short
      {2, 1, 0, 2, 0, 3, 0, 0},   // rotation long
      {3},                        // buttons without a mask
      {3, 1, 2, 3, 4, 5},         // mask longer than 32 bits
  };
  for (const auto& m : malformed) {
    EXPECT_EQ(apply(m, s), Report::Malformed) << m.size();
    EXPECT_EQ(s.translation, before.translation);
    EXPECT_EQ(s.rotation, before.rotation);
    EXPECT_EQ(s.buttons, before.buttons);
  }
  EXPECT_EQ(apply({0x17, 0x64, 0x00}, s), Report::Ignored);  // battery report of wireless devices
  EXPECT_EQ(apply({4, 1, 2, 3}, s), Report::Ignored);
  EXPECT_EQ(s.translation, before.translation);
}

TEST(SpaceMouseReports, KnownDevices) {
  EXPECT_TRUE(is_spacemouse(0x046d, 0xc626));   // SpaceNavigator
  EXPECT_TRUE(is_spacemouse(0x046d, 0xc62b));   // SpaceMouse Pro
  EXPECT_TRUE(is_spacemouse(0x256f, 0xc635));   // SpaceMouse Compact
  EXPECT_TRUE(is_spacemouse(0x256f, 0x1234));   // any 3Dconnexion product
  EXPECT_FALSE(is_spacemouse(0x046d, 0xc52b));  // a Logitech receiver
  EXPECT_FALSE(is_spacemouse(0x0403, 0xcb48));  // a Falcon
}

TEST(SpaceMouseRateControl, DeadzoneLinearRangeSaturationAndAxes) {
  RateControl rc;
  rc.full_scale = 350;
  rc.max_speed = 0.1;
  rc.deadzone = 0.1;
  AxisState s;
  s.translation = {35, 0, 0};  // exactly at the deadzone edge
  EXPECT_EQ(rc.velocity(s)[0], 0.0);
  s.translation = {350, 0, 0};
  EXPECT_DOUBLE_EQ(rc.velocity(s)[0], 0.1);
  s.translation = {700, 0, 0};  // beyond full scale: saturated
  EXPECT_DOUBLE_EQ(rc.velocity(s)[0], 0.1);
  s.translation = {-192, 0, 0};  // (0.5486 - 0.1) / 0.9 * 0.1
  EXPECT_NEAR(rc.velocity(s)[0], -(192.0 / 350 - 0.1) / 0.9 * 0.1, 1e-15);
  // Device frame: x = TX, y = -TZ (push down = move down), z = TY.
  s.translation = {0, 350, 350};
  const auto v = rc.velocity(s);
  EXPECT_DOUBLE_EQ(v[0], 0.0);
  EXPECT_DOUBLE_EQ(v[1], -0.1);
  EXPECT_DOUBLE_EQ(v[2], 0.1);
}

}  // namespace
}  // namespace palpa::plugins::spacemouse
