// The session engine: snapshots restore exactly at any point of a session
// (into the same Session or a fresh one); the threaded HapticLoop driven by
// a ManualClock gives the same bits as a Session fed the same inputs and
// commands at the same ticks; edits on a running loop (material, shape,
// probes) keep the dent and the other probes and take effect when they
// should (closed-form forces on a flat plane); with nobody taking the
// surface changes memory stays flat; the surface mailbox hands over
// exactly the writer's stream.

#include "haptics/session.h"
#include "haptics/loop.h"
#include "haptics/loop_replay.h"
#include "haptics/spin_warm.h"
#include "mesh/generate.h"
#include "bits.h"
#include "fake_device.h"
#include "manual_clock.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <thread>
#include <unistd.h>

namespace palpa::haptics {
namespace {

// ---- a scripted session: probe positions and edits by tick ---------------------

constexpr std::uint64_t kTicks = 1500;
constexpr double kRadius = 0.008;
constexpr double kK0 = 400, kK1 = 700;  // N/m: the material before and after the edit at tick 400
constexpr double kDepth1 = 0.0015;      // m: probe 1 presses still at this depth

// Tick i's time (s), as a loop on a ManualClock starting at 1 s computes it.
double tick_time(std::uint64_t i) { return static_cast<double>(std::int64_t{1'000'000'000} + std::int64_t(i + 1) * 1'000'000) * 1e-9; }

// Probe positions (device frame = world frame) as functions of the tick.
Triple probe_position(std::size_t slot, std::uint64_t tick) {
  const double t = static_cast<double>(tick) * 1e-3;
  switch (slot) {
    case 0: {  // slides and presses, always in contact
      const double s = std::sin(4.0 * t);
      return {0.012 * std::sin(2.0 * t), 0.006 * std::cos(3.0 * t), -0.001 - 0.002 * s * s};
    }
    case 1: return {-0.02, -0.02, -kDepth1};  // presses still until removed
    default: return {0.02, 0.018 + 0.004 * std::sin(1.5 * t), -0.002};  // added later, slides along y
  }
}

constexpr std::uint64_t kClutchOn = 200, kClutchOff = 260, kMaterial = 400, kShape = 700, kAdd = 800,
                        kEnable2 = 801, kRemove = 1000, kForce = 1200, kMaterialMap = 1300;

deform::Material material(double k) {
  deform::Material m;
  m.stiffness = k;
  m.damping = 0.8;
  return m;
}

deform::ShapeFunction small_shape() {
  deform::ShapeFunction s;
  s.radius = 0.005;
  return s;
}

ForceParams more_friction() {
  ForceParams f;
  f.friction = 0.5;
  return f;
}

std::shared_ptr<mesh::SurfaceMesh> plane() {
  return std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(61, 61, 1e-3));
}

CoreConfig core_config() {
  CoreConfig c;
  c.rate_hz = 1000;
  c.deform_rate_hz = 300;  // not a divisor of the tick rate: steps every 3 or 4 ticks
  c.shape.radius = kRadius;
  return c;
}

PalpaDeviceSpec fake_spec() {
  PalpaDeviceSpec s{};  // as test::make_fake_device gives
  s.position_dof = 3;
  s.force_dof = 3;
  s.max_force = 5.0;
  s.max_stiffness = 1e5;
  s.nominal_rate = 1000;
  return s;
}

SafetyLimits limits() {
  SafetyLimits l;
  l.ramp_time = 0.05;
  l.max_force_rate = 500;
  return l;
}

ProbeSetup setup(const std::string& name) {
  ProbeSetup s;
  s.name = name;
  s.spec = fake_spec();
  s.safety = limits();
  return s;
}

// A per-vertex map (stiffness growing with x), for the edit at kMaterialMap.
deform::MaterialArrays stiffness_map(const mesh::SurfaceMesh& m) {
  auto a = deform::MaterialArrays::uniform(m.vertex_count(), material(kK1));
  for (std::size_t i = 0; i < m.vertex_count(); ++i) a.stiffness[i] = 500 + 10000 * (m.positions[i][0] + 0.03);
  return a;
}

// The first tick at which slot `slot` is read.
std::uint64_t first_read(std::size_t slot) { return slot == 2 ? kAdd : 0; }

// What the fake device of `slot` returns at `tick` (see fake_device.h).
ProbeTickInput input(std::size_t slot, std::uint64_t tick) {
  ProbeTickInput in;
  in.sample.orientation[0] = 1;
  const Triple p = probe_position(slot, tick);
  for (int k = 0; k < 3; ++k) in.sample.position[k] = p[k];
  in.sample.status = PALPA_STATUS_VALID;
  in.sample.sequence = tick - first_read(slot) + 1;
  in.sample.time = tick_time(tick);
  return in;
}

LoopCommand command(LoopCommandKind kind, std::uint32_t probe = 0) {
  LoopCommand c;
  c.kind = kind;
  c.probe = probe;
  return c;
}

// The script's edits at `tick`, applied to a Session.
void script_edits(Session& s, std::uint64_t tick) {
  const double t = tick_time(tick);
  if (tick == 0) {
    s.apply(command(LoopCommandKind::Enable, 0), t);
    s.apply(command(LoopCommandKind::Enable, 1), t);
  }
  if (tick == kClutchOn) s.apply(command(LoopCommandKind::ClutchOn, 0), t);
  if (tick == kClutchOff) s.apply(command(LoopCommandKind::ClutchOff, 0), t);
  if (tick == kMaterial) {
    LoopCommand c = command(LoopCommandKind::SetMaterial);
    c.material = material(kK1);
    s.apply(c, t);
  }
  if (tick == kShape) {
    LoopCommand c = command(LoopCommandKind::SetShape);
    c.shape = small_shape();
    s.apply(c, t);
  }
  if (tick == kAdd) {
    LoopCommand c = command(LoopCommandKind::AddProbe, 2);
    c.prepared = LoopCore::prepare(setup("fake"), s.model().config);
    s.apply(c, t);
  }
  if (tick == kEnable2) s.apply(command(LoopCommandKind::Enable, 2), t);
  if (tick == kRemove) s.apply(command(LoopCommandKind::RemoveProbe, 1), t);
  if (tick == kForce) {
    LoopCommand c = command(LoopCommandKind::SetForce);
    c.force = more_friction();
    s.apply(c, t);
  }
  if (tick == kMaterialMap) s.set_materials(stiffness_map(*s.model().mesh), t);
}

// One tick's results, every slot.
struct TickOut {
  std::size_t n = 0;
  std::array<ProbeTickResult, kMaxProbes> r{};
};

// Steps `s` from its current tick to `to`, recording every tick's results
// and the snapshots taken (before the tick's edits) at the ticks in `snap_at`.
void drive(Session& s, std::uint64_t to, std::vector<TickOut>& out, const std::vector<std::uint64_t>& snap_at = {},
           std::map<std::uint64_t, SessionState>* snaps = nullptr) {
  std::array<ProbeTickInput, kMaxProbes> in{};
  while (s.tick_count() < to) {
    const std::uint64_t tick = s.tick_count();
    if (snaps && std::find(snap_at.begin(), snap_at.end(), tick) != snap_at.end()) (*snaps)[tick] = s.snapshot();
    script_edits(s, tick);
    TickOut o;
    o.n = s.core().probe_count();
    for (std::size_t i = 0; i < o.n; ++i) in[i] = input(i, tick);
    s.step(tick_time(tick), std::span<const ProbeTickInput>(in.data(), o.n),
           std::span<ProbeTickResult>(o.r.data(), o.n));
    out.push_back(o);
  }
}

double force_norm(const ProbeTickResult& r) {
  return std::sqrt(r.force_world[0] * r.force_world[0] + r.force_world[1] * r.force_world[1] +
                   r.force_world[2] * r.force_world[2]);
}

// How many ticks of `got` (starting at tick `from`) differ from `want` in any bit.
std::size_t differing_ticks(const std::vector<TickOut>& want, const std::vector<TickOut>& got, std::uint64_t from,
                            std::string* first = nullptr) {
  std::size_t n = 0;
  for (std::size_t k = 0; k < got.size(); ++k) {
    const TickOut& a = want[from + k];
    const TickOut& b = got[k];
    std::string d = a.n != b.n ? "probe count" : "";
    for (std::size_t i = 0; i < a.n && d.empty() && a.n == b.n; ++i) {
      d = test::result_difference(a.r[i], b.r[i]);
      if (!d.empty()) d += " of slot " + std::to_string(i);
    }
    if (!d.empty() && first && first->empty()) *first = d + " at tick " + std::to_string(from + k);
    n += !d.empty();
  }
  return n;
}

TEST(Session, ScriptedSessionBehavesAsThePhysicsSays) {
  // Guards for the snapshot tests below: the scripted session really
  // presses, clutches, edits and adds and removes probes.
  auto mesh = plane();
  Session s(mesh, deform::MaterialArrays::uniform(mesh->vertex_count(), material(kK0)), {}, core_config(),
            {setup("moving"), setup("still")});
  std::vector<TickOut> out;
  drive(s, kTicks, out);
  ASSERT_EQ(out.size(), kTicks);
  // Probe 1 presses still: |F| = k d exactly once ramped in (no velocity, no
  // friction), k the material of the last deformation step before the tick.
  EXPECT_NEAR(force_norm(out[kMaterial - 1].r[1]), kK0 * kDepth1, 1e-12);
  EXPECT_NEAR(force_norm(out[kMaterial + 10].r[1]), kK1 * kDepth1, 1e-12);
  std::size_t clutched = 0, pushing = 0;
  for (const TickOut& o : out) {
    clutched += o.r[0].clutched;
    pushing += force_norm(o.r[0]) > 0.1;
  }
  EXPECT_EQ(clutched, kClutchOff - kClutchOn);
  EXPECT_GT(pushing, kTicks / 2);
  // Slot 2 appears at kAdd and pushes once enabled; slot 1 is empty after kRemove.
  EXPECT_EQ(out[kAdd - 1].n, 2u);
  EXPECT_EQ(out[kAdd].n, 3u);
  EXPECT_TRUE(out[kAdd + 100].r[2].in_contact);
  EXPECT_GT(force_norm(out[kAdd + 100].r[2]), 0.5);
  EXPECT_FALSE(out[kRemove].r[1].in_contact);
  EXPECT_EQ(force_norm(out[kRemove].r[1]), 0.0);
  EXPECT_EQ(s.generation(), s.core().state().generations);
  EXPECT_GT(test::dented(s.surface().state().vertices), 0u);
  // Under still probe 1 the surface came back to rest once it was removed.
  const collision::VertexTree tree(std::span<const Vec3>(mesh->positions));
  const Index under1 = tree.nearest(Vec3(-0.02, -0.02, 0)).vertex;
  EXPECT_EQ(s.surface().state().vertices[under1].h, 0.0);
}

TEST(Session, SnapshotsRestoreExactlyAtAnyPoint) {
  auto mesh = plane();
  const auto model = SessionModel::make(mesh, {}, core_config());
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), material(kK0));
  const std::vector<ProbeSetup> setups{setup("moving"), setup("still")};

  // The uninterrupted run, with snapshots on the way.
  const std::vector<std::uint64_t> points{150, 600, 1100, 1400};
  std::map<std::uint64_t, SessionState> snaps;
  Session full(model, materials, setups);
  std::vector<TickOut> want;
  drive(full, kTicks, want, points, &snaps);
  ASSERT_EQ(snaps.size(), points.size());
  const auto want_end = full.surface().state().vertices;
  const std::uint64_t want_generation = full.generation();
  ASSERT_GT(test::dented(want_end), 0u);

  for (const std::uint64_t p : points) {
    SCOPED_TRACE("snapshot at tick " + std::to_string(p));
    const SessionState& snap = snaps.at(p);
    EXPECT_EQ(snap.tick, p);
    EXPECT_GT(test::dented(snap.surface.vertices), 0u);  // a snapshot of a pressed surface

    // (a) The same Session, which has run to the end meanwhile.
    full.restore(snap);
    ASSERT_EQ(full.tick_count(), p);
    std::vector<TickOut> again;
    drive(full, kTicks, again);
    std::string first;
    EXPECT_EQ(differing_ticks(want, again, p, &first), 0u) << first;
    EXPECT_EQ(test::vertex_differences(want_end, full.surface().state().vertices), 0u);
    EXPECT_EQ(full.generation(), want_generation);

    // (b) A fresh Session on the same model.
    Session fresh(model, materials, setups);
    fresh.restore(snap);
    std::vector<TickOut> other;
    drive(fresh, kTicks, other);
    first.clear();
    EXPECT_EQ(differing_ticks(want, other, p, &first), 0u) << first;
    EXPECT_EQ(test::vertex_differences(want_end, fresh.surface().state().vertices), 0u);
    EXPECT_EQ(fresh.generation(), want_generation);
  }

  // Without the restore a fresh session does not land there: the check sees
  // what the snapshot carries.
  Session unrestored(model, materials, setups);
  std::vector<TickOut> skipped;
  std::array<ProbeTickInput, kMaxProbes> in{};
  std::array<ProbeTickResult, kMaxProbes> r{};
  for (std::uint64_t tick = 0; tick < 20; ++tick) {
    for (std::size_t i = 0; i < 2; ++i) in[i] = input(i, 600 + tick);
    unrestored.step(tick_time(600 + tick), std::span<const ProbeTickInput>(in.data(), 2),
                    std::span<ProbeTickResult>(r.data(), 2));
    if (tick == 19) {
      EXPECT_NE(test::result_difference(r[0], want[619].r[0]), "");
    }
  }
}

// ---- the threaded loop against Session ------------------------------------------

// A loop on a ManualClock with the script's probes as fake devices.
struct LiveRig {
  test::ManualClock clock;
  std::array<test::FakeDeviceState, 3> st;
  std::vector<devices::Device> devs;
  std::unique_ptr<HapticLoop> loop;

  SafetyLimits safety = limits();

  LiveRig(std::shared_ptr<const SessionModel> model, const deform::MaterialArrays& materials, std::size_t probes,
          const SafetyLimits& safety_limits = limits(), double spin_us = 0)
      : safety(safety_limits) {
    for (std::size_t i = 0; i < st.size(); ++i) {
      st[i].clock = [this] { return clock.now_s(); };
      place(i, 0);
    }
    devs.reserve(st.size());
    for (auto& s : st) devs.push_back(test::make_fake_device(s));
    LoopConfig c;
    c.clock = &clock;
    c.spin_us = spin_us;  // with it, the warm-up at the spin's start (warm_before_tick)
    std::vector<ProbeBinding> b;
    for (std::size_t i = 0; i < probes; ++i) b.push_back(binding(i));
    loop = std::make_unique<HapticLoop>(model, materials, c, b);
  }
  ~LiveRig() { loop->stop(); }
  ProbeBinding binding(std::size_t i) {
    ProbeBinding b;
    b.device = &devs[i];
    b.name = "fake";
    b.safety = safety;
    return b;
  }
  void place(std::size_t slot, std::uint64_t tick) {
    const Triple p = probe_position(slot, tick);
    st[slot].x = p[0];
    st[slot].y = p[1];
    st[slot].z = p[2];
  }
};

// One tick of a started `loop` with a spin of `spin_us`, with the clock
// stopped 1 us into the spin first: where `expect_warm`, a warm-up must run
// there (and make no tick); otherwise the haptic thread is given 200 ms in
// which a warm-up would show, and none may. With `stop_at_hold` the clock
// then stops again at the spin's deadline (haptics::warm_deadline_ns before
// the tick), where the held warm-up must run (where `expect_warm`). Then the
// rest of the period makes the tick.
void tick_through_spin(HapticLoop& loop, test::ManualClock& clock, double spin_us, bool expect_warm,
                       bool stop_at_hold = false) {
  const std::int64_t period = test::period_ns(loop);
  const auto spin_ns = static_cast<std::int64_t>(spin_us * 1e3);
  const std::int64_t into_spin = period - spin_ns + 1000;
  const std::uint64_t tick = loop.ticks();
  // Moves the clock by `by` ns, then checks for the warm-up it should start.
  auto advance_expecting_warm_up = [&](std::int64_t by, const char* where) {
    const std::uint64_t warm_ups = loop.warm_ups();
    clock.advance(by);
    if (expect_warm) {
      ASSERT_TRUE(clock.await([&] { return loop.warm_ups() > warm_ups; }, test::kLoopWaitTimeout))
          << "no warm-up " << where << " before tick " << tick;
    } else {
      EXPECT_FALSE(clock.await([&] { return loop.warm_ups() > warm_ups; }, std::chrono::milliseconds(200)))
          << "a warm-up " << where << " before tick " << tick;
    }
    ASSERT_EQ(loop.ticks(), tick) << "the warm-up " << where << " made a tick";
  };
  ASSERT_NO_FATAL_FAILURE(advance_expecting_warm_up(into_spin, "at the spin's start"));
  std::int64_t at = into_spin;
  if (stop_at_hold) {
    const std::int64_t hold = period - haptics::warm_deadline_ns(spin_ns);
    ASSERT_NO_FATAL_FAILURE(advance_expecting_warm_up(hold - at, "at the deadline (held)"));
    at = hold;
  }
  clock.advance(period - at);
  ASSERT_TRUE(clock.await([&] { return loop.ticks() > tick && loop.deform_idle(); }, test::kLoopWaitTimeout))
      << "tick " << tick;
}

// The live loop, fed the script's positions and edits at the same ticks as
// Session::step, gives the same bits; `spin_us` > 0 adds the haptic thread's
// warm-up run of the last tick before each tick, and `stop_at_hold` the held
// warm-up at the spin's deadline, whose replica the tick then reads.
void expect_loop_equals_session(double spin_us, bool stop_at_hold = false) {
  auto mesh = plane();
  const auto model = SessionModel::make(mesh, {}, core_config());
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), material(kK0));

  // The single-threaded reference.
  Session session(model, materials, {setup("fake"), setup("fake")});
  std::vector<TickOut> want;
  drive(session, kTicks, want);

  // The live loop, fed the same positions and edits at the same ticks.
  LiveRig rig(model, materials, 2, limits(), spin_us);
  rig.loop->start();
  std::size_t differ = 0, slot = 99;
  std::string first;
  std::vector<TickOut> got;
  for (std::uint64_t tick = 0; tick < kTicks; ++tick) {
    for (std::size_t i = 0; i < 3; ++i) rig.place(i, tick);
    HapticLoop& loop = *rig.loop;
    if (tick == 0) {
      loop.enable(0);
      loop.enable(1);
    }
    if (tick == kClutchOn) loop.set_clutch(0, true);
    if (tick == kClutchOff) loop.set_clutch(0, false);
    if (tick == kMaterial) loop.set_material(material(kK1));
    if (tick == kShape) loop.set_shape(small_shape());
    if (tick == kAdd) loop.add_probe(rig.binding(2), slot);
    if (tick == kEnable2) loop.enable(2);
    if (tick == kRemove) loop.remove_probe(1);
    if (tick == kForce) loop.set_force(more_friction());
    if (tick == kMaterialMap) loop.set_materials(stiffness_map(*mesh));
    if (spin_us > 0 && tick > 0) {
      // The warm-up runs at the spin's start (and, with stop_at_hold, the
      // held one at the deadline), then the tick.
      ASSERT_NO_FATAL_FAILURE(tick_through_spin(loop, rig.clock, spin_us, true, stop_at_hold));
    } else {
      ASSERT_TRUE(test::run_ticks(loop, rig.clock, 1));
    }
    const LoopView v = loop.view();
    ASSERT_EQ(v.tick, tick);
    TickOut o;
    o.n = v.probe_count;
    for (std::size_t i = 0; i < o.n; ++i) o.r[i] = v.probes[i];
    got.push_back(o);
  }
  EXPECT_EQ(slot, 2u);
  differ = differing_ticks(want, got, 0, &first);
  EXPECT_EQ(differ, 0u) << first;
  rig.loop->stop();
  EXPECT_EQ(test::vertex_differences(session.surface().state().vertices, rig.loop->surface().state().vertices), 0u);
  EXPECT_EQ(rig.loop->core_state().generations, session.core().state().generations);
  // The removed device was told zero and not read again.
  EXPECT_EQ(rig.st[1].reads.load(), kRemove);
  EXPECT_EQ(rig.st[2].reads.load(), kTicks - kAdd);
  // One warm-up before every tick after the first with a spin (the clock
  // then stands still until the tick's time), a second (the held one) where
  // the clock stopped at the deadline too, none without a spin.
  EXPECT_EQ(rig.loop->warm_ups(), spin_us > 0 ? (stop_at_hold ? 2 : 1) * (kTicks - 1) : 0u);
}

TEST(Session, ThreadedLoopEqualsSessionStepBitForBit) { expect_loop_equals_session(0); }

// The warm-up runs the last tick again on the replica the next tick reads,
// on the haptic thread, between ticks: it must change no result and no state.
TEST(Session, ThreadedLoopWithTheWarmUpEqualsSessionStepBitForBit) { expect_loop_equals_session(400); }

// The held warm-up at the spin's deadline keeps its replica for the tick,
// which reads it instead of taking the current one: with every step made
// before it (as here), the same bits again.
TEST(Session, ThreadedLoopWithTheHeldWarmUpEqualsSessionStepBitForBit) { expect_loop_equals_session(400, true); }

// A warm-up that would start when the tick is (nearly) due is not run: it
// would only make that tick later. Here the clock jumps a whole period at
// a time, so the haptic thread always wakes at its tick's time.
TEST(Session, NoWarmUpStartsWhenTheTickIsDue) {
  auto mesh = plane();
  const auto model = SessionModel::make(mesh, {}, core_config());
  LiveRig rig(model, deform::MaterialArrays::uniform(mesh->vertex_count(), material(kK0)), 1, limits(), 400);
  rig.loop->start();
  rig.loop->enable(0);
  ASSERT_TRUE(test::run_ticks(*rig.loop, rig.clock, 20));
  EXPECT_EQ(rig.loop->warm_ups(), 0u);
}

// After restore() the core's last tick belongs to another state (the probe
// positions it read are not in the snapshot), so no warm-up runs before the
// first tick from the restored state; after that one precedes every tick.
TEST(Session, NoWarmUpAfterARestoreUntilATickHasRun) {
  auto mesh = plane();
  const auto model = SessionModel::make(mesh, {}, core_config());
  constexpr double kSpinUs = 400;
  LiveRig rig(model, deform::MaterialArrays::uniform(mesh->vertex_count(), material(kK0)), 1, limits(), kSpinUs);
  HapticLoop& loop = *rig.loop;
  rig.place(0, 0);
  loop.start();
  loop.enable(0);
  for (int k = 0; k < 5; ++k) ASSERT_NO_FATAL_FAILURE(tick_through_spin(loop, rig.clock, kSpinUs, k > 0));
  loop.stop();
  const SessionState snap = loop.snapshot();
  loop.restore(snap);
  rig.clock.reset();
  const std::uint64_t before = loop.warm_ups();
  loop.start();
  for (int k = 0; k < 5; ++k) ASSERT_NO_FATAL_FAILURE(tick_through_spin(loop, rig.clock, kSpinUs, k > 0));
  EXPECT_EQ(loop.warm_ups() - before, 4u);
}

// ---- edits on the running loop --------------------------------------------------

Index vertex_under(const mesh::SurfaceMesh& m, double x, double y) {
  const collision::VertexTree tree(std::span<const Vec3>(m.positions));
  return tree.nearest(Vec3(x, y, 0)).vertex;
}

TEST(Session, LiveEditsKeepTheDentAndTheOtherProbes) {
  // Two probes pressing still on a flat plane (|F| = k d exactly: no
  // velocity, no friction): A at (-15, 0) mm, 2 mm deep, B at (15, 0) mm,
  // 1 mm deep; later C at (0, 15) mm, 1.5 mm deep.
  auto mesh = plane();
  CoreConfig cc = core_config();
  cc.deform_rate_hz = 250;  // a step every 4 ticks: at the ticks t with t % 4 == 3
  const auto model = SessionModel::make(mesh, {}, cc);
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), material(kK0));
  SafetyLimits fast;  // no ramp, no rate limit worth the name: the force follows the model at once
  fast.ramp_time = 0;
  fast.max_force_rate = 1e6;
  LiveRig rig(model, materials, 2, fast);
  const double dA = 0.002, dB = 0.001, dC = 0.0015;
  auto still = [&](std::size_t i, double x, double y, double d) {
    rig.st[i].x = x;
    rig.st[i].y = y;
    rig.st[i].z = -d;
  };
  still(0, -0.015, 0, dA);
  still(1, 0.015, 0, dB);
  still(2, 0, 0.015, dC);
  HapticLoop& loop = *rig.loop;
  loop.start();
  loop.enable(0);
  loop.enable(1);
  ASSERT_TRUE(test::run_ticks(loop, rig.clock, 400));
  const Index vA = vertex_under(*mesh, -0.015, 0), vB = vertex_under(*mesh, 0.015, 0);
  auto h = [&](Index i) { return loop.surface().state().vertices[i].h; };
  LoopView v = loop.view();
  ASSERT_NEAR(force_norm(v.probes[0]), kK0 * dA, 1e-12);
  ASSERT_NEAR(force_norm(v.probes[1]), kK0 * dB, 1e-12);
  const double hA = h(vA), hB = h(vB);
  ASSERT_NEAR(hA, -dA, 1e-5);  // the dents settled under the probes
  ASSERT_NEAR(hB, -dB, 1e-5);

  // set_material before tick T: applied at the start of T, it does not wait
  // for the next scheduled step (the first due tick D >= T) but goes to the
  // surface at once as an edits-only generation: tick T feels k0, ticks
  // from T + 1 on k1.
  std::uint64_t T = loop.ticks();
  if (T % 4 == 3) {  // keep T off a step tick so that "before" has a tick
    ASSERT_TRUE(test::run_ticks(loop, rig.clock, 1));
    ++T;
  }
  const std::uint64_t D = T + (3 - T % 4);
  const std::uint64_t generation = loop.view().model_generation;
  const CommandTicket material_ticket = loop.set_material(material(kK1));
  for (std::uint64_t tick = T; tick <= D + 2; ++tick) {
    ASSERT_TRUE(test::run_ticks(loop, rig.clock, 1));
    v = loop.view();
    ASSERT_EQ(v.tick, tick);
    const double k = tick <= T ? kK0 : kK1;
    EXPECT_NEAR(force_norm(v.probes[0]), k * dA, 1e-12) << "tick " << tick << ", edit at " << T;
    EXPECT_NEAR(force_norm(v.probes[1]), k * dB, 1e-12) << "tick " << tick;
    EXPECT_FALSE(v.probes[0].flags & (kSafetyRamping | kSafetyDisabled));
    EXPECT_FALSE(v.probes[1].flags & (kSafetyRamping | kSafetyDisabled));
  }
  EXPECT_TRUE(loop.applied(material_ticket));
  // Steps are made at the ticks t with t % 4 == 3, plus the edit's own
  // generation at T; a tick uses those of the ticks before it.
  EXPECT_EQ(generation, (T - 1) / 4);
  EXPECT_EQ(loop.view().model_generation, (D + 2) / 4 + 1);
  // The dents stayed (a rebuilt or reset surface would start again from 0).
  EXPECT_NEAR(h(vA), hA, 1e-6);
  EXPECT_NEAR(h(vB), hB, 1e-6);
  EXPECT_EQ(loop.surface().material(vA), material(kK1));

  // set_shape: the dent under A keeps its depth; a vertex between the new
  // and the old support radius comes back to rest; B is unaffected.
  const Index ring = vertex_under(*mesh, -0.015 + 0.0065, 0);  // 6.5 mm from A: inside 8 mm, outside 5 mm
  ASSERT_LT(h(ring), -1e-6);
  loop.set_shape(small_shape());
  ASSERT_TRUE(test::run_ticks(loop, rig.clock, 200));
  EXPECT_EQ(h(ring), 0.0);
  EXPECT_NEAR(h(vA), -dA, 1e-5);
  EXPECT_NEAR(h(vB), -dB, 1e-5);
  v = loop.view();
  EXPECT_NEAR(force_norm(v.probes[0]), kK1 * dA, 1e-12);
  EXPECT_NEAR(force_norm(v.probes[1]), kK1 * dB, 1e-12);

  // add_probe: C joins in the free slot 2 and pushes k1 d; A and B go on.
  std::size_t slot = 99;
  const CommandTicket add_ticket = loop.add_probe(rig.binding(2), slot);
  ASSERT_EQ(slot, 2u);
  ASSERT_TRUE(test::run_ticks(loop, rig.clock, 1));
  EXPECT_TRUE(loop.applied(add_ticket));
  EXPECT_EQ(loop.view().probe_count, 3u);
  EXPECT_FALSE(loop.view().probes[2].enabled);  // output disabled until enable
  EXPECT_EQ(force_norm(loop.view().probes[2]), 0.0);
  loop.enable(2);
  ASSERT_TRUE(test::run_ticks(loop, rig.clock, 100));
  v = loop.view();
  const Index vC = vertex_under(*mesh, 0, 0.015);
  EXPECT_NEAR(force_norm(v.probes[2]), kK1 * dC, 1e-12);
  EXPECT_NEAR(h(vC), -dC, 1e-5);
  EXPECT_NEAR(force_norm(v.probes[0]), kK1 * dA, 1e-12);
  EXPECT_NEAR(h(vA), -dA, 1e-5);

  // remove_probe: its ticket is applied at the next tick, its device gets
  // zero and is not read again; its dent relaxes, A and C stay.
  const std::uint64_t reads_before = rig.st[1].reads.load();
  const CommandTicket remove_ticket = loop.remove_probe(1);
  EXPECT_FALSE(loop.applied(remove_ticket));
  ASSERT_TRUE(test::run_ticks(loop, rig.clock, 1));
  EXPECT_TRUE(loop.applied(remove_ticket));
  EXPECT_EQ(rig.st[1].reads.load(), reads_before);
  EXPECT_EQ(rig.st[1].fz.load(), 0.0);
  EXPECT_EQ(rig.st[1].fx.load(), 0.0);
  v = loop.view();
  EXPECT_FALSE(v.probes[1].in_contact);
  EXPECT_EQ(force_norm(v.probes[1]), 0.0);
  ASSERT_TRUE(test::run_ticks(loop, rig.clock, 300));
  EXPECT_EQ(rig.st[1].reads.load(), reads_before);
  EXPECT_EQ(h(vB), 0.0);
  EXPECT_NEAR(h(vA), -dA, 1e-5);
  EXPECT_NEAR(h(vC), -dC, 1e-5);
  v = loop.view();
  EXPECT_NEAR(force_norm(v.probes[0]), kK1 * dA, 1e-12);
  EXPECT_NEAR(force_norm(v.probes[2]), kK1 * dC, 1e-12);
  EXPECT_NEAR(rig.st[0].fz.load(), kK1 * dA, 1e-6);
  loop.stop();
}

TEST(Session, EditsWhileStoppedReplayExactly) {
  // A material edit and a reset made while the loop is stopped are
  // recorded; the replay of the session gives the live forces and surface.
  auto mesh = plane();
  CoreConfig cc = core_config();
  cc.deform_rate_hz = 250;
  const auto model = SessionModel::make(mesh, {}, cc);
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), material(kK0));
  test::ManualClock clock;
  test::FakeDeviceState st;
  st.clock = [&clock] { return clock.now_s(); };
  st.x = 0.001;
  st.z = -0.002;
  auto dev = test::make_fake_device(st);
  LoopConfig c;
  c.clock = &clock;
  c.record_capacity = 1 << 14;
  ProbeBinding b;
  b.device = &dev;
  b.safety = limits();
  HapticLoop loop(model, materials, c, {b});
  LoopRecording rec;
  loop.start();
  loop.enable(0);
  ASSERT_TRUE(test::run_ticks(loop, clock, 101));
  loop.stop();
  loop.set_material(material(kK1));  // stopped: applied at once
  clock.reset();
  loop.start();
  ASSERT_TRUE(test::run_ticks(loop, clock, 100));
  loop.stop();
  loop.reset_surface();
  clock.reset();
  loop.start();
  ASSERT_TRUE(test::run_ticks(loop, clock, 100));
  loop.stop();
  rec.drain(loop);
  ASSERT_EQ(rec.ticks.size(), 301u);
  // Live: the new material is felt from the first tick after the restart.
  EXPECT_NEAR(std::abs(rec.ticks[150].force_device[0][2]), kK1 * 0.002, 1e-3);

  LoopReplay replay(mesh, materials, {}, loop.config().core, loop.setups());
  std::size_t differ = 0;
  std::uint64_t first = 0;
  replay.run(rec, [&](const TickRecord& tr, std::span<const ProbeTickResult> r) {
    const bool d = !test::same_bits(tr.force_device[0], r[0].force_device) || tr.flags[0] != r[0].flags;
    if (d && differ++ == 0) first = tr.tick;
  });
  EXPECT_EQ(differ, 0u) << "first at tick " << first;
  EXPECT_EQ(test::vertex_differences(loop.surface().state().vertices, replay.surface().state().vertices), 0u);
}

// ---- bounded surface publishing ------------------------------------------------

// Resident set size of this process, bytes (/proc/self/statm, second field).
std::size_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  std::size_t pages = 0, resident = 0;
  f >> pages >> resident;
  return resident * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

void no_consumer_for_a_minute(int side) {
  // A plane of side x side vertices 1 mm apart; a probe pressing 2 mm deep
  // slides along a Lissajous path over most of it for 60000 ticks (60 s at
  // 1 kHz); nobody reads the surface changes.
  auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(side, side, 1e-3));
  const double half = 0.5e-3 * (side - 1) - 0.01;
  CoreConfig cc = core_config();
  cc.deform_rate_hz = 500;
  const auto model = SessionModel::make(mesh, {}, cc);
  LiveRig rig(model, deform::MaterialArrays::uniform(mesh->vertex_count(), material(kK0)), 1);
  HapticLoop& loop = *rig.loop;
  auto slide = [&](std::uint64_t tick) {
    const double t = static_cast<double>(tick) * 1e-3;
    rig.st[0].x = half * std::sin(0.37 * t);
    rig.st[0].y = half * std::sin(0.23 * t + 0.5);
    rig.st[0].z = -0.002;
  };
  slide(0);
  const std::size_t mailbox_bytes = loop.surface_changes().bytes();
  loop.start();
  loop.enable(0);
  ASSERT_TRUE(test::run_ticks(loop, rig.clock, 1000, slide));
  const std::size_t after_1s = resident_bytes();
  ASSERT_TRUE(test::run_ticks(loop, rig.clock, 59000, slide));
  const std::size_t after_60s = resident_bytes();
  const LoopView v = loop.view();
  const LoopStatistics stats = loop.statistics();
  loop.stop();
  const double growth_mb = (static_cast<double>(after_60s) - static_cast<double>(after_1s)) / (1 << 20);
  std::printf("[ resident ] %d vertices, no consumer: %.2f MB after 1 s, %.2f MB after 60 s (%+.3f MB)\n",
              side * side, static_cast<double>(after_1s) / (1 << 20), static_cast<double>(after_60s) / (1 << 20),
              growth_mb);
  ::testing::Test::RecordProperty("resident_after_1s", std::to_string(after_1s));
  ::testing::Test::RecordProperty("resident_after_60s", std::to_string(after_60s));
  EXPECT_EQ(v.tick, 59999u);
  EXPECT_EQ(stats.deform_steps, 30000u);  // every step made: the publishing never held the model up
  EXPECT_TRUE(v.probes[0].in_contact);
  EXPECT_LT(std::abs(growth_mb), 1.0);
  EXPECT_EQ(loop.surface_changes().bytes(), mailbox_bytes);
  // A reader coming now gets exactly the model's stream.
  std::vector<float> stream;
  loop.take_surface_changes(stream);
  const auto model_stream = loop.surface().stream();
  ASSERT_EQ(stream.size(), model_stream.size());
  EXPECT_TRUE(std::equal(stream.begin(), stream.end(), model_stream.begin()));
}

TEST(Session, NoSurfaceConsumerKeepsMemoryFlat) { no_consumer_for_a_minute(101); }
TEST(Session, NoSurfaceConsumerKeepsMemoryFlatAt200kVertices) { no_consumer_for_a_minute(448); }

TEST(SurfaceMailbox, ReadsExactlyTheBlocksWritten) {
  constexpr std::size_t n = 1000;  // 15 full blocks and a partial one
  constexpr Index B = core::SurfaceMailbox::kBlock;
  core::SurfaceMailbox box(n);
  const std::size_t bytes = box.bytes();
  std::vector<float> stream(4 * n, 0.0f);
  // The first read delivers everything (zeros).
  auto r = box.begin_read();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].begin, 0u);
  EXPECT_EQ(r[0].end, n);
  box.end_read();
  EXPECT_TRUE(box.begin_read().empty());
  box.end_read();

  std::mt19937 rng(7);
  for (int round = 0; round < 200; ++round) {
    std::vector<IndexRange> ranges;
    std::vector<bool> want(n / B + 1, false);
    const int count = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < count; ++k) {
      const Index a = rng() % n, len = 1 + rng() % 150;
      const Index b = std::min<Index>(n, a + len);
      ranges.push_back({a, b});
      for (Index i = a; i < b; ++i) {
        for (int c = 0; c < 4; ++c) stream[4 * i + c] = static_cast<float>(round * 10000 + i * 4 + c);
        want[i / B] = true;
      }
    }
    box.publish(stream, ranges);
    std::vector<bool> got(n / B + 1, false);
    Index last_end = 0;
    bool first = true;
    for (const auto& g : box.begin_read()) {
      if (!first) {
        EXPECT_GT(g.begin, last_end);  // sorted, disjoint, contiguous ones merged
      }
      first = false;
      EXPECT_EQ(g.begin % B, 0u);
      EXPECT_TRUE(g.end % B == 0 || g.end == n);
      for (Index i = g.begin; i < g.end; ++i) got[i / B] = true;
      last_end = g.end;
    }
    std::vector<float> mirror(stream.size(), -1.0f);
    const IndexRange all{0, static_cast<Index>(n)};
    box.read_into(mirror, std::span<const IndexRange>(&all, 1));
    EXPECT_TRUE(std::equal(stream.begin(), stream.end(), mirror.begin()));
    box.end_read();
    EXPECT_EQ(got, want) << "round " << round;
  }
  EXPECT_EQ(box.bytes(), bytes);
}

TEST(SurfaceMailbox, ReaderEndsWithExactlyTheWritersStream) {
  // Many short sessions: only a block's last write decides the end state,
  // so each session ends with writes racing the reader's reads.
  constexpr std::size_t n = 3000;
  std::size_t failed_trials = 0;
  for (int trial = 0; trial < 150; ++trial) {
    core::SurfaceMailbox box(n);
    std::vector<float> writer(4 * n, 0.0f), reader(4 * n, -1.0f);
    std::atomic<bool> done{false};
    std::thread w([&] {
      std::mt19937 rng(100 + trial);
      std::vector<IndexRange> ranges;
      for (int round = 1; round <= 300; ++round) {
        ranges.clear();
        const int count = 1 + static_cast<int>(rng() % 3);
        for (int k = 0; k < count; ++k) {
          const Index a = rng() % n, b = std::min<Index>(n, a + 1 + rng() % 200);
          for (Index i = a; i < b; ++i)
            for (int c = 0; c < 4; ++c) writer[4 * i + c] = static_cast<float>(round) + 0.25f * c;
          ranges.push_back({a, b});
        }
        box.publish(writer, ranges);
      }
      done.store(true);
    });
    auto read = [&] {
      const auto ranges = box.begin_read();
      box.read_into(reader, ranges);
      box.end_read();
    };
    std::size_t reads = 0;
    while (!done.load()) {
      read();
      ++reads;
    }
    w.join();
    read();  // one more read after the writer stopped
    std::size_t differ = 0;
    for (std::size_t i = 0; i < writer.size(); ++i) differ += writer[i] != reader[i];
    failed_trials += differ != 0;
    if (differ != 0 && failed_trials == 1)
      ADD_FAILURE() << differ << " values differ after trial " << trial << " (" << reads << " reads)";
    // And nothing is left to read.
    EXPECT_TRUE(box.begin_read().empty());
    box.end_read();
  }
  EXPECT_EQ(failed_trials, 0u);
}

}  // namespace
}  // namespace palpa::haptics
