// The real `falcon` plugin, through unmodified libusb, against an emulated
// Falcon (fixtures/falcon.umockdev + falcon_emulator.cpp): firmware
// handling, homing before any force, position reading, force writing with
// the Jacobian transpose (checked against the emulated physics in closed
// form), the command watchdog, and the haptic loop with an unplug in the
// middle that must give zero force and a latched fault.

#include "devices/loader.h"
#include "falcon_emulator.h"
#include "haptics/loop.h"
#include "mesh/generate.h"
#include "umockdev_support.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <random>
#include <thread>

namespace palpa {
namespace {

using namespace std::chrono_literals;
namespace fc = palpa::plugins::falcon;

const char* kNode = "/dev/bus/usb/001/005";
const char* kSys = "/sys/devices/pci0000:00/0000:00:14.0/usb1/1-2";
constexpr double kHandStiffness = 200;  // N/m, as in the emulator

double now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

// Our own stand-in image (random bytes): the real firmware is Novint's.
std::vector<std::uint8_t> test_image(std::size_t n) {
  std::mt19937 rng(2024);
  std::vector<std::uint8_t> v(n);
  for (auto& b : v) b = static_cast<std::uint8_t>(rng());
  return v;
}

std::string write_image(const std::vector<std::uint8_t>& image) {
  const auto path = test::temp_dir("falcon_fw") / "test_firmware.bin";
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(image.data()),
                                              static_cast<std::streamsize>(image.size()));
  return path.string();
}

class FalconEmulated : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!test::umockdev_preloaded()) GTEST_FAIL() << test::kNeedsUmockdevWrapper;
    bed_ = std::make_unique<test::Testbed>();
    emu_ = std::make_unique<test::FalconEmulator>();
  }
  void TearDown() override {
    bed_.reset();
    emu_.reset();
  }
  void plug_in() {
    bed_->add_from_file(test::fixture_dir() / "falcon.umockdev");
    bed_->attach_ioctl(kNode, emu_->handler());
  }
  devices::Device make(const std::string& options = "") {
    return devices::PluginLoader({PALPA_PLUGIN_DIR}).load("falcon").create(options);
  }
  std::string start_error(devices::Device& d) {
    try {
      d.start();
    } catch (const devices::DeviceError& e) {
      return e.what();
    }
    return "no error";
  }
  // Moves the hand in a straight line over `seconds`.
  void move_hand(const fc::Vec3& from, const fc::Vec3& to, double seconds) {
    const double t0 = now();
    for (double t = 0; t < seconds; t = now() - t0) {
      emu_->set_hand(from + (to - from) * (t / seconds));
      std::this_thread::sleep_for(5ms);
    }
    emu_->set_hand(to);
  }
  // The homing motion: all the way in and out.
  void home(devices::Device& d) {
    const fc::Vec3 c(0, 0, 0.11);
    move_hand(c, fc::Vec3(0, 0, 0.085), 0.4);
    move_hand(fc::Vec3(0, 0, 0.085), fc::Vec3(0, 0, 0.16), 0.6);
    move_hand(fc::Vec3(0, 0, 0.16), c, 0.4);
    PalpaDeviceSample s;
    const double t0 = now();
    while (now() - t0 < 1.0 && (!d.read(s) || (s.status & PALPA_STATUS_NOT_READY)))
      std::this_thread::sleep_for(2ms);
  }
  // Reads until the sample is at rest for a while, returns it.
  PalpaDeviceSample settle(devices::Device& d, double seconds) {
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    PalpaDeviceSample s;
    d.read(s);
    return s;
  }

  std::unique_ptr<test::Testbed> bed_;
  std::unique_ptr<test::FalconEmulator> emu_;
};

TEST_F(FalconEmulated, NoFalconConnected) {
  devices::Device d = make();
  EXPECT_EQ(start_error(d), "falcon: no Novint Falcon found (USB 0403:cb48)");
}

TEST_F(FalconEmulated, NoFirmwareOnTheDeviceAndNoFileConfigured) {
  emu_->expect_firmware(test_image(1500));
  plug_in();
  devices::Device d = make();
  EXPECT_EQ(start_error(d),
            "falcon: the Falcon has no firmware loaded and no firmware file is configured; set "
            "firmware=/path/to/the firmware file from Novint's driver package (Palpa does not ship it)");
}

TEST_F(FalconEmulated, FirmwareFileThatDoesNotExist) {
  emu_->expect_firmware(test_image(1500));
  plug_in();
  devices::Device d = make("firmware=/nonexistent/falcon.bin");
  EXPECT_EQ(start_error(d), "falcon: firmware file '/nonexistent/falcon.bin' does not exist");
}

TEST_F(FalconEmulated, FirmwareIsUploadedWithEchoCheck) {
  const auto image = test_image(1500);
  emu_->expect_firmware(image);
  plug_in();
  devices::Device d = make("firmware=" + write_image(image));
  ASSERT_EQ(start_error(d), "no error");
  EXPECT_TRUE(emu_->firmware_loaded());
  EXPECT_EQ(d.message(), "falcon: homing: move the grip all the way in and out until the LED turns green");
}

TEST_F(FalconEmulated, AWrongEchoStopsTheUpload) {
  const auto image = test_image(1500);
  emu_->expect_firmware(image);
  emu_->corrupt_echo_at(700);
  plug_in();
  devices::Device d = make("firmware=" + write_image(image));
  char expected[160];
  std::snprintf(expected, sizeof expected, "falcon: firmware upload failed at byte 700: echoed 0x%02x, sent 0x%02x",
                image[700] ^ 0xff, image[700]);
  EXPECT_EQ(start_error(d), expected);
  EXPECT_FALSE(emu_->firmware_loaded());
}

TEST_F(FalconEmulated, HomingThenPositionsAndForces) {
  emu_->expect_firmware({});  // already loaded
  plug_in();
  devices::Device d = make();
  ASSERT_EQ(start_error(d), "no error");
  PalpaDeviceSample s;
  std::this_thread::sleep_for(100ms);
  d.read(s);
  EXPECT_TRUE(s.status & PALPA_STATUS_NOT_READY);  // homing first

  // A force asked before homing is not applied.
  PalpaForceCommand c{};
  c.force[1] = 3.0;
  c.time = now();
  c.expires_after = 10;
  d.write(c);
  home(d);
  d.read(s);
  ASSERT_EQ(s.status, PALPA_STATUS_VALID) << d.message();
  EXPECT_EQ(emu_->homed(), 0x7);
  EXPECT_EQ(emu_->max_motor_before_homing(), 0);
  EXPECT_EQ(emu_->last_command().leds, fc::kLedGreen);
  EXPECT_FALSE(emu_->last_command().homing);
  EXPECT_EQ(d.message(), "falcon: running");

  // Position: the hand holds the grip at a point; the plugin reads it back
  // through encoders and forward kinematics (resolution ~0.1 mm).
  c = PalpaForceCommand{};
  d.write(c);
  const fc::Vec3 hand(0.012, -0.008, 0.12);
  move_hand(fc::Vec3(0, 0, 0.11), hand, 0.3);
  s = settle(d, 0.6);
  const fc::Vec3 read_back(s.position[0], s.position[1], s.position[2]);
  EXPECT_LT((read_back - emu_->position()).norm(), 3e-4);
  EXPECT_LT((emu_->position() - hand).norm(), 5e-4);

  // Force: F pushes the grip against the hand spring: p = hand + F / k.
  for (const fc::Vec3& F : {fc::Vec3(0, 2.0, 0), fc::Vec3(-1.5, 0, 1.0)}) {
    const double t0 = now();
    while (now() - t0 < 0.8) {  // keep the command fresh (the watchdog)
      c.force[0] = F[0];
      c.force[1] = F[1];
      c.force[2] = F[2];
      c.time = now();
      c.expires_after = 0.05;
      d.write(c);
      std::this_thread::sleep_for(5ms);
    }
    const fc::Vec3 expected = hand + F / kHandStiffness;
    EXPECT_LT((emu_->position() - expected).norm(), 1e-3) << "F = " << F.transpose() << ", at "
                                                          << emu_->position().transpose();
  }

  // The command expires (no more writes): zero force, back to the hand.
  std::this_thread::sleep_for(700ms);
  EXPECT_LT((emu_->position() - hand).norm(), 5e-4);
  const fc::Command last = emu_->last_command();
  EXPECT_EQ(last.motor, (std::array<std::int16_t, 3>{0, 0, 0}));
}

TEST_F(FalconEmulated, HapticLoopPressesTheOrganAndUnplugLatchesAFault) {
  emu_->expect_firmware({});
  plug_in();
  devices::Device d = make();
  ASSERT_EQ(start_error(d), "no error");
  home(d);

  // A flat organ at world z = 0; the device centre (z = 0.11 m) maps there.
  auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(81, 81, 1e-3));
  deform::Material m;
  m.stiffness = 500;
  m.damping = 2;
  haptics::LoopConfig c;
  c.core.deform_rate_hz = 200;  // the organ deforms; the force depends on the depth only
  c.core.shape.radius = 0.01;
  haptics::ProbeBinding b;
  b.device = &d;
  b.mapping.offset = {0, 0, -0.11};
  b.safety.ramp_time = 0.2;
  haptics::HapticLoop loop(mesh, deform::MaterialArrays::uniform(mesh->vertex_count(), m), {}, c, {b});
  loop.start();
  loop.enable(0);

  // The hand pushes 5 mm into the organ. Equilibrium of hand spring and
  // organ spring: k_h (0.105 - z) + k (0.11 - z) = 0.
  move_hand(fc::Vec3(0, 0, 0.11), fc::Vec3(0, 0, 0.105), 0.3);
  const double z = (kHandStiffness * 0.105 + 500 * 0.11) / (kHandStiffness + 500);
  const double settle_start = now();  // settles in well under a second; allow for a loaded machine
  while (now() - settle_start < 5.0 && !(std::abs(emu_->position()[2] - z) < 2e-4 &&
                                         std::abs(loop.view().probes[0].force_device[2] - 500 * (0.11 - z)) < 0.1))
    std::this_thread::sleep_for(20ms);
  haptics::LoopView v = loop.view();
  EXPECT_NEAR(emu_->position()[2], z, 3e-4);
  EXPECT_TRUE(v.probes[0].in_contact);
  EXPECT_NEAR(v.probes[0].force_device[2], 500 * (0.11 - z), 0.15);
  EXPECT_EQ(v.probes[0].fault, 0);

  // Unplug in the middle of the session.
  emu_->unplug();
  bed_->remove_device(kSys);
  const double t0 = now();
  while (now() - t0 < 0.5 && loop.view().probes[0].fault == 0) std::this_thread::sleep_for(2ms);
  v = loop.view();
  EXPECT_EQ(v.probes[0].fault, static_cast<std::uint8_t>(haptics::SafetyFault::Device));
  EXPECT_TRUE(v.probes[0].flags & haptics::kSafetyFaultLatched);
  EXPECT_EQ(v.probes[0].force_device, (haptics::Triple{0, 0, 0}));
  EXPECT_EQ(d.message(), "falcon: unplugged; plug it back in and restart the device");
  // The session keeps running; re-enabling does not clear a fault that persists.
  const std::uint64_t ticks = v.tick;
  loop.enable(0);
  std::this_thread::sleep_for(100ms);
  v = loop.view();
  EXPECT_GT(v.tick, ticks + 50);
  EXPECT_EQ(v.probes[0].fault, static_cast<std::uint8_t>(haptics::SafetyFault::Device));
  EXPECT_EQ(v.probes[0].force_device, (haptics::Triple{0, 0, 0}));
  loop.stop();
}

}  // namespace
}  // namespace palpa
