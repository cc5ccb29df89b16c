// A new tissue as a loop command (SetTissue, issue 10: "an edit is a
// recorded command, not a restart"), against closed forms and independent
// paths: a stiff lesion added under a probe held on a linear plane raises
// the normal reaction to k d (1 + (rho - 1) a^2 / (a^2 + R d)) (the lesion
// law of docs/TISSUE.md with the tip inside the lesion), the same bits a
// Session built with that field from the start gives; removing it gives the
// lesion-free session's bits again; a map edit gives k' d; pulse drives
// arrive with the tissue and leave with it; a snapshot taken with an edit
// pending or in force restores exactly into a fresh Session; and the
// threaded HapticLoop on a ManualClock gives a Session's bits with the
// same SetTissue commands.

#include "haptics/loop.h"
#include "haptics/loop_replay.h"
#include "haptics/session.h"
#include "mesh/generate.h"
#include "tissue/field.h"
#include "bits.h"
#include "fake_device.h"
#include "manual_clock.h"

#include <gtest/gtest.h>

#include <cmath>

namespace palpa::haptics {
namespace {

constexpr double kK = 400;         // N/m, the plane's linear material
constexpr double kDepth = 0.002;   // m, the held probe's indentation
constexpr double kTip = 0.008;     // m, tip radius of the fields
constexpr double kLesionR = 0.003; // m, the lesion's radius
constexpr double kRatio = 5;       // the lesion's modulus ratio

double tick_time(std::uint64_t i) {
  return static_cast<double>(std::int64_t{1'000'000'000} + std::int64_t(i + 1) * 1'000'000) * 1e-9;
}

std::shared_ptr<mesh::SurfaceMesh> plane() { return std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(61, 61, 1e-3)); }

deform::Material linear(double k) {
  deform::Material m;
  m.stiffness = k;
  m.damping = 0.8;
  return m;
}

CoreConfig config() {
  CoreConfig c;
  c.rate_hz = 1000;
  c.deform_rate_hz = 300;
  c.shape.radius = 0.008;
  return c;
}

ProbeSetup setup() {
  ProbeSetup s;
  s.name = "fake";
  s.spec.position_dof = 3;
  s.spec.force_dof = 3;
  s.spec.max_force = 5.0;
  s.spec.max_stiffness = 1e5;
  s.spec.nominal_rate = 1000;
  s.safety.ramp_time = 0.05;
  s.safety.max_force_rate = 500;
  return s;
}

// A field on `m` with the given lesions and pulses (no breathing, no dynamic regions).
std::shared_ptr<const tissue::TissueField> field(const mesh::SurfaceMesh& m, std::vector<tissue::Lesion> lesions,
                                                 std::vector<tissue::Pulse> pulses = {}) {
  return std::make_shared<tissue::TissueField>(
      tissue::make_field(m, kTip, lesions, pulses, tissue::Breathing{}, {}, {}));
}

tissue::Lesion stiff_lesion() {
  tissue::Lesion l;
  l.name = "stiff";
  l.centre = Vec3(0, 0, -0.004);  // the tip (2 mm deep) is inside it
  l.semi_axes = Vec3::Constant(kLesionR);
  l.modulus_ratio = kRatio;
  return l;
}

// A vessel along y at x = 20 mm, away from the probe.
tissue::Pulse vessel() {
  tissue::Pulse p;
  p.name = "vessel";
  p.path = {Vec3(0.02, -0.03, 0), Vec3(0.02, 0.03, 0)};
  p.radius = 0.005;
  p.rate_bpm = 60;
  p.amplitude = 0.001;
  return p;
}

std::shared_ptr<const TissueModel> tissue_of(std::shared_ptr<const tissue::TissueField> f,
                                             std::shared_ptr<const deform::MaterialMap> map = nullptr) {
  auto t = std::make_shared<TissueModel>();
  t->field = std::move(f);
  t->map = std::move(map);
  return t;
}

// The probe held still at (0, 0, -kDepth).
ProbeTickInput held(std::uint64_t tick) {
  ProbeTickInput in;
  in.sample = position_sample(Vec3(0, 0, -kDepth), tick + 1, tick_time(tick));
  return in;
}

// Steps `s` to tick `to`; `edits(s, tick)` runs before each tick.
template <class Edits>
void drive(Session& s, std::uint64_t to, std::vector<ProbeTickResult>& out, Edits edits) {
  std::array<ProbeTickResult, 1> r{};
  while (s.tick_count() < to) {
    const std::uint64_t tick = s.tick_count();
    if (tick == 0) s.apply(LoopCommand::of(LoopCommandKind::Enable, 0), tick_time(0));
    edits(s, tick);
    const ProbeTickInput in = held(tick);
    s.step(tick_time(tick), std::span<const ProbeTickInput>(&in, 1), std::span<ProbeTickResult>(r));
    out.push_back(r[0]);
  }
}
void drive(Session& s, std::uint64_t to, std::vector<ProbeTickResult>& out) {
  drive(s, to, out, [](Session&, std::uint64_t) {});
}

// Ticks in [from, to) whose results differ in any bit.
std::size_t differing(const std::vector<ProbeTickResult>& a, const std::vector<ProbeTickResult>& b, std::size_t from,
                      std::size_t to, std::string* first = nullptr) {
  std::size_t n = 0;
  for (std::size_t k = from; k < to; ++k) {
    const std::string d = test::result_difference(a[k], b[k]);
    if (!d.empty() && first && first->empty()) *first = d + " at tick " + std::to_string(k);
    n += !d.empty();
  }
  return n;
}

TEST(TissueEdit, ALesionAddedMidRunIsFeltAsAFreshSessionWithItFeelsItAndRemovingItUndoesIt) {
  const auto mesh = plane();
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), linear(kK));
  const auto lesion = field(*mesh, {stiff_lesion()});
  const auto with = tissue_of(lesion);
  const auto without = tissue_of(nullptr);  // null field: no lesions at all

  // The reference without any field, and one with the lesion from the start.
  Session plain(SessionModel::make(mesh, {}, config()), materials, {setup()});
  Session fresh(SessionModel::make(mesh, {}, config(), lesion), materials, {setup()});
  std::vector<ProbeTickResult> want_plain, want_lesion, got;
  drive(plain, 900, want_plain);
  drive(fresh, 900, want_lesion);

  // The edited session: the lesion arrives at tick 300 and leaves at 600.
  Session edited(SessionModel::make(mesh, {}, config()), materials, {setup()});
  drive(edited, 900, got, [&](Session& s, std::uint64_t tick) {
    if (tick == 300) s.set_tissue(with, tick_time(tick));
    if (tick == 600) s.set_tissue(without, tick_time(tick));
  });

  // Closed forms: k d held still; with the tip inside the lesion the
  // contrast (rho - 1) a^2 / (a^2 + R d) on top.
  const double f0 = kK * kDepth;
  const double a2 = kLesionR * kLesionR;
  const double f1 = f0 * (1 + (kRatio - 1) * a2 / (a2 + kTip * kDepth));
  EXPECT_NEAR(got[299].normal_reaction, f0, 0.01 * f0);
  EXPECT_NEAR(got[599].normal_reaction, f1, 0.01 * f1);
  EXPECT_NEAR(got[899].normal_reaction, f0, 0.01 * f0);
  EXPECT_GT(got[300].normal_reaction, 2 * f0) << "felt at the tick that applied the command";
  EXPECT_NEAR(got[599].force_world[2], f1, 0.01 * f1);

  // Independent paths: before the edit the plain session's bits; from the
  // edit on the normal reaction of the session built with the lesion (the
  // surface does not depend on lesions), and every bit once the safety
  // filter's force rate limit has caught up; after the removal the plain
  // session's bits again.
  std::string first;
  EXPECT_EQ(differing(want_plain, got, 0, 300, &first), 0u) << first;
  for (std::size_t k = 300; k < 600; ++k)
    ASSERT_TRUE(test::same_bits(got[k].normal_reaction, want_lesion[k].normal_reaction)) << "tick " << k;
  first.clear();
  EXPECT_EQ(differing(want_lesion, got, 350, 600, &first), 0u) << first;
  first.clear();
  EXPECT_EQ(differing(want_plain, got, 650, 900, &first), 0u) << first;
  EXPECT_EQ(test::vertex_differences(plain.surface().state().vertices, edited.surface().state().vertices), 0u);
  EXPECT_EQ(edited.field(), nullptr);
}

TEST(TissueEdit, ATissueMapReachesTheSurfaceAtTheNextTickAndAMaterialEditAfterItWins) {
  const auto mesh = plane();
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), linear(kK));
  auto map = std::make_shared<deform::MaterialMap>();
  map->tissues = {linear(2 * kK)};
  map->tissue_of.assign(mesh->vertex_count(), 0);
  Session s(SessionModel::make(mesh, {}, config()), materials, {setup()});
  std::vector<ProbeTickResult> got;
  drive(s, 600, got, [&](Session& session, std::uint64_t tick) {
    if (tick == 200) session.set_tissue(tissue_of(nullptr, map), tick_time(tick));
    if (tick == 400) {
      LoopCommand c = LoopCommand::of(LoopCommandKind::SetMaterial);
      c.material = linear(3 * kK);
      session.apply(c, tick_time(tick));
    }
  });
  EXPECT_NEAR(got[199].normal_reaction, kK * kDepth, 0.01 * kK * kDepth);
  // Edits reach the surface with the edits-only step of the tick that applied them.
  EXPECT_NEAR(got[201].normal_reaction, 2 * kK * kDepth, 0.01 * kK * kDepth);
  EXPECT_NEAR(got[399].normal_reaction, 2 * kK * kDepth, 0.01 * kK * kDepth);
  EXPECT_NEAR(got[599].normal_reaction, 3 * kK * kDepth, 0.01 * kK * kDepth);
  EXPECT_EQ(s.surface().material(0), linear(3 * kK));
  // A bad tissue is refused before anything changes.
  auto short_map = std::make_shared<deform::MaterialMap>(*map);
  short_map->tissue_of.pop_back();
  try {
    s.set_tissue(tissue_of(nullptr, short_map), 0);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "tissue: the map has 3720 tissue indices for 3721 vertices");
  }
  EXPECT_FALSE(s.core().state().pending.any());
  EXPECT_THROW(s.set_tissue(nullptr, 0), std::invalid_argument);
}

TEST(TissueEdit, PulseDrivesArriveWithTheTissueAndLeaveWithIt) {
  const auto mesh = plane();
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), linear(kK));
  const auto pulsing = field(*mesh, {}, {vessel()});
  ASSERT_EQ(pulsing->pulse_count, 1u);
  // The vertex on the vessel at (20 mm, 0): weight 1.
  Index v = 0;
  for (Index i = 0; i < mesh->vertex_count(); ++i)
    if ((mesh->positions[i] - Vec3(0.02, 0, 0)).norm() < 1e-9) v = i;
  ASSERT_EQ(pulsing->pulse_weight[0][v], 1.0f);

  Session fresh(SessionModel::make(mesh, {}, config(), pulsing), materials, {setup()});
  Session edited(SessionModel::make(mesh, {}, config()), materials, {setup()});
  std::vector<ProbeTickResult> a, b;
  drive(fresh, 1500, a);
  drive(edited, 1500, b, [&](Session& s, std::uint64_t tick) {
    if (tick == 200) s.set_tissue(tissue_of(pulsing), tick_time(tick));
  });
  // Before the edit the vessel's vertex rests; 1.3 s after it, it follows
  // the drive as it does in the session that pulsed from the start (the
  // start-up transient decays as exp(-c t / 2m)).
  const double h_fresh = fresh.surface().state().vertices[v].h;
  const double h_edited = edited.surface().state().vertices[v].h;
  EXPECT_GT(std::abs(h_fresh), 1e-5);
  EXPECT_NEAR(h_edited, h_fresh, 1e-12);
  EXPECT_EQ(edited.surface_field(), pulsing.get());

  // Without the pulse the vertex returns exactly to rest.
  std::vector<ProbeTickResult> c;
  drive(edited, 2500, c, [&](Session& s, std::uint64_t tick) {
    if (tick == 1500) s.set_tissue(tissue_of(nullptr), tick_time(tick));
  });
  EXPECT_EQ(edited.surface().state().vertices[v].h, 0.0);
  EXPECT_EQ(edited.surface_field(), nullptr);
}

TEST(TissueEdit, SnapshotsWithATissueEditPendingOrInForceRestoreExactly) {
  const auto mesh = plane();
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), linear(kK));
  auto map = std::make_shared<deform::MaterialMap>();
  map->tissues = {linear(kK), linear(3 * kK)};
  map->tissue_of.assign(mesh->vertex_count(), 0);
  for (Index i = 0; i < mesh->vertex_count(); ++i) map->tissue_of[i] = mesh->positions[i].x() > 0 ? 1 : 0;
  const auto model = SessionModel::make(mesh, {}, config());
  Session s(model, materials, {setup()});
  std::vector<ProbeTickResult> want;
  drive(s, 250, want);
  s.set_tissue(tissue_of(field(*mesh, {stiff_lesion()}, {vessel()}), map), tick_time(250));
  const SessionState pending = s.snapshot();  // the command applied, its step not made
  ASSERT_TRUE(pending.core.pending.any());
  ASSERT_NE(pending.tissue, nullptr);
  ASSERT_NE(pending.pending_tissue_map, nullptr);
  drive(s, 400, want);
  const SessionState in_force = s.snapshot();
  EXPECT_EQ(in_force.surface_tissue, in_force.tissue);
  EXPECT_TRUE(in_force.materials.edited_tissue_map);
  drive(s, 700, want);

  for (const SessionState* snap : {&pending, &in_force}) {
    Session again(model, materials, {setup()});  // built without the tissue
    again.restore(*snap);
    std::vector<ProbeTickResult> got(snap->tick);
    drive(again, 700, got);
    std::string first;
    EXPECT_EQ(differing(want, got, snap->tick, 700, &first), 0u) << first;
    EXPECT_EQ(test::vertex_differences(s.surface().state().vertices, again.surface().state().vertices), 0u);
  }
  // And back into the same session, then a restore of a state from before the edit.
  std::vector<ProbeTickResult> got(250);
  Session again(model, materials, {setup()});
  again.restore(in_force);
  SessionState before;
  {
    Session early(model, materials, {setup()});
    std::vector<ProbeTickResult> unused;
    drive(early, 250, unused);
    before = early.snapshot();
  }
  again.restore(before);
  EXPECT_EQ(again.field(), nullptr);
  EXPECT_EQ(again.surface_field(), nullptr);
  drive(again, 700, got, [&](Session& session, std::uint64_t tick) {
    if (tick == 250) session.set_tissue(tissue_of(field(*mesh, {stiff_lesion()}, {vessel()}), map), tick_time(tick));
  });
  std::string first;
  EXPECT_EQ(differing(want, got, 250, 700, &first), 0u) << first;
}

TEST(TissueEdit, TheThreadedLoopEqualsSessionStepWithSetTissueCommands) {
  const auto mesh = plane();
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), linear(kK));
  const auto model = SessionModel::make(mesh, {}, config(), field(*mesh, {}, {vessel()}));
  auto map = std::make_shared<deform::MaterialMap>();
  map->tissues = {linear(kK), linear(2 * kK)};
  map->tissue_of.assign(mesh->vertex_count(), 0);
  for (Index i = 0; i < mesh->vertex_count(); ++i) map->tissue_of[i] = mesh->positions[i].y() > 0.001 ? 1 : 0;
  const auto first_edit = tissue_of(field(*mesh, {stiff_lesion()}), map);
  tissue::Pulse faster = vessel();  // another beat than the model's vessel: its values must be the new field's
  faster.rate_bpm = 90;
  faster.amplitude = 0.0015;
  const auto second_edit = tissue_of(field(*mesh, {}, {faster}));
  constexpr std::uint64_t kTicks = 900, kFirst = 250, kSecond = 600;
  // The probe slides along y over the lesion and the map's border.
  auto place = [](std::uint64_t tick) {
    return Vec3(0.001, 0.004 * std::sin(static_cast<double>(tick) * 4e-3), -kDepth);
  };

  Session session(model, materials, {setup()});
  std::vector<ProbeTickResult> want;
  {
    std::array<ProbeTickResult, 1> r{};
    for (std::uint64_t tick = 0; tick < kTicks; ++tick) {
      const double t = tick_time(tick);
      if (tick == 0) session.apply(LoopCommand::of(LoopCommandKind::Enable, 0), t);
      if (tick == kFirst) session.set_tissue(first_edit, t);
      if (tick == kSecond) session.set_tissue(second_edit, t);
      ProbeTickInput in;
      in.sample = position_sample(place(tick), tick + 1, t);
      session.step(t, std::span<const ProbeTickInput>(&in, 1), std::span<ProbeTickResult>(r));
      want.push_back(r[0]);
    }
  }

  test::ManualClock clock;
  test::FakeDeviceState st;
  st.clock = [&clock] { return clock.now_s(); };
  auto dev = test::make_fake_device(st);
  LoopConfig c;
  c.clock = &clock;
  ProbeBinding b;
  b.device = &dev;
  b.name = "fake";
  b.safety = setup().safety;
  HapticLoop loop(model, materials, c, {b});
  loop.start();
  std::vector<ProbeTickResult> got;
  for (std::uint64_t tick = 0; tick < kTicks; ++tick) {
    const Vec3 p = place(tick);
    st.x = p.x(), st.y = p.y(), st.z = p.z();
    if (tick == 0) loop.enable(0);
    if (tick == kFirst) loop.set_tissue(first_edit);
    if (tick == kSecond) loop.set_tissue(second_edit);
    ASSERT_TRUE(test::run_ticks(loop, clock, 1));
    const LoopView v = loop.view();
    ASSERT_EQ(v.tick, tick);
    got.push_back(v.probes[0]);
  }
  loop.stop();
  std::string first;
  EXPECT_EQ(differing(want, got, 0, kTicks, &first), 0u) << first;
  EXPECT_GT(want[kFirst + 10].normal_reaction, 1.5 * want[kFirst - 1].normal_reaction) << "the lesion is felt";
  // Both replicas got the same tissue: the surface, its materials and its
  // drives (the vessel's vertices move as in the Session).
  EXPECT_EQ(test::vertex_differences(session.surface().state().vertices, loop.surface().state().vertices), 0u);
  for (Index i = 0; i < mesh->vertex_count(); i += 7)
    ASSERT_EQ(loop.surface().material(i), session.surface().material(i)) << "vertex " << i;
  // The loop's snapshot holds the tissue in force and restores it.
  const SessionState snap = loop.snapshot();
  EXPECT_EQ(snap.tissue, second_edit);
  EXPECT_EQ(snap.surface_tissue, second_edit);
  EXPECT_EQ(snap.materials.tissue_map, map);
  Session restored(model, materials, {setup()});
  restored.restore(snap);
  EXPECT_EQ(restored.field(), second_edit->field.get());
  EXPECT_EQ(test::vertex_differences(restored.surface().state().vertices, loop.surface().state().vertices), 0u);
}

TEST(TissueEdit, ATissueSetWhileTheLoopIsStoppedReachesBothReplicasAndReplaysExactly) {
  const auto mesh = plane();
  const auto materials = deform::MaterialArrays::uniform(mesh->vertex_count(), linear(kK));
  const auto model = SessionModel::make(mesh, {}, config());
  auto map = std::make_shared<deform::MaterialMap>();
  map->tissues = {linear(2 * kK)};
  map->tissue_of.assign(mesh->vertex_count(), 0);
  test::ManualClock clock;
  test::FakeDeviceState st;
  st.clock = [&clock] { return clock.now_s(); };
  st.z = -kDepth;
  auto dev = test::make_fake_device(st);
  LoopConfig c;
  c.clock = &clock;
  c.record_capacity = 1 << 14;
  ProbeBinding b;
  b.device = &dev;
  b.safety = setup().safety;
  HapticLoop loop(model, materials, c, {b});
  LoopRecording rec;
  loop.start();
  loop.enable(0);
  ASSERT_TRUE(test::run_ticks(loop, clock, 150));
  loop.stop();
  loop.set_tissue(tissue_of(field(*mesh, {stiff_lesion()}, {vessel()}), map));  // stopped: applied at once
  EXPECT_EQ(loop.surface().material(0), linear(2 * kK));
  clock.reset();
  loop.start();
  ASSERT_TRUE(test::run_ticks(loop, clock, 300));
  loop.stop();
  rec.drain(loop);
  ASSERT_EQ(rec.ticks.size(), 450u);
  ASSERT_EQ(rec.commands.size(), 2u);
  EXPECT_TRUE(rec.commands[1].immediate);
  // Live: the stiffer map and the lesion from the first tick after the restart.
  const double a2 = kLesionR * kLesionR;
  const double f = 2 * kK * kDepth * (1 + (kRatio - 1) * a2 / (a2 + kTip * kDepth));
  EXPECT_NEAR(rec.ticks[449].force_device[0][2], f, 0.01 * f);

  LoopReplay replay(model, materials, loop.setups());
  std::size_t differ = 0;
  std::uint64_t first = 0;
  replay.run(rec, [&](const TickRecord& tr, std::span<const ProbeTickResult> r) {
    const bool d = !test::same_bits(tr.force_device[0], r[0].force_device) || tr.flags[0] != r[0].flags;
    if (d && differ++ == 0) first = tr.tick;
  });
  EXPECT_EQ(differ, 0u) << "first at tick " << first;
  // The vessel moved the surface alike (its drives reached the replica the
  // haptic thread read first and the other one).
  EXPECT_EQ(test::vertex_differences(loop.surface().state().vertices, replay.surface().state().vertices), 0u);
  EXPECT_GT(test::dented(loop.surface().state().vertices), 0u);
}

}  // namespace
}  // namespace palpa::haptics
