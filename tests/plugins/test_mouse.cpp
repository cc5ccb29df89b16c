// The `mouse` plugin: the host feeds positions through palpa_device_feed
// (Device::feed), lock-free; the loop reads them like any device.

#include "devices/loader.h"
#include "haptics/loop.h"
#include "mesh/generate.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace palpa {
namespace {

using namespace std::chrono_literals;

devices::Device make_mouse(const std::string& options = "") {
  devices::Device d = devices::PluginLoader({PALPA_PLUGIN_DIR}).load("mouse").create(options);
  d.start();
  return d;
}

PalpaDeviceSample at(double x, double y, double z, std::uint32_t buttons = 0) {
  PalpaDeviceSample s{};
  s.orientation[0] = 1;
  s.position[0] = x;
  s.position[1] = y;
  s.position[2] = z;
  s.buttons = buttons;
  return s;
}

TEST(MousePlugin, SpecIsAVirtualProbeWithoutForce) {
  devices::Device d = make_mouse("workspace=0.25;rate=120;buttons=2");
  EXPECT_TRUE(d.can_feed());
  EXPECT_EQ(d.spec().position_dof, 3u);
  EXPECT_EQ(d.spec().force_dof, 0u);
  EXPECT_EQ(d.spec().workspace_max[1], 0.25);
  EXPECT_EQ(d.spec().nominal_rate, 120.0);
  EXPECT_EQ(d.spec().button_count, 2u);
  PalpaForceCommand c{};
  EXPECT_FALSE(d.write(c));  // no force output
}

TEST(MousePlugin, NothingValidUntilTheFirstFeed) {
  devices::Device d = make_mouse();
  PalpaDeviceSample s;
  ASSERT_TRUE(d.read(s));
  EXPECT_EQ(s.status & PALPA_STATUS_VALID, 0u);
  EXPECT_EQ(s.sequence, 0u);
  EXPECT_EQ(d.message(), "mouse: waiting for the first position");
}

TEST(MousePlugin, FedSamplesAreStampedAndReadBack) {
  devices::Device d = make_mouse();
  ASSERT_TRUE(d.feed(at(0.01, 0.02, 0.03, 5)));
  PalpaDeviceSample s;
  ASSERT_TRUE(d.read(s));
  EXPECT_EQ(s.position[0], 0.01);
  EXPECT_EQ(s.position[1], 0.02);
  EXPECT_EQ(s.position[2], 0.03);
  EXPECT_EQ(s.buttons, 5u);
  EXPECT_EQ(s.status, PALPA_STATUS_VALID);
  EXPECT_EQ(s.sequence, 1u);
  EXPECT_GT(s.time, 0.0);
  ASSERT_TRUE(d.feed(at(0.04, 0, 0)));
  ASSERT_TRUE(d.read(s));
  EXPECT_EQ(s.sequence, 2u);
  EXPECT_EQ(s.position[0], 0.04);
  EXPECT_EQ(d.message(), "mouse: running");
}

TEST(MousePlugin, ConcurrentFeedAndReadNeverTear) {
  devices::Device d = make_mouse();
  std::atomic<bool> done{false};
  std::thread feeder([&] {
    for (int k = 1; k <= 500'000; ++k) d.feed(at(k, 2.0 * k, 3.0 * k));
    done.store(true);
  });
  std::uint64_t last = 0, torn = 0, backwards = 0, reads = 0;
  while (!done.load()) {
    PalpaDeviceSample s;
    d.read(s);
    if (s.sequence == 0) continue;
    torn += s.position[1] != 2 * s.position[0] || s.position[2] != 3 * s.position[0] ||
            s.sequence != static_cast<std::uint64_t>(s.position[0]);
    backwards += s.sequence < last;
    last = s.sequence;
    ++reads;
  }
  feeder.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_GT(reads, 0u);
}

TEST(MousePlugin, DrivesTheHapticLoopLikeAnyDevice) {
  auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(41, 41, 1e-3));
  deform::Material m;
  m.stiffness = 500;
  devices::Device d = make_mouse();
  haptics::LoopConfig c;
  c.core.deform_rate_hz = 200;
  haptics::ProbeBinding b;
  b.device = &d;
  haptics::HapticLoop loop(mesh, deform::MaterialArrays::uniform(mesh->vertex_count(), m), {}, c, {b});
  loop.start();
  // The GUI feeds at display rate.
  for (int i = 0; i < 30; ++i) {
    d.feed(at(0.001, 0.0, -0.002));
    std::this_thread::sleep_for(10ms);
  }
  const haptics::LoopView v = loop.view();
  loop.stop();
  EXPECT_TRUE(v.probes[0].in_contact) << "flags " << v.probes[0].flags << " tick " << v.tick << " z "
                                      << v.probes[0].world[2] << " status " << v.probes[0].sample.status;
  EXPECT_NEAR(v.probes[0].world[0], 0.001, 1e-15);
  EXPECT_NEAR(v.probes[0].force_world[2], 500 * 0.002, 1e-3);  // shown, not sent
  EXPECT_EQ(v.probes[0].force_device, (haptics::Triple{0, 0, 0}));
}

}  // namespace
}  // namespace palpa
