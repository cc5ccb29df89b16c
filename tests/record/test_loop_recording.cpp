// The recorder attached to the real-time loop: its writer thread drains the
// HapticLoop's own record queues (the haptic thread only pushes to them);
// the file holds every tick and command of a session driven tick by tick
// on a ManualClock, no record is dropped, and the file alone replays the
// forces bit for bit.

#include "haptics/loop.h"
#include "haptics/loop_replay.h"
#include "mesh/generate.h"
#include "record/recorder.h"
#include "record/session_file.h"
#include "record_rig.h"
#include "../loop/fake_device.h"
#include "../loop/manual_clock.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

namespace palpa::record {
namespace {

constexpr std::uint64_t kTicks = 1200;

void place_probe(palpa::test::FakeDeviceState& st, std::uint64_t tick) {
  const double t = static_cast<double>(tick) * 1e-3;
  st.x = 0.01 * std::sin(3.0 * t);
  st.y = 0.005 * std::cos(2.0 * t);
  st.z = -0.001 - 0.002 * std::pow(std::sin(5.0 * t), 2);
}

TEST(LoopRecording, WriterDrainsTheLoopsQueuesAndTheFileReplaysBitForBit) {
  const auto file = test::temp_dir() / "live.palpa";
  std::filesystem::remove(file);
  auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(61, 61, 1e-3));
  deform::Material m;
  m.stiffness = 400;
  m.damping = 0.5;
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), m);
  palpa::test::ManualClock clock;
  haptics::LoopConfig c;
  c.core.rate_hz = 1000;
  c.core.deform_rate_hz = 300;
  c.core.shape.radius = 0.008;
  c.record_capacity = 1 << 14;
  c.clock = &clock;
  const auto model = haptics::SessionModel::make(mesh, {}, c.core);
  palpa::test::FakeDeviceState st;
  st.clock = [&clock] { return clock.now_s(); };
  place_probe(st, 0);
  auto dev = palpa::test::make_fake_device(st);
  haptics::ProbeBinding b;
  b.device = &dev;
  b.safety.ramp_time = 0.05;
  b.safety.max_force_rate = 500;
  haptics::HapticLoop loop(model, materials, c, {b});
  {
    Recorder r(file, *model, materials, loop.setups(), test::Rig::info("live"));
    r.attach(loop);
    loop.start();
    const bool ran = palpa::test::run_ticks(loop, clock, kTicks, [&](std::uint64_t tick) {
      place_probe(st, tick);
      if (tick == 0) loop.enable(0);
      if (tick == 300) loop.set_clutch(0, true);
      if (tick == 400) loop.set_clutch(0, false);
    });
    loop.stop();
    EXPECT_TRUE(ran);
    r.snapshot(loop.snapshot());
    r.finish();
    r.detach();
    EXPECT_EQ(r.stats().dropped, 0u);
  }
  EXPECT_EQ(loop.statistics().record_drops, 0u);

  const auto f = SessionFile::open(file);
  EXPECT_EQ(f.header().status, SessionStatus::Finished);
  const auto span = f.ticks();
  ASSERT_EQ(span.ticks.size(), kTicks);
  EXPECT_TRUE(span.results.empty()) << "the loop's ticks carry no results";
  std::vector<std::shared_ptr<const deform::MaterialArrays>> keep;
  haptics::LoopRecording rec;
  rec.ticks = span.ticks;
  rec.commands = f.commands(keep);
  rec.deforms = f.deforms();
  ASSERT_EQ(rec.commands.size(), 3u);
  EXPECT_EQ(rec.commands[1].tick, 300u);
  ASSERT_GE(rec.deforms.size(), kTicks * 3 / 10 - 1);
  haptics::LoopReplay replay(f.mesh(), f.initial_materials(), f.header().options, f.header().config, f.header().setups);
  std::size_t same = 0, pushed = 0;
  replay.run(rec, [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> again) {
    same += std::memcmp(&t.force_device[0], &again[0].force_device, sizeof(haptics::Triple)) == 0;
    pushed += again[0].force_device[2] != 0.0;
  });
  EXPECT_EQ(same, kTicks);
  EXPECT_GT(pushed, 600u);
  EXPECT_EQ(f.snapshots().size(), 1u);
}

}  // namespace
}  // namespace palpa::record
