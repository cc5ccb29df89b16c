// The real `spacemouse` plugin reading an emulated SpaceNavigator through
// unmodified hidapi: the sysfs chain and report descriptor come from
// fixtures/spacemouse.umockdev, the timed reports from
// fixtures/spacemouse.script, and the hidraw ioctls are answered here. An
// unplug at the end must give a latched fault.

#include "devices/loader.h"
#include "umockdev_support.h"

#include <gtest/gtest.h>

#include <linux/hidraw.h>
#include <sys/ioctl.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <thread>
#include <vector>

namespace palpa {
namespace {

using namespace std::chrono_literals;

const char* kHidraw = "/dev/hidraw3";
const char* kHidrawSys = "/sys/devices/pci0000:00/0000:00:14.0/usb1/1-3/1-3:1.0/0003:046D:C626.0002/hidraw/hidraw3";
const char* kHidSys = "/sys/devices/pci0000:00/0000:00:14.0/usb1/1-3/1-3:1.0/0003:046D:C626.0002";

// What the kernel's hidraw driver answers, from the fixture's sysfs data.
struct HidrawAnswers {
  std::vector<std::uint8_t> descriptor;
  std::atomic<int> ioctls{0};  // counted on umockdev's worker thread, read by the test (TSan)
};

gboolean on_hidraw_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer user) {
  auto* a = static_cast<HidrawAnswers*>(user);
  const gulong request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  GError* error = nullptr;
  ++a->ioctls;
  if (request == HIDIOCGRDESCSIZE) {
    UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(int), &error);
    int size = static_cast<int>(a->descriptor.size());
    umockdev_ioctl_data_update(d, 0, reinterpret_cast<guint8*>(&size), sizeof size);
    umockdev_ioctl_client_complete(client, 0, 0);
    g_object_unref(d);
    return TRUE;
  }
  if (request == HIDIOCGRDESC) {
    UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(hidraw_report_descriptor), &error);
    hidraw_report_descriptor r{};
    r.size = static_cast<__u32>(a->descriptor.size());
    std::memcpy(r.value, a->descriptor.data(), a->descriptor.size());
    umockdev_ioctl_data_update(d, 0, reinterpret_cast<guint8*>(&r), sizeof r);
    umockdev_ioctl_client_complete(client, 0, 0);
    g_object_unref(d);
    return TRUE;
  }
  if (request == HIDIOCGRAWINFO) {
    UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(hidraw_devinfo), &error);
    hidraw_devinfo info{};
    info.bustype = 3;  // BUS_USB
    info.vendor = 0x046d;
    info.product = static_cast<__s16>(0xc626);
    umockdev_ioctl_data_update(d, 0, reinterpret_cast<guint8*>(&info), sizeof info);
    umockdev_ioctl_client_complete(client, 0, 0);
    g_object_unref(d);
    return TRUE;
  }
  umockdev_ioctl_client_complete(client, -1, ENOTTY);
  return TRUE;
}

class SpaceMouseEmulated : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!test::umockdev_preloaded()) GTEST_FAIL() << test::kNeedsUmockdevWrapper;
    bed_ = std::make_unique<test::Testbed>();
    bed_->add_from_file(test::fixture_dir() / "spacemouse.umockdev");
    // The report descriptor the hidraw ioctls return is the fixture's sysfs one.
    std::ifstream f(std::string(umockdev_testbed_get_root_dir(bed_->get())) + kHidSys + "/report_descriptor",
                    std::ios::binary);
    answers_.descriptor.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    ASSERT_GT(answers_.descriptor.size(), 20u);
    handler_ = umockdev_ioctl_base_new();
    g_signal_connect(handler_, "handle-ioctl", G_CALLBACK(on_hidraw_ioctl), &answers_);
  }
  void TearDown() override {
    bed_.reset();
    if (handler_) g_object_unref(handler_);
  }
  std::unique_ptr<test::Testbed> bed_;
  UMockdevIoctlBase* handler_ = nullptr;
  HidrawAnswers answers_;
};

TEST_F(SpaceMouseEmulated, ScriptedReportsMoveTheProbeAndUnplugLatchesAFault) {
  bed_->load_script(kHidraw, test::fixture_dir() / "spacemouse.script");
  bed_->attach_ioctl(kHidraw, handler_);
  devices::Device d =
      devices::PluginLoader({PALPA_PLUGIN_DIR}).load("spacemouse").create("speed=0.1;deadzone=0.05;workspace=0.2");
  d.start();  // finds the emulated device by enumeration
  EXPECT_EQ(d.message(), std::string("spacemouse: running on ") + kHidraw);
  EXPECT_GT(answers_.ioctls.load(), 0);  // hidapi asked for the report descriptor

  // Follow the script (about 1.8 s when nothing is late), reading like the
  // haptic loop does, until it has ended: the button was pressed and released
  // and the pull toward the user is over (z still for 150 ms). umockdev plays
  // the script in real time, so on a loaded machine its delays stretch; the
  // test therefore measures, from the samples' own times, how long the probe
  // moved, and checks position = speed x that time (0.1 m/s), not the script's
  // nominal 0.3 s and 0.2 s. Its reports are 200 ms apart or more, so that two
  // never reach the plugin in one read (see the script's header).
  PalpaDeviceSample s{};
  double max_x = 0;
  bool button_seen = false;
  double prev_t = -1, max_gap = 0;
  double x_from = -1, x_to = -1, z_from = -1, z_to = -1, prev_x = 0, prev_z = 0;
  const auto limit = std::chrono::steady_clock::now() + 30s;
  // A first read right after start(): the plugin integrates from start(), so
  // a deflection already under way (a slow start on a loaded machine) counts from here.
  ASSERT_TRUE(d.read(s));
  prev_t = s.time, prev_x = s.position[0], prev_z = s.position[2];
  for (;;) {
    ASSERT_TRUE(d.read(s));
    ASSERT_EQ(s.status, PALPA_STATUS_VALID);
    if (prev_t >= 0) max_gap = std::max(max_gap, s.time - prev_t);
    if (s.position[0] > prev_x) {
      if (x_from < 0) x_from = prev_t;
      x_to = s.time;
    }
    if (s.position[2] < prev_z) {
      if (z_from < 0) z_from = prev_t;
      z_to = s.time;
    }
    prev_t = s.time, prev_x = s.position[0], prev_z = s.position[2];
    max_x = std::max(max_x, s.position[0]);
    button_seen |= (s.buttons & 1u) != 0;
    if (button_seen && s.buttons == 0 && z_to > 0 && s.time - z_to > 0.15) break;
    ASSERT_LT(std::chrono::steady_clock::now(), limit)
        << "the script did not end within 30 s (a report lost? two read as one are rejected)";
    std::this_thread::sleep_for(2ms);
  }
  ASSERT_GT(x_from, 0);
  ASSERT_GT(z_from, 0);
  // Each interval is known to within one read on either side; reads more than
  // 50 ms apart integrate only 50 ms (the plugin's clamp), so allow for that too.
  const double slack = 0.1 * 2 * max_gap + 1e-3;
  // Full right deflection for 0.3 s, then a pull toward the user for 0.2 s
  // (HID -TY: device z decreases); the twist moves nothing. Each position
  // is checked closely against the time measured, and against the script's
  // time only to at least half of it: a reader that sees a deflection late
  // and its end on time shortens it (by about 100 ms when the whole process
  // was stopped for 80 ms in every 150).
  EXPECT_NEAR(s.position[0], 0.1 * (x_to - x_from), slack) << "moved for " << x_to - x_from << " s";
  EXPECT_GT(s.position[0], 0.1 * 0.3 / 2);
  EXPECT_NEAR(max_x, s.position[0], 1e-12);
  EXPECT_NEAR(s.position[1], 0.0, 1e-12);
  EXPECT_NEAR(s.position[2], -0.1 * (z_to - z_from), slack) << "moved for " << z_to - z_from << " s";
  EXPECT_LT(s.position[2], -0.1 * 0.2 / 2);
  EXPECT_TRUE(button_seen);
  EXPECT_EQ(s.buttons, 0u);  // released again

  // Unplug: the node hangs up and the device disappears.
  const PalpaDeviceSample before = s;
  bed_->hang_up(kHidraw);
  bed_->remove_device(kHidrawSys);
  const auto t1 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t1 < 500ms && !(s.status & PALPA_STATUS_FAULT)) {
    d.read(s);
    std::this_thread::sleep_for(2ms);
  }
  EXPECT_EQ(s.status, PALPA_STATUS_FAULT);
  EXPECT_EQ(s.position[0], before.position[0]);  // the probe does not move
  const std::string m = d.message();
  EXPECT_EQ(m.rfind(std::string("spacemouse: reading ") + kHidraw + " failed (", 0), 0u) << m;
  EXPECT_NE(m.find("unplugged? restart the device"), std::string::npos) << m;
  std::this_thread::sleep_for(50ms);
  d.read(s);
  EXPECT_EQ(s.status, PALPA_STATUS_FAULT);  // latched
}

TEST_F(SpaceMouseEmulated, NoDeviceGivesAClearMessage) {
  bed_->remove_device(kHidrawSys);
  devices::Device d = devices::PluginLoader({PALPA_PLUGIN_DIR}).load("spacemouse").create("");
  try {
    d.start();
    FAIL();
  } catch (const devices::DeviceError& e) {
    EXPECT_STREQ(e.what(),
                 "spacemouse: no 3Dconnexion device found (vendor 046d or 256f); is it plugged in and is "
                 "/dev/hidraw* readable?");
  }
}

}  // namespace
}  // namespace palpa
