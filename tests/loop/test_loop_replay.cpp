// Exact replay: a live threaded session (moving probe, commands, clutch,
// deformation on its own thread) replayed from its records gives bit-equal
// forces, flags and final surface; a replay snapshot at any tick restores
// into another replay that continues with the same bits (seeking). The live
// session runs on a ManualClock: its commands and probe positions are set
// by tick, so the session is the same however loaded the machine is.

#include "haptics/loop_replay.h"
#include "mesh/generate.h"
#include "bits.h"
#include "fake_device.h"
#include "manual_clock.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

namespace palpa::haptics {
namespace {

constexpr std::uint64_t kTicks = 1200;

/// A live session recorded from a HapticLoop driven tick by tick, and what
/// the loop's model looked like at its end.
struct LiveSession {
  std::shared_ptr<mesh::SurfaceMesh> mesh;
  deform::MaterialArrays materials;
  CoreConfig core;
  std::vector<ProbeSetup> setups;
  LoopRecording rec;
  std::vector<deform::VertexState> final_vertices;
  std::uint64_t record_drops = 0;
};

// The probe presses in and slides; the position is a function of the tick.
void place_probe(test::FakeDeviceState& st, std::uint64_t tick) {
  const double t = static_cast<double>(tick) * 1e-3;
  st.x = 0.01 * std::sin(3.0 * t);
  st.y = 0.005 * std::cos(2.0 * t);
  st.z = -0.001 - 0.002 * std::pow(std::sin(5.0 * t), 2);  // always pressing
}

// The recorded sessions' plane (60 mm, 1 mm cells) and its material: 400
// N/m and 0.5 N s/m at every vertex.
std::shared_ptr<mesh::SurfaceMesh> session_plane() {
  return std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(61, 61, 1e-3));
}
deform::MaterialArrays session_materials(const mesh::SurfaceMesh& mesh) {
  deform::Material m;
  m.stiffness = 400;
  m.damping = 0.5;
  return deform::MaterialArrays::uniform(mesh.vertex_count(), m);
}

// The probe's binding to `dev`: a 50 ms ramp-in, at most 500 N/s.
ProbeBinding session_binding(devices::Device& dev) { return test::fake_binding(dev, 0.05, 500); }

LiveSession record_live_session() {
  LiveSession s;
  s.mesh = session_plane();
  s.materials = session_materials(*s.mesh);

  test::ManualClock clock;
  LoopConfig c;
  c.core.rate_hz = 1000;
  c.core.deform_rate_hz = 300;
  c.core.shape.radius = 0.008;
  c.record_capacity = 1 << 16;
  c.clock = &clock;

  test::FakeDeviceState st;
  st.clock = [&clock] { return clock.now_s(); };
  place_probe(st, 0);
  auto dev = test::make_fake_device(st);
  HapticLoop loop(s.mesh, s.materials, {}, c, {session_binding(dev)});

  loop.start();
  const bool ran = test::run_ticks(loop, clock, kTicks, [&](std::uint64_t tick) {
    place_probe(st, tick);
    if (tick == 0) loop.enable(0);
    if (tick == 300) loop.set_clutch(0, true);
    if (tick == 400) loop.set_clutch(0, false);
    if (tick == 700) loop.disable(0);
    if (tick == 750) loop.enable(0);
    if (tick % 256 == 0) s.rec.drain(loop);
  });
  loop.stop();
  EXPECT_TRUE(ran);
  s.rec.drain(loop);
  s.core = loop.config().core;
  s.setups = loop.setups();
  s.final_vertices = loop.surface().state().vertices;
  s.record_drops = loop.statistics().record_drops;
  return s;
}

TEST(LoopReplay, ReproducesALiveSessionBitForBit) {
  const LiveSession live = record_live_session();
  const LoopRecording& rec = live.rec;
  ASSERT_EQ(rec.ticks.size(), kTicks);
  ASSERT_EQ(rec.commands.size(), 5u);
  EXPECT_EQ(live.record_drops, 0u);
  // Each command took effect at the tick it was issued before.
  const std::uint64_t at[] = {0, 300, 400, 700, 750};
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(rec.commands[i].tick, at[i]);
  // 300 Hz against 1 kHz: 0.3 steps per tick, none dropped, and every tick
  // used the model made from the steps all earlier ticks asked for.
  ASSERT_GE(rec.deforms.size(), kTicks * 3 / 10 - 1);
  ASSERT_LE(rec.deforms.size(), kTicks * 3 / 10);
  std::size_t made_before = 0;
  for (const TickRecord& tr : rec.ticks) {
    while (made_before < rec.deforms.size() && rec.deforms[made_before].contacts_tick < tr.tick) ++made_before;
    ASSERT_EQ(tr.model_generation, made_before) << "tick " << tr.tick;
  }
  for (std::size_t g = 0; g < rec.deforms.size(); ++g) ASSERT_EQ(rec.deforms[g].generation, g + 1);

  // Replay and compare every tick.
  LoopReplay replay(live.mesh, live.materials, {}, live.core, live.setups);
  std::size_t compared = 0, force_diff = 0, flag_diff = 0, nonzero = 0, clutched = 0;
  replay.run(rec, [&](const TickRecord& tr, std::span<const ProbeTickResult> again) {
    ++compared;
    force_diff += !test::same_bits(tr.force_device[0], again[0].force_device);
    flag_diff += tr.flags[0] != again[0].flags;
    nonzero += again[0].force_device[2] != 0.0;
    clutched += again[0].clutched;
  });
  EXPECT_EQ(compared, rec.ticks.size());
  EXPECT_EQ(force_diff, 0u);
  EXPECT_EQ(flag_diff, 0u);
  EXPECT_GT(nonzero, 600u);          // the session did push
  EXPECT_EQ(clutched, 400u - 300u);  // the clutch held from tick 300 to tick 399

  // The model: the same generation and bitwise the same vertex states.
  EXPECT_EQ(replay.generation(), rec.deforms.back().generation);
  EXPECT_EQ(test::vertex_differences(live.final_vertices, replay.surface().state().vertices), 0u);
  EXPECT_GT(test::dented(live.final_vertices), 0u);
}

// The same on the real clock, with the haptic thread's spin and its warm-ups
// as in the workbench (LoopConfig::warm_before_tick): there, which replica a
// tick reads depends on how the two threads meet (a step published during a
// tick's held warm-up is read from the next tick on), but every tick records
// the generation it read, so the replay must still give the same bits, and
// the generations the ticks read never go back. Nothing here depends on how
// fast the threads run; under ThreadSanitizer (tools/tsan.sh) this is also
// the run in which the deformation thread publishes while the haptic thread
// holds a replica.
TEST(LoopReplay, ReproducesALiveSessionOnTheRealClockWithTheHeldWarmUp) {
  const auto mesh = session_plane();
  const deform::MaterialArrays materials = session_materials(*mesh);
  // 10 kHz with the spin the workbench plans for it (40% of the period): a
  // step on this small plane is published tens of microseconds after the
  // tick that asked for it, so some land in the next tick's last 10 us,
  // during its held warm-up.
  LoopConfig c;
  c.core.rate_hz = 10000;
  c.core.deform_rate_hz = 500;
  c.core.shape.radius = 0.008;
  c.record_capacity = 1 << 16;
  c.realtime = false;
  c.spin_us = 40;
  ASSERT_TRUE(c.warm_before_tick);

  test::FakeDeviceState st;  // samples timed by CLOCK_MONOTONIC, as the loop's clock
  place_probe(st, 0);
  auto dev = test::make_fake_device(st);
  HapticLoop loop(mesh, materials, {}, c, {session_binding(dev)});
  LoopRecording rec;
  loop.start();
  loop.enable(0);
  // 0.2 s unloaded; the bound is for a loaded machine, where the haptic
  // thread (not real-time here) skips the periods it is held up past.
  constexpr std::uint64_t kLiveTicks = 2000;
  constexpr std::chrono::seconds kBound{60};
  const bool ran = test::wait_until(
      [&] {
        place_probe(st, loop.ticks() / 10);  // the path of the 1 kHz session, ten times slower
        rec.drain(loop);
        return loop.ticks() >= kLiveTicks;
      },
      kBound);
  loop.stop();
  ASSERT_TRUE(ran) << "the loop made " << loop.ticks() << " ticks in " << kBound.count() << " s";
  rec.drain(loop);
  ASSERT_EQ(loop.statistics().record_drops, 0u);
  ASSERT_GE(rec.ticks.size(), kLiveTicks);
  ASSERT_FALSE(rec.deforms.empty());

  // Generations read never go back; count the ticks that read a replica
  // while a newer one had already been published (held across a publish).
  std::size_t behind = 0, next_deform = 0;
  for (std::size_t k = 0; k < rec.ticks.size(); ++k) {
    const TickRecord& tr = rec.ticks[k];
    if (k > 0) {
      ASSERT_GE(tr.model_generation, rec.ticks[k - 1].model_generation) << "tick " << tr.tick;
    }
    while (next_deform < rec.deforms.size() && rec.deforms[next_deform].generation <= tr.model_generation)
      ++next_deform;
    behind += next_deform < rec.deforms.size() && rec.deforms[next_deform].time < tr.time;
  }
  std::printf("[ real clock ] %zu ticks, %zu steps, %llu warm-ups; %zu ticks read a replica held across a publish\n",
              rec.ticks.size(), rec.deforms.size(), static_cast<unsigned long long>(loop.warm_ups()), behind);

  LoopReplay replay(mesh, materials, {}, loop.config().core, loop.setups());
  std::size_t compared = 0, force_diff = 0, flag_diff = 0, nonzero = 0;
  replay.run(rec, [&](const TickRecord& tr, std::span<const ProbeTickResult> again) {
    ++compared;
    force_diff += !test::same_bits(tr.force_device[0], again[0].force_device);
    flag_diff += tr.flags[0] != again[0].flags;
    nonzero += again[0].force_device[2] != 0.0;
  });
  EXPECT_EQ(compared, rec.ticks.size());
  EXPECT_EQ(force_diff, 0u);
  EXPECT_EQ(flag_diff, 0u);
  EXPECT_GT(nonzero, 0u);  // the probe pressed
  EXPECT_EQ(test::vertex_differences(loop.surface().state().vertices, replay.surface().state().vertices), 0u);
}

TEST(LoopReplay, SeeksFromASnapshotAtAnyTick) {
  const LiveSession live = record_live_session();
  const LoopRecording& rec = live.rec;
  ASSERT_EQ(rec.ticks.size(), kTicks);

  // The whole replay, every tick's results kept.
  std::vector<ProbeTickResult> full;
  LoopReplay whole(live.mesh, live.materials, {}, live.core, live.setups);
  whole.run(rec, [&](const TickRecord&, std::span<const ProbeTickResult> r) { full.push_back(r[0]); });
  ASSERT_EQ(full.size(), kTicks);
  const auto whole_end = whole.surface().state().vertices;

  // Seek points: inside the clutch, while disabled, on and off a
  // deformation boundary, the first and the last tick.
  for (const std::uint64_t k : {std::uint64_t{0}, std::uint64_t{1}, std::uint64_t{333}, std::uint64_t{350},
                                std::uint64_t{720}, std::uint64_t{1000}, kTicks - 1}) {
    SCOPED_TRACE("seek to tick " + std::to_string(k));
    LoopReplay first(live.mesh, live.materials, {}, live.core, live.setups);
    first.run(rec, nullptr, k);
    ASSERT_EQ(first.tick(), k);
    const ReplayState snap = first.snapshot();

    // (a) A new replay restored from the snapshot.
    LoopReplay seek(live.mesh, live.materials, {}, live.core, live.setups);
    seek.restore(snap);
    ASSERT_EQ(seek.tick(), k);
    std::uint64_t tick = k;
    std::size_t differ = 0;
    std::string first_field;
    seek.run(rec, [&](const TickRecord& tr, std::span<const ProbeTickResult> r) {
      ASSERT_EQ(tr.tick, tick);
      const std::string d = test::result_difference(full[tick], r[0]);
      if (!d.empty() && first_field.empty()) first_field = d + " at tick " + std::to_string(tick);
      differ += !d.empty();
      ++tick;
    });
    EXPECT_EQ(tick, kTicks);
    EXPECT_EQ(differ, 0u) << first_field;
    EXPECT_EQ(test::vertex_differences(whole_end, seek.surface().state().vertices), 0u);

    // (b) The replay that ran to the end, sent back to tick k.
    whole.restore(snap);
    tick = k;
    differ = 0;
    whole.run(rec, [&](const TickRecord&, std::span<const ProbeTickResult> r) {
      differ += !test::result_difference(full[tick], r[0]).empty();
      ++tick;
    });
    EXPECT_EQ(tick, kTicks);
    EXPECT_EQ(differ, 0u);
    EXPECT_EQ(test::vertex_differences(whole_end, whole.surface().state().vertices), 0u);
  }
  // And the replay equals the live loop.
  EXPECT_EQ(test::vertex_differences(live.final_vertices, whole_end), 0u);
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
