// One tick of the loop against closed forms: a probe pressed into a flat
// linear-spring surface feels k * depth along the normal, through any
// mapping; every watchdog and input check withholds the force.

#include "haptics/loop_core.h"
#include "mesh/generate.h"
#include "bits.h"

#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>
#include <memory>

#if defined(__x86_64__)
#include <xmmintrin.h>
#endif

namespace palpa::haptics {
namespace {

constexpr double kStiffness = 500.0;  // N/m
constexpr double kPeriod = 1e-3;

class LoopCoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    mesh_ = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(41, 41, 1e-3));
    deform::Material m;
    m.stiffness = kStiffness;
    m.damping = 1.0;
    surface_ = std::make_unique<deform::DeformableSurface>(mesh_, deform::MaterialArrays::uniform(mesh_->vertex_count(), m));
    tree_ = std::make_unique<collision::VertexTree>(*mesh_);
    config_.rate_hz = 1000;
    config_.deform_rate_hz = 0;
  }

  ProbeSetup setup(int force_dof = 3) const {
    ProbeSetup s;
    s.name = "test";
    s.spec.position_dof = 3;
    s.spec.force_dof = force_dof;
    s.spec.max_force = 5.0;
    s.safety.max_force_rate = 1e9;
    s.safety.ramp_time = 0;
    return s;
  }

  std::unique_ptr<LoopCore> make(std::vector<ProbeSetup> s, const tissue::TissueField* field = nullptr) {
    auto core = std::make_unique<LoopCore>(*tree_, *mesh_, config_, std::move(s), field);
    for (std::size_t i = 0; i < core->probe_count(); ++i) core->apply(LoopCommand::of(LoopCommandKind::Enable, std::uint32_t(i)), 0);
    return core;
  }

  // One tick with the device at `p`.
  ProbeTickResult tick(LoopCore& core, const Vec3& p, std::uint32_t status = PALPA_STATUS_VALID,
                       std::uint32_t buttons = 0, bool read_ok = true, double model_time = 0) {
    ProbeTickInput in;
    in.sample.orientation[0] = 1;
    for (int k = 0; k < 3; ++k) in.sample.position[k] = p[k];
    in.sample.status = status;
    in.sample.buttons = buttons;
    in.sample.sequence = ++seq_;
    in.sample.time = t_;
    in.read_ok = read_ok;
    ProbeTickResult r;
    core.tick(seq_, t_, *surface_, model_time, std::span<const ProbeTickInput>(&in, 1),
              std::span<ProbeTickResult>(&r, 1), contacts_);
    t_ += kPeriod;
    return r;
  }

  // Probe p's sample at tick i (time t, s): sliding across the plane, 4 mm
  // apart, in and out of contact now and then.
  static ProbeTickInput sliding_input(int p, std::uint64_t i, double t) {
    const double s = static_cast<double>(i) * kPeriod;
    const double x = -0.015 + 0.025 * s + 0.004 * p, y = 0.006 * std::sin(3.0 * s + p);
    const double z = -0.0015 + 0.0025 * std::sin(9.0 * s + 2.0 * p);  // leaves the surface now and then
    ProbeTickInput in;
    in.sample.orientation[0] = 1;
    in.sample.position[0] = x;
    in.sample.position[1] = y;
    in.sample.position[2] = z;
    in.sample.status = PALPA_STATUS_VALID;
    in.sample.sequence = i;
    in.sample.time = t;
    in.read_ok = true;
    return in;
  }

  std::shared_ptr<mesh::SurfaceMesh> mesh_;
  std::unique_ptr<deform::DeformableSurface> surface_;
  std::unique_ptr<collision::VertexTree> tree_;
  CoreConfig config_;
  ContactSet contacts_;
  double t_ = 1.0;
  std::uint64_t seq_ = 0;
};

TEST_F(LoopCoreTest, PressingAtRestGivesStiffnessTimesDepth) {
  auto core = make({setup()});
  tick(*core, Vec3(0.0003, -0.0002, 0.01));  // above: no contact
  ProbeTickResult r;
  for (int i = 0; i < 3; ++i) r = tick(*core, Vec3(0.0003, -0.0002, -0.004));
  EXPECT_TRUE(r.in_contact);
  EXPECT_NEAR(r.depth, 0.004, 1e-12);
  // The probe just arrived, so its velocity estimate is not zero yet: wait.
  for (int i = 0; i < 500; ++i) r = tick(*core, Vec3(0.0003, -0.0002, -0.004));
  EXPECT_NEAR(r.force_device[2], kStiffness * 0.004, 1e-6);
  EXPECT_NEAR(r.force_device[0], 0.0, 1e-6);
  EXPECT_NEAR(r.force_device[1], 0.0, 1e-6);
  ASSERT_EQ(contacts_.count, 1u);
  EXPECT_NEAR(contacts_.contacts[0].depth, 0.004, 1e-12);
  EXPECT_NEAR(contacts_.contacts[0].point[0], 0.0003, 1e-12);
  EXPECT_NEAR(contacts_.contacts[0].point[2], 0.0, 1e-12);
}

TEST_F(LoopCoreTest, MappingTransformsPositionsAndForces) {
  ProbeSetup s = setup();
  s.mapping.scale = 2.0;
  s.mapping.axes = AxisMap::parse("x,-z,y");
  auto core = make({s});
  // World (0.001, 0.002, -0.003) = 2 * (dx, -dz, dy).
  const Vec3 device(0.0005, -0.0015, -0.001);
  ProbeTickResult r;
  for (int i = 0; i < 500; ++i) r = tick(*core, device);
  EXPECT_NEAR(r.world[0], 0.001, 1e-15);
  EXPECT_NEAR(r.world[1], 0.002, 1e-15);
  EXPECT_NEAR(r.world[2], -0.003, 1e-15);
  // World force (0, 0, 1.5) is device force (0, 1.5, 0).
  EXPECT_NEAR(r.force_world[2], 1.5, 1e-6);
  EXPECT_NEAR(r.force_device[1], 1.5, 1e-6);
  EXPECT_NEAR(r.force_device[2], 0.0, 1e-6);
}

TEST_F(LoopCoreTest, FrictionOpposesSlidingWithCoefficientK) {
  auto core = make({setup()});
  // Slide along +x at 0.05 m/s, 4 mm deep: Fn = k d = 2 N (the velocity has no
  // normal part), friction -K Fn along x.
  ProbeTickResult r;
  for (int i = 0; i < 400; ++i) r = tick(*core, Vec3(-0.01 + 0.05 * i * kPeriod, 0, -0.004));
  EXPECT_NEAR(r.velocity[0], 0.05, 1e-6);
  EXPECT_NEAR(r.force_device[2], 2.0, 1e-6);
  EXPECT_NEAR(r.force_device[0], -config_.force.friction * 2.0, 1e-6);
}

// A probe that slides, then is held still (a device whose encoders read the
// same position tick after tick): its filtered velocity decays towards zero
// geometrically. The tick takes subnormal values as zero, so neither the
// velocity nor the force ever holds one (the velocity stops just above the
// range, where a (0 - v) is flushed). Before, it entered the range about
// 2.6 s in and stayed there (a v rounded to zero, so v += a (0 - v)
// stopped changing it), and every later tick took a microcode assist at
// each use and twice as long. The caller's floating-point mode is left as
// it was.
TEST_F(LoopCoreTest, AHeldProbesVelocityNeverTurnsSubnormal) {
  auto core = make({setup()});
  for (int i = 0; i < 200; ++i) tick(*core, Vec3(-0.005 + 5e-5 * i, 0.0, -0.001));  // 5 cm/s, 1 mm deep
  const Vec3 held(0.005, 0.0, -0.001);
#if defined(__x86_64__)
  const unsigned mode = _mm_getcsr();
#endif
  for (int i = 0; i < 4000; ++i) {
    const ProbeTickResult r = tick(*core, held);
#if defined(__x86_64__)
    ASSERT_EQ(_mm_getcsr(), mode) << "tick " << i << " left the caller's floating-point mode changed";
#endif
    for (int k = 0; k < 3; ++k) {
      ASSERT_NE(std::fpclassify(r.velocity[k]), FP_SUBNORMAL) << "velocity " << k << " at tick " << i;
      ASSERT_NE(std::fpclassify(r.force_world[k]), FP_SUBNORMAL) << "force " << k << " at tick " << i;
    }
  }
  const ProbeTickResult r = tick(*core, held);
  EXPECT_LT(std::abs(r.velocity[0]) + std::abs(r.velocity[1]) + std::abs(r.velocity[2]), 1e-300);
  EXPECT_TRUE(r.in_contact) << "the probe should still press the surface";
}

TEST_F(LoopCoreTest, ClutchButtonHoldsTheProbeAndWithholdsForce) {
  ProbeSetup s = setup();
  s.mapping.clutch_button = 1;
  auto core = make({s});
  ProbeTickResult r;
  for (int i = 0; i < 300; ++i) r = tick(*core, Vec3(0, 0, -0.002));
  EXPECT_GT(r.force_device[2], 0.9);
  // Pressed where the probe is, then the device moves away.
  r = tick(*core, Vec3(0, 0, -0.002), PALPA_STATUS_VALID, 0b10);
  EXPECT_TRUE(r.flags & kSafetyClutch);
  r = tick(*core, Vec3(0.01, 0, -0.002), PALPA_STATUS_VALID, 0b10);
  EXPECT_TRUE(r.flags & kSafetyClutch);
  EXPECT_EQ(r.world, (Triple{0, 0, -0.002}));
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
  ASSERT_EQ(contacts_.count, 1u);  // the probe still presses the organ
}

TEST_F(LoopCoreTest, LoopLateWatchdogWithholdsOneTick) {
  auto core = make({setup()});
  ProbeTickResult r;
  for (int i = 0; i < 300; ++i) r = tick(*core, Vec3(0, 0, -0.002));
  ASSERT_GT(r.force_device[2], 0.9);
  t_ += 5 * kPeriod;  // the next tick starts 6 periods after the previous
  r = tick(*core, Vec3(0, 0, -0.002));
  EXPECT_TRUE(r.flags & kSafetyLoopLate);
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
  r = tick(*core, Vec3(0, 0, -0.002));
  EXPECT_FALSE(r.flags & kSafetyLoopLate);
  EXPECT_GT(r.force_device[2], 0.9);
}

TEST_F(LoopCoreTest, ModelLateWatchdog) {
  config_.deform_rate_hz = 500;  // timeout 10 periods = 20 ms
  auto core = make({setup()});
  ProbeTickResult r;
  for (int i = 0; i < 300; ++i) r = tick(*core, Vec3(0, 0, -0.002), PALPA_STATUS_VALID, 0, true, t_ - 0.019);
  EXPECT_FALSE(r.flags & kSafetyModelLate);
  EXPECT_GT(r.force_device[2], 0.9);
  r = tick(*core, Vec3(0, 0, -0.002), PALPA_STATUS_VALID, 0, true, t_ - 0.021);
  EXPECT_TRUE(r.flags & kSafetyModelLate);
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
}

TEST_F(LoopCoreTest, DeviceStatesWithholdForceAndFaultsLatch) {
  auto core = make({setup()});
  ProbeTickResult r;
  for (int i = 0; i < 300; ++i) r = tick(*core, Vec3(0, 0, -0.002));
  ASSERT_GT(r.force_device[2], 0.9);
  r = tick(*core, Vec3(0, 0, -0.002), PALPA_STATUS_VALID | PALPA_STATUS_NOT_READY);
  EXPECT_TRUE(r.flags & kSafetyNotReady);
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
  r = tick(*core, Vec3(0, 0, -0.002), PALPA_STATUS_VALID | PALPA_STATUS_STALE);
  EXPECT_TRUE(r.flags & kSafetyStale);
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
  r = tick(*core, Vec3(0, 0, -0.002));
  EXPECT_GT(r.force_device[2], 0.9);  // not latched

  r = tick(*core, Vec3(0, 0, -0.002), PALPA_STATUS_VALID | PALPA_STATUS_FAULT);
  EXPECT_TRUE(r.flags & kSafetyDeviceFault);
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
  EXPECT_EQ(r.fault, static_cast<std::uint8_t>(SafetyFault::Device));
  for (int i = 0; i < 10; ++i) r = tick(*core, Vec3(0, 0, -0.002));
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));  // latched
  EXPECT_TRUE(r.flags & kSafetyFaultLatched);
  core->apply(LoopCommand::of(LoopCommandKind::Enable, 0), t_);
  r = tick(*core, Vec3(0, 0, -0.002));
  EXPECT_GT(r.force_device[2], 0.9);

  r = tick(*core, Vec3(0, 0, -0.002), PALPA_STATUS_VALID, 0, /*read_ok=*/false);
  EXPECT_EQ(r.fault, static_cast<std::uint8_t>(SafetyFault::Device));
}

TEST_F(LoopCoreTest, InvalidAndAbsurdPositions) {
  auto core = make({setup()});
  ProbeTickResult r;
  for (int i = 0; i < 300; ++i) r = tick(*core, Vec3(0, 0, -0.002));
  r = tick(*core, Vec3(NAN, 0, -0.002));
  EXPECT_TRUE(r.flags & kSafetyBadInput);
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
  EXPECT_EQ(contacts_.count, 0u);
  // A teleport is a jump: zero force for that tick.
  r = tick(*core, Vec3(0.06, 0.0, -0.002));
  EXPECT_TRUE(r.flags & kSafetyJump);
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
  // Finite but absurd: no contact possible, no crash, zero force.
  for (double big : {1e3, 1e30, 1e300, -1e300}) {
    r = tick(*core, Vec3(big, big, big));
    EXPECT_FALSE(r.in_contact);
    EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
    for (double w : r.world) EXPECT_TRUE(std::isfinite(w));
  }
}

TEST_F(LoopCoreTest, DeviceWithoutForceOutputShowsTheModelForce) {
  auto core = make({setup(/*force_dof=*/0)});
  ProbeTickResult r;
  for (int i = 0; i < 300; ++i) r = tick(*core, Vec3(0, 0, -0.002));
  EXPECT_EQ(r.force_device, (Triple{0, 0, 0}));
  EXPECT_NEAR(r.force_world[2], 1.0, 1e-6);
}

TEST_F(LoopCoreTest, ConfigurationErrorsNameTheField) {
  auto message = [&](CoreConfig c) {
    try {
      LoopCore core(*tree_, *mesh_, c, {setup()});
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CoreConfig c = config_;
  c.rate_hz = 50000;
  EXPECT_EQ(message(c), "loop configuration: rate_hz must be in [100, 10000], got 50000");
  c = config_;
  c.force.max_force = NAN;
  EXPECT_EQ(message(c), "loop configuration: force.max_force must be in [1e-06, 10000], got nan");
  c = config_;
  c.deform_rate_hz = -3;
  EXPECT_EQ(message(c), "loop configuration: deform_rate_hz must be in [1, 10000], got -3");
  EXPECT_THROW(LoopCore(*tree_, *mesh_, config_, std::vector<ProbeSetup>(kMaxProbes + 1, setup())),
               std::invalid_argument);
}

// warm_caches (what Session::deform runs after a step) re-reads the last
// tick's data and must change nothing: a core warmed after every
// deformation step gives the same bits as one never warmed, and its probe
// memories are the same before and after each warm. Two probes slide across
// the deforming plane, in and out of contact, across many triangles. Where a
// probe hovered clear of the surface (no search), the warm asks the tree.
// With a free slot between probes, each probe's tick reads and keeps its own
// memory (haptic_tick through the slots, nothing gathered): probes 0 and 2
// of a core whose probe 1 is removed while they are in contact feel, bit for
// bit, what probes 0 and 1 of a core that never had it feel, before and
// after, through contacts, releases and warm-ups.
TEST_F(LoopCoreTest, AProbeBeyondAFreeSlotKeepsItsOwnMemory) {
  auto holed = make({setup(), setup(), setup()});
  auto packed = make({setup(), setup()});
  ContactSet packed_contacts;
  std::size_t in_contact = 0, out_of_contact = 0, removed_in_contact = 0;
  for (std::uint64_t i = 1; i <= 1200; ++i) {
    const double t = 1.0 + static_cast<double>(i) * kPeriod;
    if (i == 400) {
      holed->apply(LoopCommand::of(LoopCommandKind::RemoveProbe, 1), t);
      for (int p : {0, 2}) removed_in_contact += holed->state().memory[p].in_contact;
    }
    std::array<ProbeTickInput, 3> in{};
    for (int p = 0; p < 3; ++p) in[p] = sliding_input(p, i, t);
    const std::array<ProbeTickInput, 2> packed_in{in[0], in[2]};
    std::array<ProbeTickResult, 3> a{};
    std::array<ProbeTickResult, 2> b{};
    holed->tick(i, t, *surface_, 0, in, a, contacts_);
    packed->tick(i, t, *surface_, 0, packed_in, b, packed_contacts);
    for (int k = 0; k < 2; ++k) {
      const ProbeTickResult& h = a[k == 0 ? 0 : 2];
      SCOPED_TRACE("tick " + std::to_string(i) + ", probe " + std::to_string(k == 0 ? 0 : 2));
      EXPECT_EQ(h.force_world, b[k].force_world);
      EXPECT_EQ(h.contact_point, b[k].contact_point);
      EXPECT_EQ(std::bit_cast<std::uint64_t>(h.depth), std::bit_cast<std::uint64_t>(b[k].depth));
      EXPECT_EQ(h.in_contact, b[k].in_contact);
      EXPECT_EQ(h.path, b[k].path);
      (h.in_contact ? in_contact : out_of_contact) += 1;
    }
    if (i % 3 == 0) {
      holed->warm_caches(*surface_);
      packed->warm_caches(*surface_);
    }
  }
  EXPECT_GT(in_contact, 600u);
  EXPECT_GT(out_of_contact, 300u);
  EXPECT_GT(removed_in_contact, 0u) << "no probe was in contact when probe 1 was removed";
}

TEST_F(LoopCoreTest, WarmingTheCachesChangesNoResultAndNoMemory) {
  auto cold = make({setup(), setup()});
  auto warm = make({setup(), setup()});
  std::vector<deform::Contact> contacts;
  ContactSet warm_contacts;
  std::size_t in_contact = 0, out_of_contact = 0, warmed = 0, clear = 0, clear_warmed = 0;
  std::array<std::uint8_t, 2> last_path{};
  for (std::uint64_t i = 1; i <= 1200; ++i) {
    const double t = 1.0 + static_cast<double>(i) * kPeriod;
    std::array<ProbeTickInput, 2> in{};
    for (int p = 0; p < 2; ++p) in[p] = sliding_input(p, i, t);
    std::array<ProbeTickResult, 2> a{}, b{};
    cold->tick(i, t, *surface_, 0, in, a, contacts_);
    warm->tick(i, t, *surface_, 0, in, b, warm_contacts);
    for (int p = 0; p < 2; ++p) {
      SCOPED_TRACE("tick " + std::to_string(i) + ", probe " + std::to_string(p));
      EXPECT_EQ(a[p].force_device, b[p].force_device);
      EXPECT_EQ(a[p].force_world, b[p].force_world);
      EXPECT_EQ(a[p].contact_point, b[p].contact_point);
      EXPECT_EQ(a[p].contact_normal, b[p].contact_normal);
      EXPECT_EQ(a[p].velocity, b[p].velocity);
      EXPECT_EQ(std::bit_cast<std::uint64_t>(a[p].depth), std::bit_cast<std::uint64_t>(b[p].depth));
      EXPECT_EQ(std::bit_cast<std::uint64_t>(a[p].normal_reaction), std::bit_cast<std::uint64_t>(b[p].normal_reaction));
      EXPECT_EQ(a[p].in_contact, b[p].in_contact);
      EXPECT_EQ(a[p].path, b[p].path);
      EXPECT_EQ(a[p].flags, b[p].flags);
      (a[p].in_contact ? in_contact : out_of_contact) += 1;
      clear += b[p].path == static_cast<std::uint8_t>(collision::ContactPath::Clear);
      last_path[p] = b[p].path;
    }
    if (i % 2 != 0) continue;
    // A deformation step from the cold core's contacts, then the warm.
    to_contacts(contacts_, contacts);
    surface_->set_contacts(contacts);
    surface_->step(2 * kPeriod);
    const auto before = warm->state().memory;
    warm->warm_caches(*surface_, i % 4 == 0);  // with a rehearsal past the corners every other time
    ++warmed;
    const auto& after = warm->state().memory;
    for (int p = 0; p < 2; ++p) {
      if (last_path[p] == static_cast<std::uint8_t>(collision::ContactPath::Clear)) {
        ++clear_warmed;
        EXPECT_EQ(warm->last_warm()[p].path, collision::ContactPath::Tree);
      }
      EXPECT_EQ(before[p].cursor.clear_from, after[p].cursor.clear_from);
      EXPECT_EQ(before[p].cursor.clearance, after[p].cursor.clearance);
      EXPECT_EQ(before[p].in_contact, after[p].in_contact);
      EXPECT_EQ(before[p].corners, after[p].corners);
      EXPECT_EQ(before[p].cursor.triangle, after[p].cursor.triangle);
      EXPECT_EQ(before[p].cursor.ahead, after[p].cursor.ahead);
      EXPECT_EQ(before[p].cursor.tree.leaf, after[p].cursor.tree.leaf);
      EXPECT_EQ(before[p].cursor.probe, after[p].cursor.probe);
      EXPECT_EQ(before[p].cursor.barycentric, after[p].cursor.barycentric);
    }
  }
  // The path did what it is for: long runs in contact and out of it.
  EXPECT_GT(in_contact, 600u);
  EXPECT_GT(out_of_contact, 300u);
  EXPECT_EQ(warmed, 600u);
  EXPECT_GT(clear, 50u);
  EXPECT_GT(clear_warmed, 25u);
  std::printf("%zu probe-ticks in contact, %zu out of it, %zu of those clear; %zu warms after a clear tick\n",
              in_contact, out_of_contact, clear, clear_warmed);
}

// rehearse_tick (what Session::deform runs after warm_caches) runs tick()'s
// code once more and puts back everything it writes: a core that rehearses
// after every deformation step gives, bit for bit, the results, requests and
// state of one that never does. The rehearsal must show in nothing but its
// own scratch results, which repeat the last tick (the same sample: the same
// position and velocity). What a forgotten restore would change: the safety
// filters' ramp and force-rate limit (probe 0 ramps in and is rate limited),
// the clutch's offset (probe 2 clutches and lets go), the ramp after probe
// 0 is enabled again at tick 710, the deformation
// schedule (generations, the phase, the request), the probes' memories, the free slot
// (probe 1 leaves at tick 400).
// With a tissue field (a pulse under the path and a guarding region over
// the whole plane), the guarding's triggers are compared too.
class RehearsalTest : public LoopCoreTest, public ::testing::WithParamInterface<bool> {};

TEST_P(RehearsalTest, RehearsingATickChangesNoResultNoRequestAndNoState) {
  config_.deform_rate_hz = 700;  // 0.7 of a step a tick: a rehearsal after a step is often due a step itself
  std::vector<ProbeSetup> probes{setup(), setup(), setup()};
  probes[0].safety.ramp_time = 0.05;
  probes[0].safety.max_force_rate = 40.0;
  probes[2].mapping.clutch_button = 0;
  tissue::TissueField field;
  if (GetParam()) {
    tissue::Pulse pulse;
    pulse.name = "artery";
    pulse.path = {Vec3(-0.02, 0.0, -0.003), Vec3(0.02, 0.0, -0.003)};
    pulse.radius = 0.006;
    pulse.amplitude = 0.0005;
    pulse.rate_bpm = 90;
    tissue::DynamicRegion guard;
    guard.region = "all";
    guard.guarding.enabled = true;
    guard.guarding.threshold = 0.3;  // N
    guard.guarding.factor = 1.5;
    guard.guarding.duration = 0.15;
    guard.guarding.release = 0.05;
    field = tissue::make_field(*mesh_, 0.008, {}, {pulse}, {}, {guard},
                               {std::vector<float>(mesh_->vertex_count(), 1.0f)});
  }
  auto plain = make(probes, GetParam() ? &field : nullptr);
  auto rehearsed = make(probes, GetParam() ? &field : nullptr);
  ContactSet rehearsed_contacts;
  std::vector<deform::Contact> contacts;
  std::size_t rehearsals = 0, in_contact = 0, clutched = 0, ramped = 0, limited = 0, guarded = 0;
  for (std::uint64_t i = 1; i <= 1500; ++i) {
    const double t = 1.0 + static_cast<double>(i) * kPeriod;
    for (auto* c : {plain.get(), rehearsed.get()}) {
      if (i == 400) c->apply(LoopCommand::of(LoopCommandKind::RemoveProbe, 1), t);
      if (i == 700) c->apply(LoopCommand::of(LoopCommandKind::Disable, 0), t);
      if (i == 710) c->apply(LoopCommand::of(LoopCommandKind::Enable, 0), t);  // ramps in again over 50 ms
    }
    std::array<ProbeTickInput, 3> in{};
    for (int p = 0; p < 3; ++p) in[p] = sliding_input(p, i, t);
    if (i % 300 > 200) in[2].sample.buttons = 1;  // probe 2's clutch held for 99 ticks in 300
    std::array<ProbeTickResult, 3> a{}, b{};
    const bool due_a = plain->tick(i, t, *surface_, t, in, a, contacts_);
    const bool due_b = rehearsed->tick(i, t, *surface_, t, in, b, rehearsed_contacts);
    ASSERT_EQ(due_a, due_b) << "tick " << i;
    for (int p = 0; p < 3; ++p) {
      SCOPED_TRACE("tick " + std::to_string(i) + ", probe " + std::to_string(p));
      EXPECT_EQ(test::result_difference(a[p], b[p]), "");
      EXPECT_EQ(a[p].path, b[p].path);
      in_contact += a[p].in_contact;
      clutched += a[p].clutched;
      if (p == 0) {
        ramped += (a[p].flags & kSafetyRamping) != 0;
        limited += (a[p].flags & kSafetyRateLimited) != 0;
      }
    }
    const CoreState& sa = plain->state();
    const CoreState& sb = rehearsed->state();
    ASSERT_TRUE(test::same_bits(sa.deform_phase, sb.deform_phase)) << "tick " << i;
    ASSERT_EQ(sa.generations, sb.generations) << "tick " << i;
    for (std::size_t g = 0; g < tissue::kMaxDynamicRegions; ++g)
      ASSERT_TRUE(test::same_bits(sa.reactions.triggered_at[g], sb.reactions.triggered_at[g])) << "tick " << i;
    guarded += sa.reactions.triggered_at[0] == t;
    for (int p = 0; p < 3; ++p) {
      ASSERT_EQ(sa.probes[p].active, sb.probes[p].active);
      ASSERT_EQ(sa.memory[p].in_contact, sb.memory[p].in_contact);
      ASSERT_EQ(sa.memory[p].cursor.triangle, sb.memory[p].cursor.triangle);
      ASSERT_EQ(sa.memory[p].cursor.barycentric, sb.memory[p].cursor.barycentric);
    }
    if (!due_a) continue;
    ASSERT_EQ(plain->request().generation, rehearsed->request().generation);
    ASSERT_EQ(plain->request().contacts.count, rehearsed->request().contacts.count);
    // The step from the plain core's contacts, then the warm-up and the
    // rehearsal of the last tick, as Session::deform.
    to_contacts(contacts_, contacts);
    surface_->set_contacts(contacts);
    surface_->step(plain->request().dt);
    rehearsed->warm_caches(*surface_, true);
    std::array<ProbeTickResult, 3> scratch{};
    rehearsed->rehearse_tick(*surface_, in, scratch);
    ++rehearsals;
    EXPECT_EQ(rehearsed->request().generation, plain->request().generation);
    EXPECT_EQ(rehearsed->request().tick, plain->request().tick);
    EXPECT_EQ(rehearsed->state().pending.any(), plain->state().pending.any());
    for (int p = 0; p < 3; ++p) {
      SCOPED_TRACE("rehearsal after tick " + std::to_string(i) + ", probe " + std::to_string(p));
      if (!rehearsed->active(p)) {
        EXPECT_EQ(scratch[p].world, (Triple{0, 0, 0}));  // a free slot's result, cleared
        continue;
      }
      EXPECT_EQ(scratch[p].world, b[p].world);
      EXPECT_EQ(scratch[p].velocity, b[p].velocity);
    }
  }
  EXPECT_GT(rehearsals, 1000u);
  EXPECT_GT(in_contact, 1000u);
  EXPECT_GT(clutched, 300u);
  EXPECT_GT(ramped, 30u);
  EXPECT_GT(limited, 30u);
  if (GetParam()) {
    EXPECT_GT(guarded, 2u) << "the guarding never set off";
  }
  std::printf("%zu rehearsals; %zu probe-ticks in contact, %zu clutched; probe 0 ramping on %zu ticks, rate limited on "
              "%zu; the guarding set off %zu times\n",
              rehearsals, in_contact, clutched, ramped, limited, guarded);
}

INSTANTIATE_TEST_SUITE_P(LoopCore, RehearsalTest, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& i) {
                           return std::string(i.param ? "WithATissueField" : "WithoutATissueField");
                         });

}  // namespace
}  // namespace palpa::haptics
