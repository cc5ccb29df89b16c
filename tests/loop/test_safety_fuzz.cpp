// Safety under fuzzing: millions of ticks of the loop's tick code with
// teleporting probes, NaN / infinite / absurd positions, random device
// states, random commands and mappings, late ticks and a late model, on a
// deforming sphere. No non-finite or over-limit force ever leaves, and the
// force never changes by more than the per-tick limit except when it drops
// to zero. Absurd configurations are either refused with a message or obey
// the same rules.

#include "haptics/loop_core.h"
#include "mesh/generate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace palpa::haptics {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

struct Fuzzer {
  std::mt19937_64 rng;
  explicit Fuzzer(std::uint64_t seed) : rng(seed) {}
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
  bool chance(double p) { return uniform(0, 1) < p; }
  int pick(int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); }

  // An absurd double: NaN, +-inf, huge, tiny, denormal, negative zero.
  double absurd() {
    const double values[] = {kNan, kInf, -kInf, 1e300, -1e300, 1e-300, -4.9e-324, -0.0, 1e18, -7e9};
    return values[pick(10)];
  }

  DeviceMapping mapping() {
    DeviceMapping m;
    const double scales[] = {1e-9, 1e-3, 0.5, 1, 3, 1e3, 1e9};
    m.scale = scales[pick(7)];
    for (auto& o : m.offset) o = chance(0.8) ? uniform(-0.1, 0.1) : uniform(-1e6, 1e6);
    const char* axes[] = {"x,y,z", "-x,z,y", "y,-z,x", "z,x,-y", "-z,-y,-x"};
    m.axes = AxisMap::parse(axes[pick(5)]);
    const double fs[] = {0, 1e-6, 0.3, 1, 10, 1e6};
    m.force_scale = fs[pick(6)];
    m.clutch_button = pick(3) - 1;
    return m;
  }
};

struct ProbeCheck {
  Triple previous{};
  std::uint64_t violations_finite = 0, violations_limit = 0, violations_rate = 0, violations_fault = 0;
  std::uint64_t nonzero = 0, clamped = 0, rate_limited = 0, held = 0;
};

// Runs `ticks` fuzzed ticks; returns per-probe checks.
std::vector<ProbeCheck> run(LoopCore& core, deform::DeformableSurface& surface, Fuzzer& fz, std::uint64_t ticks,
                            double period) {
  const std::size_t n = core.probe_count();
  std::vector<ProbeCheck> checks(n);
  std::vector<ProbeTickInput> inputs(n);
  std::vector<ProbeTickResult> results(n);
  std::vector<Vec3> walk(n, Vec3(0, 0, 0.05));
  std::vector<deform::Contact> scratch;
  ContactSet contacts;
  double t = 100.0, model_time = t;
  std::uint64_t seq = 0;

  double storm = 0;  // probability scale of glitches, changed every 2000 ticks
  for (std::uint64_t k = 0; k < ticks; ++k) {
    if (k % 2000 == 0) {
      const double levels[] = {0.0, 0.0, 0.02, 0.2, 1.0};
      storm = levels[fz.pick(5)];
    }
    // Time: mostly regular, sometimes late, rarely absurd.
    t += period;
    if (fz.chance(0.005 * storm)) t += period * fz.uniform(2, 50);
    if (fz.chance(0.001 * storm)) t -= period * 3;  // backwards
    if (fz.chance(0.001 * storm)) t = fz.absurd();
    if (!std::isfinite(t) && fz.chance(0.5)) t = 100.0 + k * period;  // come back to a sane clock
    // Model: mostly fresh, sometimes late.
    model_time = fz.chance(0.02 * storm) ? t - fz.uniform(0, 1) : t - period;

    // Commands: enable often enough to see forces; sometimes anything else.
    if (fz.chance(0.002)) {
      LoopCommand c;
      c.probe = static_cast<std::uint32_t>(fz.pick(static_cast<int>(n) + 1));  // sometimes out of range
      c.kind = static_cast<LoopCommandKind>(fz.pick(5));
      c.mapping = fz.chance(0.7) ? DeviceMapping{} : fz.mapping();
      core.apply(c, t);
    }
    if (fz.chance(0.002))
      core.apply(LoopCommand::of(LoopCommandKind::Enable, static_cast<std::uint32_t>(fz.pick(static_cast<int>(n)))), t);

    // Inputs: a random walk in a shell around the sphere with every kind of glitch.
    for (std::size_t i = 0; i < n; ++i) {
      PalpaDeviceSample& s = inputs[i].sample;
      s = PalpaDeviceSample{};
      s.orientation[0] = 1;
      walk[i] += Vec3(fz.uniform(-1, 1), fz.uniform(-1, 1), fz.uniform(-1, 1)) * 2e-4;
      if (!(walk[i].norm() > 0.044 && walk[i].norm() < 0.052))
        walk[i] = Vec3(fz.uniform(-1, 1), fz.uniform(-1, 1), fz.uniform(-1, 1)).normalized() * 0.049;
      if (fz.chance(0.01 * storm)) walk[i] = Vec3(fz.uniform(-1, 1), fz.uniform(-1, 1), fz.uniform(-1, 1));  // teleport
      for (int a = 0; a < 3; ++a) s.position[a] = walk[i][a];
      if (fz.chance(0.01 * storm))
        for (int a = 0; a < 3; ++a)
          if (fz.chance(0.5)) s.position[a] = fz.absurd();
      s.status = fz.chance(0.03 * storm) ? static_cast<std::uint32_t>(fz.pick(16)) : PALPA_STATUS_VALID;
      s.buttons = fz.chance(0.01 * storm) ? static_cast<std::uint32_t>(fz.rng()) : 0u;
      s.sequence = fz.chance(0.1) ? seq : ++seq;
      s.time = fz.chance(0.005 * storm) ? fz.absurd() : t;
      inputs[i].read_ok = !fz.chance(0.002 * storm);
    }

    core.tick(k, t, surface, model_time, inputs, results, contacts);

    // The checks: finite, within the limit, bounded change unless stopping.
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 f = to_vec(results[i].force_device);
      const Vec3 prev = to_vec(checks[i].previous);
      const SafetyLimits& lim = core.limits(i);
      ProbeCheck& c = checks[i];
      if (!f.allFinite() || !to_vec(results[i].force_world).allFinite()) ++c.violations_finite;
      if (!(f.norm() <= lim.max_force)) ++c.violations_limit;
      if (!f.isZero(0) && !((f - prev).norm() <= lim.max_force_rate * period * (1 + 1e-9))) ++c.violations_rate;
      if (results[i].fault != 0 && !f.isZero(0)) ++c.violations_fault;
      if (!f.isZero(0)) ++c.nonzero;
      if (results[i].flags & kSafetyClamped) ++c.clamped;
      if (results[i].flags & kSafetyRateLimited) ++c.rate_limited;
      if (results[i].flags & kSafetyHoldMask) ++c.held;
      c.previous = results[i].force_device;
    }

    // Deformation every 4 ticks with the tick's contacts.
    if (k % 4 == 3) {
      to_contacts(contacts, scratch);
      surface.set_contacts(scratch);
      surface.step(4 * period);
    }
  }
  return checks;
}

class SafetyFuzz : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    mesh_ = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(3000, 0.05));
    tree_ = std::make_unique<collision::VertexTree>(std::span<const Vec3>(mesh_->positions));
  }
  static void TearDownTestSuite() {
    tree_.reset();
    mesh_.reset();
  }
  static deform::MaterialArrays materials(double k) {
    deform::Material m;
    m.stiffness = k;
    m.damping = 2;
    m.mass = 1e-3;
    return deform::MaterialArrays::uniform(mesh_->vertex_count(), m);
  }
  static ProbeSetup probe(const char* name, double max_force, double rate, double ramp) {
    ProbeSetup s;
    s.name = name;
    s.spec.position_dof = 3;
    s.spec.force_dof = 3;
    s.spec.max_force = max_force;
    s.safety.max_force_rate = rate;
    s.safety.ramp_time = ramp;
    return s;
  }
  static inline std::shared_ptr<mesh::SurfaceMesh> mesh_;
  static inline std::unique_ptr<collision::VertexTree> tree_;
};

TEST_F(SafetyFuzz, MillionsOfTicksNeverLeaveAnUnsafeForce) {
  constexpr std::uint64_t kTicks = 1'500'000;
  std::uint64_t total = 0, nonzero = 0, clamped = 0, rate_limited = 0, held = 0;
  for (std::uint64_t seed : {1u, 2u}) {
    CoreConfig cfg;
    cfg.rate_hz = 1000;
    cfg.deform_rate_hz = 250;
    cfg.force.max_force = 50;  // the model may ask for more than the devices allow
    cfg.shape.radius = 0.01;
    // Stiff material so forces reach the limits.
    deform::DeformableSurface surface(mesh_, materials(3000));
    LoopCore core(*tree_, *mesh_, cfg,
                  {probe("a", 1.0, 300, 0.0), probe("b", 5.0, 2000, 0.2), probe("c", 8.9, 1e5, 0.05)});
    Fuzzer fz(seed);
    const auto checks = run(core, surface, fz, kTicks, cfg.period());
    for (std::size_t i = 0; i < checks.size(); ++i) {
      EXPECT_EQ(checks[i].violations_finite, 0u) << "probe " << i << " seed " << seed;
      EXPECT_EQ(checks[i].violations_limit, 0u) << "probe " << i << " seed " << seed;
      EXPECT_EQ(checks[i].violations_rate, 0u) << "probe " << i << " seed " << seed;
      EXPECT_EQ(checks[i].violations_fault, 0u) << "probe " << i << " seed " << seed;
      nonzero += checks[i].nonzero;
      clamped += checks[i].clamped;
      rate_limited += checks[i].rate_limited;
      held += checks[i].held;
    }
    total += kTicks * checks.size();
  }
  // The fuzz must actually exercise force output, not only the zero path.
  // The fuzz must exercise force output and every limit, not only the zero path.
  EXPECT_GT(nonzero, total / 50);
  EXPECT_GT(clamped, 1000u);
  EXPECT_GT(rate_limited, 1000u);
  EXPECT_GT(held, 1000u);
  std::printf("fuzzed %llu probe-ticks: %llu non-zero forces, %llu clamped, %llu rate-limited, %llu held at zero\n",
              static_cast<unsigned long long>(total), static_cast<unsigned long long>(nonzero),
              static_cast<unsigned long long>(clamped), static_cast<unsigned long long>(rate_limited),
              static_cast<unsigned long long>(held));
}

TEST_F(SafetyFuzz, AbsurdConfigurationsAreRefusedOrSafe) {
  Fuzzer fz(99);
  int refused = 0, accepted = 0;
  for (int round = 0; round < 300; ++round) {
    CoreConfig cfg;
    auto value = [&](double sane) { return fz.chance(0.5) ? sane * fz.uniform(0.1, 10) : fz.absurd(); };
    cfg.rate_hz = fz.chance(0.5) ? 1000 : value(1000);
    cfg.deform_rate_hz = fz.chance(0.5) ? 250 : value(250);
    cfg.watchdog_periods = fz.chance(0.7) ? 3 : value(3);
    cfg.model_timeout_periods = fz.chance(0.7) ? 10 : value(10);
    cfg.velocity_cutoff_hz = fz.chance(0.7) ? 50 : value(50);
    cfg.force.friction = fz.chance(0.7) ? 0.3 : value(0.3);
    cfg.force.slip_speed = fz.chance(0.7) ? 1e-3 : value(1e-3);
    cfg.force.max_force = fz.chance(0.7) ? 10 : value(10);
    cfg.shape.radius = fz.chance(0.7) ? 0.01 : value(0.01);
    ProbeSetup p = probe("p", fz.chance(0.7) ? 5.0 : value(5), fz.chance(0.7) ? 1000 : value(1000),
                         fz.chance(0.7) ? 0.1 : value(0.1));
    p.safety.max_jump = fz.chance(0.7) ? 0.05 : value(0.05);
    if (fz.chance(0.3)) p.mapping = fz.mapping();
    if (fz.chance(0.1)) p.mapping.scale = fz.absurd();
    std::unique_ptr<LoopCore> core;
    try {
      core = std::make_unique<LoopCore>(*tree_, *mesh_, cfg, std::vector<ProbeSetup>{p});
    } catch (const std::invalid_argument& e) {
      EXPECT_GT(std::string(e.what()).size(), 10u);
      ++refused;
      continue;
    }
    ++accepted;
    deform::DeformableSurface surface(mesh_, materials(fz.chance(0.5) ? 500 : 1e6));
    const auto checks = run(*core, surface, fz, 5000, cfg.period());
    EXPECT_EQ(checks[0].violations_finite, 0u) << round;
    EXPECT_EQ(checks[0].violations_limit, 0u) << round;
    EXPECT_EQ(checks[0].violations_rate, 0u) << round;
    EXPECT_EQ(checks[0].violations_fault, 0u) << round;
  }
  EXPECT_GT(refused, 30);
  EXPECT_GT(accepted, 30);
}

}  // namespace
}  // namespace palpa::haptics
