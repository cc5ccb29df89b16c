// Exact replay: a live threaded session (moving probe, commands, clutch,
// deformation on its own thread) replayed from its records gives bit-equal
// forces, flags and final surface.

#include "haptics/loop_replay.h"
#include "mesh/generate.h"
#include "fake_device.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

namespace palpa::haptics {
namespace {

using namespace std::chrono_literals;

TEST(LoopReplay, ReproducesALiveSessionBitForBit) {
  auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(61, 61, 1e-3));
  deform::Material m;
  m.stiffness = 400;
  m.damping = 0.5;
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), m);
  LoopConfig c;
  c.core.rate_hz = 1000;
  c.core.deform_rate_hz = 300;
  c.core.shape.radius = 0.008;
  c.record_capacity = 1 << 16;

  test::FakeDeviceState st;
  st.z = 0.002;
  auto dev = test::make_fake_device(st);
  ProbeBinding b;
  b.device = &dev;
  b.safety.ramp_time = 0.05;
  b.safety.max_force_rate = 500;
  HapticLoop loop(mesh, materials, {}, c, {b});

  // Live: the probe presses in and slides while the test issues commands.
  LoopRecording rec;
  loop.start();
  loop.enable(0);
  const auto t0 = std::chrono::steady_clock::now();
  int step = 0;
  while (std::chrono::steady_clock::now() - t0 < 1200ms) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    st.x = 0.01 * std::sin(3.0 * t);
    st.y = 0.005 * std::cos(2.0 * t);
    st.z = -0.001 - 0.002 * std::pow(std::sin(5.0 * t), 2);  // always pressing
    if (step == 300) loop.set_clutch(0, true);
    if (step == 400) loop.set_clutch(0, false);
    if (step == 700) loop.disable(0);
    if (step == 750) loop.enable(0);
    ++step;
    rec.drain(loop);
    std::this_thread::sleep_for(1ms);
  }
  loop.stop();
  rec.drain(loop);
  ASSERT_GT(rec.ticks.size(), 900u);
  ASSERT_GT(rec.deforms.size(), 200u);
  ASSERT_EQ(rec.commands.size(), 5u);
  ASSERT_EQ(loop.statistics().record_drops, 0u);

  // Replay and compare every tick.
  LoopReplay replay(mesh, materials, {}, loop.config().core, loop.setups());
  std::size_t compared = 0, force_diff = 0, flag_diff = 0, nonzero = 0;
  replay.run(rec, [&](const TickRecord& live, std::span<const ProbeTickResult> again) {
    ++compared;
    force_diff += std::memcmp(live.force_device[0].data(), again[0].force_device.data(), sizeof(Triple)) != 0;
    flag_diff += live.flags[0] != again[0].flags;
    nonzero += again[0].force_device[2] != 0.0;
  });
  EXPECT_EQ(compared, rec.ticks.size());
  EXPECT_EQ(force_diff, 0u);
  EXPECT_EQ(flag_diff, 0u);
  EXPECT_GT(nonzero, 200u);  // the session did push

  // The model: the same generation and bitwise the same vertex states.
  const auto& live = loop.surface().state().vertices;
  const auto& again = replay.surface().state().vertices;
  ASSERT_EQ(live.size(), again.size());
  EXPECT_EQ(replay.generation(), rec.deforms.back().generation);
  std::size_t state_diff = 0, moved = 0;
  for (std::size_t i = 0; i < live.size(); ++i) {
    state_diff += std::memcmp(&live[i], &again[i], sizeof(live[i])) != 0;
    moved += live[i].h != 0.0;
  }
  EXPECT_EQ(state_diff, 0u);
  EXPECT_GT(moved, 0u);
}

TEST(LoopReplay, RefusesIncompleteRecordings) {
  auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(5, 5, 1e-3));
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), deform::Material{});
  ProbeSetup s;
  s.name = "p";
  s.spec.force_dof = 3;
  s.spec.max_force = 5;
  LoopReplay replay(mesh, materials, {}, CoreConfig{}, {s});
  LoopRecording rec;
  rec.ticks.resize(2);
  rec.ticks[0].tick = 0;
  rec.ticks[0].probe_count = 1;
  rec.ticks[1].tick = 1;
  rec.ticks[1].probe_count = 1;
  rec.ticks[1].model_generation = 1;
  try {
    replay.run(rec, nullptr);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "replay: deformation step 1 used by tick 1 is missing from the recording");
  }
  LoopReplay replay2(mesh, materials, {}, CoreConfig{}, {s});
  rec.ticks.erase(rec.ticks.begin());
  try {
    replay2.run(rec, nullptr);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "replay: the recording starts at tick 1, not at tick 0");
  }
}

}  // namespace
}  // namespace palpa::haptics
