// What a trainee feels of the tissue model, checked against closed forms and
// the properties palpation has: Hertz contact, continuity across a region
// edge, buried lesions, pulse, breathing, keyframes and guarding.

#include "haptics/indent.h"
#include "haptics/session.h"
#include "mesh/generate.h"
#include "tissue/field.h"
#include "tissue/lesion.h"
#include "tissue/tissue.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

namespace palpa::haptics {
namespace {

constexpr double kTip = 0.008;  // m

tissue::Tissue soft(double e_pa = 4100) {
  tissue::Tissue t;
  t.name = "soft";
  t.youngs_modulus = e_pa;
  t.poisson = 0.49;
  t.damping_ratio = 1.0;
  return t;
}

std::shared_ptr<const mesh::SurfaceMesh> plane(int n = 101, double spacing = 0.001) {
  auto m = std::make_shared<mesh::SurfaceMesh>(mesh::make_plane(n, n, spacing));
  return m;
}

CoreConfig config(double rate = 1000) {
  CoreConfig c;
  c.rate_hz = rate;
  c.deform_rate_hz = rate / 2;
  c.force.max_force = 100;
  c.force.friction = 0;
  c.shape.kind = deform::ShapeKind::Wendland;
  c.shape.radius = 0.02;
  return c;
}

std::shared_ptr<const SessionModel> model_of(std::shared_ptr<const mesh::SurfaceMesh> m, tissue::TissueField field = {},
                                             std::shared_ptr<const deform::MaterialMap> map = nullptr) {
  field.tip_radius = kTip;
  return SessionModel::make(std::move(m), {}, config(), std::make_shared<tissue::TissueField>(std::move(field)),
                            std::move(map));
}

// Presses at (x, y) on the plane to each depth; returns the settled forces.
std::vector<double> press(const std::shared_ptr<const SessionModel>& model, const deform::Material& mat, double x,
                          double y, const std::vector<double>& depths) {
  const IndentSite site = indent_site(*model, Vec3(x, y, 0));
  IndentOptions o;
  o.settle = 0.2;
  std::vector<double> f;
  for (const auto& s : indent(model, mat, site, depths, o)) f.push_back(s.force);
  return f;
}

TEST(TissueFeel, HertzOnAFlatPatchWithinTenPercent) {
  const tissue::Tissue t = soft();
  const auto model = model_of(plane(121));
  const std::vector<double> depths{0.001, 0.002, 0.004, 0.006, 0.008, 0.010};
  const auto f = press(model, tissue::hertz_material(t, kTip), 0, 0, depths);
  for (std::size_t k = 0; k < depths.size(); ++k) {
    const double hertz = 4.0 / 3.0 * t.youngs_modulus / (1 - t.poisson * t.poisson) * std::sqrt(kTip) *
                         std::pow(depths[k], 1.5);
    EXPECT_NEAR(f[k] / hertz, 1.0, 0.10) << "depth " << depths[k] << " m: " << f[k] << " N vs Hertz " << hertz;
    EXPECT_NEAR(f[k] / hertz, 1.0, 0.02) << "the softening near 0 costs at most 1.5% from 1 mm";
  }
}

TEST(TissueFeel, HertzOnACurvedOrganUpToAFifthOfItsThickness) {
  // A 50 mm sphere: 100 mm thick along the inward normal, so up to 20 mm.
  const tissue::Tissue t = soft(8000);
  auto sphere = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(20000, 0.05));
  const auto model = model_of(sphere);
  const IndentSite site = indent_site(*model, Vec3(0, 0, 0.06));
  ASSERT_NEAR(site.thickness, 0.1, 1e-3);
  std::vector<double> depths;
  for (double d = 0.001; d <= 0.2 * site.thickness + 1e-12; d += 0.003) depths.push_back(d);
  IndentOptions o;
  o.settle = 0.2;
  const auto s = indent(model, tissue::hertz_material(t, kTip), site, depths, o);
  for (const auto& r : s) {
    ASSERT_TRUE(r.in_contact);
    EXPECT_NEAR(r.force / tissue::hertz_force(t, kTip, r.depth), 1.0, 0.10) << "depth " << r.depth;
  }
}

TEST(TissueFeel, TheMappingScalesWithModulusAndTipAsHertzSays) {
  const tissue::Tissue a = soft(2000), b = soft(8000);
  // Four times the modulus: four times the force; twice the tip: sqrt(2) times.
  EXPECT_NEAR(tissue::hertz_coefficient(b, kTip) / tissue::hertz_coefficient(a, kTip), 4.0, 1e-12);
  EXPECT_NEAR(tissue::hertz_coefficient(a, 2 * kTip) / tissue::hertz_coefficient(a, kTip), std::sqrt(2.0), 1e-12);
  // The material's spring is the coefficient's law.
  const deform::Material m = tissue::hertz_material(a, kTip);
  const double d = 0.005;
  EXPECT_NEAR(-deform::hertz_spring(m, -d) / tissue::hertz_force(a, kTip, d), 1.0, 0.01);
}

TEST(TissueFeel, SlidingAcrossATissueEdgeNeverJumps) {
  // Left half 3 kPa, right half 15 kPa, a sharp edge at x = 0; and the right
  // half viscoelastic, so the corners differ in more than the modulus.
  auto m = plane(81);
  tissue::Tissue left = soft(3000), right = soft(15000);
  right.relaxation_time = 0.3;
  right.relaxation_fraction = 0.5;
  auto map = std::make_shared<deform::MaterialMap>();
  map->tissues = {tissue::hertz_material(left, kTip), tissue::hertz_material(right, kTip)};
  for (const Vec3& p : m->positions) map->tissue_of.push_back(p.x() > 0 ? 1 : 0);
  const auto model = model_of(m, {}, map);
  ProbeSetup probe;
  probe.name = "slider";
  probe.spec.position_dof = 3;
  probe.safety.max_jump = 1e9;
  Session s(model, deform::MaterialArrays::uniform(m->vertex_count(), map->tissues[0]), {probe});
  std::vector<ProbeTickInput> in(1);
  std::vector<ProbeTickResult> out(1);
  const double depth = 0.004, speed = 0.01;  // m, m/s
  double prev = -1, worst = 0;
  const double fa = tissue::hertz_force(left, kTip, depth), fb = tissue::hertz_force(right, kTip, depth);
  for (int n = 0; n < 3000; ++n) {
    const double t = n * 1e-3;
    const double x = -0.015 + speed * t;
    auto& smp = in[0].sample;
    smp.orientation[0] = 1;
    smp.position[0] = x;
    smp.position[1] = 0.0003;
    smp.position[2] = -std::min(depth, 0.0005 * n);
    smp.status = PALPA_STATUS_VALID;
    smp.sequence = n + 1;
    smp.time = t;
    s.step(t, in, out);
    if (n > 10) {
      ASSERT_TRUE(out[0].in_contact) << n;
    }
    const double f = out[0].normal_reaction;
    if (n > 20 && prev >= 0) worst = std::max(worst, std::abs(f - prev));
    prev = f;
  }
  // 10 um per tick over 1 mm triangles: the force moves by a few percent of
  // the contrast per tick, never by the contrast at once.
  EXPECT_LT(worst, 0.05 * (fb - fa)) << "largest change in one tick " << worst << " N; contrast " << fb - fa << " N";
  // Ends on the stiff side: between its relaxed force and the (1 + g) of a
  // quick press (sliding keeps meeting unrelaxed tissue).
  EXPECT_GT(prev, 0.95 * fb);
  EXPECT_LT(prev, 1.5 * fb);
}

// --- Lesions ---------------------------------------------------------------

tissue::LesionData sphere_lesion(double radius, double centre_depth, double ratio, double x = 0) {
  tissue::Lesion l;
  l.centre = Vec3(x, 0, -centre_depth);
  l.semi_axes = Vec3::Constant(radius);
  l.modulus_ratio = ratio;
  return tissue::lesion_data(l);
}

// Contrast at surface point (x, 0, 0) of a flat patch pressed d deep.
double contrast(const tissue::LesionData& l, double x, double d) {
  return tissue::lesion_contrast(l, Vec3(x, 0, -d), d, kTip);
}

TEST(LesionFeel, FeltOnlyWhenThePressIsDeepEnoughForItsDepth) {
  const auto l = sphere_lesion(0.005, 0.020, 4);  // top 15 mm down
  EXPECT_EQ(contrast(l, 0, 0.001), 0.0);
  EXPECT_EQ(contrast(l, 0, 0.002), 0.0);  // reach 2.5 sqrt(R d) = 10 mm < the 13 mm gap
  EXPECT_GT(contrast(l, 0, 0.008), 0.0);
  // The press depth at which it first shows grows with the lesion's depth.
  auto onset = [](const tissue::LesionData& les) {
    for (double d = 0.0001; d < 0.05; d += 0.0001)
      if (contrast(les, 0, d) > 0) return d;
    return 1.0;
  };
  EXPECT_LT(onset(sphere_lesion(0.005, 0.010, 4)), onset(sphere_lesion(0.005, 0.015, 4)));
  EXPECT_LT(onset(sphere_lesion(0.005, 0.015, 4)), onset(sphere_lesion(0.005, 0.020, 4)));
}

TEST(LesionFeel, ContrastFallsMonotonicallyWithDepthAndVanishes) {
  const double d = 0.005;
  double prev = 1e9;
  bool vanished = false;
  for (double z = 0.006; z < 0.06; z += 0.0005) {
    const double c = contrast(sphere_lesion(0.005, z, 4), 0, d);
    EXPECT_LE(c, prev) << "centre depth " << z;
    prev = c;
    if (c == 0) vanished = true;
    if (vanished) {
      EXPECT_EQ(c, 0.0) << "stays zero beyond the reach, depth " << z;
    }
  }
  EXPECT_TRUE(vanished);
  // Beyond the reach exactly: top of the lesion farther than 2.5 sqrt(R d) below the tip.
  const double reach = tissue::kLesionReach * std::sqrt(kTip * d);
  EXPECT_EQ(contrast(sphere_lesion(0.005, d + reach + 0.005 + 1e-6, 4), 0, d), 0.0);
  EXPECT_GT(contrast(sphere_lesion(0.005, d + reach + 0.005 - 1e-3, 4), 0, d), 0.0);
}

TEST(LesionFeel, ALargerOrStifferLesionIsFeltDeeper) {
  // The deepest centre at which the contrast still reaches 10% at a 6 mm press.
  auto deepest = [](double radius, double ratio) {
    double z_best = 0;
    for (double z = radius + 0.001; z < 0.08; z += 0.0002)
      if (contrast(sphere_lesion(radius, z, ratio), 0, 0.006) >= 0.10) z_best = z;
    return z_best - radius;  // depth of its top
  };
  EXPECT_GT(deepest(0.008, 4), deepest(0.004, 4));
  EXPECT_GT(deepest(0.005, 8), deepest(0.005, 3));
}

TEST(LesionFeel, TheFootprintGrowsWithPressure) {
  const auto l = sphere_lesion(0.005, 0.012, 4);
  auto footprint = [&](double d) {
    double x = 0;
    while (x < 0.1 && contrast(l, x, d) > 0) x += 0.0001;
    return x;
  };
  const double f3 = footprint(0.003), f6 = footprint(0.006), f9 = footprint(0.009);
  EXPECT_GT(f3, 0.0);
  EXPECT_GT(f6, f3);
  EXPECT_GT(f9, f6);
}

TEST(LesionFeel, ContinuousAcrossTheEdgeAtConstantDepth) {
  // Lipschitz in x: no step of 0.1 mm changes the contrast by more than a
  // small bound, over the whole slide across the lesion and its edge.
  const auto l = sphere_lesion(0.006, 0.010, 5);
  const double d = 0.006;
  double worst = 0, peak = 0;
  for (double x = -0.04; x < 0.04; x += 0.0001) {
    const double a = contrast(l, x, d), b = contrast(l, x + 0.0001, d);
    worst = std::max(worst, std::abs(b - a));
    peak = std::max(peak, a);
  }
  EXPECT_GT(peak, 1.0);
  EXPECT_LT(worst, 0.02 * peak);
}

TEST(LesionFeel, TheTickAddsTheContrastTimesTheTissueForce) {
  tissue::TissueField field;
  tissue::Lesion les;
  les.centre = Vec3(0, 0, -0.012);
  les.semi_axes = Vec3::Constant(0.006);
  les.modulus_ratio = 4;
  field.lesion_count = 1;
  field.lesions[0] = tissue::lesion_data(les);
  field.tip_radius = kTip;
  const tissue::Tissue t = soft();
  const deform::Material m = tissue::hertz_material(t, kTip);
  const auto plain = model_of(plane(101));
  const auto with = model_of(plane(101), field);
  const std::vector<double> depths{0.002, 0.005, 0.008};
  const auto f0 = press(plain, m, 0, 0, depths);
  const auto f1 = press(with, m, 0, 0, depths);
  for (std::size_t k = 0; k < depths.size(); ++k) {
    const double c = tissue::lesion_contrast(field.lesions[0], Vec3(0, 0, -depths[k]), depths[k], kTip);
    EXPECT_NEAR(f1[k], f0[k] * (1 + c), 1e-3 * f0[k]) << depths[k];
  }
  EXPECT_GT(f1[2], 1.5 * f0[2]) << "a stiff lesion 6 mm down is felt at an 8 mm press";
  // Far from it, nothing.
  const auto far0 = press(plain, m, 0.04, 0.04, {0.005});
  const auto far1 = press(with, m, 0.04, 0.04, {0.005});
  EXPECT_EQ(far0[0], far1[0]);
}

// --- Pulse and breathing ---------------------------------------------------

// Runs a session with one still probe (world position p) for `seconds`;
// returns the normal reaction per tick.
std::vector<double> hold(const std::shared_ptr<const SessionModel>& model, const deform::Material& mat, const Vec3& p,
                         double seconds, Session** keep = nullptr) {
  ProbeSetup probe;
  probe.name = "still";
  probe.spec.position_dof = 3;
  probe.safety.max_jump = 1e9;
  static std::unique_ptr<Session> kept;
  kept = std::make_unique<Session>(model, deform::MaterialArrays::uniform(model->mesh->vertex_count(), mat),
                                   std::vector<ProbeSetup>{probe});
  std::vector<ProbeTickInput> in(1);
  std::vector<ProbeTickResult> out(1);
  std::vector<double> f;
  const double dt = model->config.period();
  const auto n = static_cast<long>(std::lround(seconds / dt));
  for (long k = 0; k < n; ++k) {
    const double t = k * dt;
    auto& s = in[0].sample;
    s.orientation[0] = 1;
    // Come down from 1 mm above in the first 0.2 s, then hold.
    const double down = std::min(1.0, t / 0.2);
    for (int c = 0; c < 3; ++c) s.position[c] = p[c];
    s.position[2] = 0.001 + down * (p.z() - 0.001);
    s.status = PALPA_STATUS_VALID;
    s.sequence = k + 1;
    s.time = t;
    kept->step(t, in, out);
    f.push_back(out[0].normal_reaction);
  }
  if (keep) *keep = kept.get();
  return f;
}

tissue::TissueField pulse_field(const mesh::SurfaceMesh& m, double bpm) {
  tissue::Pulse p;
  p.name = "artery";
  p.path = {Vec3(0, -0.05, -0.004), Vec3(0, 0.05, -0.004)};
  p.radius = 0.015;
  p.rate_bpm = bpm;
  p.amplitude = 0.001;
  return tissue::make_field(m, kTip, {}, {p}, {}, {}, {});
}

TEST(PulseFeel, TheForceSpectrumOfARestingProbePeaksAtTheRate) {
  auto m = plane(81);
  const double bpm = 72;
  const auto model = model_of(m, pulse_field(*m, bpm));
  const auto f = hold(model, tissue::hertz_material(soft(), kTip), Vec3(0, 0, -0.003), 11.0);
  // Drop the first second; scan the DTFT of the rest from 0.5 to 3 Hz.
  std::vector<double> x(f.begin() + 1000, f.end());
  double mean = 0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(x.size());
  double best_f = 0, best = 0;
  for (double hz = 0.5; hz <= 3.0; hz += 0.001) {
    std::complex<double> acc = 0;
    for (std::size_t k = 0; k < x.size(); ++k)
      acc += (x[k] - mean) * std::polar(1.0, -2 * std::numbers::pi * hz * static_cast<double>(k) * 1e-3);
    if (std::abs(acc) > best) {
      best = std::abs(acc);
      best_f = hz;
    }
  }
  EXPECT_NEAR(best_f, bpm / 60, 0.02 * bpm / 60) << "peak at " << best_f << " Hz";
  // The beat is felt: peak-to-peak a good part of the force.
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  EXPECT_GT(*hi - *lo, 0.2 * mean);
}

TEST(PulseFeel, NothingMovesFarFromTheVessel) {
  auto m = plane(81);
  const auto model = model_of(m, pulse_field(*m, 72));
  Session* s = nullptr;
  const auto f = hold(model, tissue::hertz_material(soft(), kTip), Vec3(0.03, 0, -0.003), 3.0, &s);
  for (std::size_t k = 1000; k < f.size(); ++k) EXPECT_EQ(f[k], f[1000]) << k;
  // Vertices beyond the vessel's radius and outside the probe's field stay exactly at rest.
  const auto& st = s->surface().state().vertices;
  for (Index i = 0; i < m->vertex_count(); ++i) {
    const Vec3& p = m->positions[i];
    if (std::abs(p.x()) > 0.016 && (p - Vec3(0.03, 0, 0)).norm() > 0.021) {
      EXPECT_EQ(st[i].h, 0.0) << i;
    }
  }
  // And near it the surface rises and falls.
  double top = 0;
  for (Index i = 0; i < m->vertex_count(); ++i)
    if (m->positions[i].norm() < 1e-9) top = st[i].h;
  EXPECT_GT(std::abs(top), 0.0);
}

TEST(BreathingFeel, AStillProbeFeelsTheForceFollowThePhase) {
  auto m = plane(81);
  tissue::Breathing b;
  b.enabled = true;
  b.rate_bpm = 15;  // a 4 s breath
  b.translation = Vec3(0, 0, 0.004);
  const auto model = model_of(m, tissue::make_field(*m, kTip, {}, {}, b, {}, {}));
  const tissue::Tissue t = soft();
  const auto f = hold(model, tissue::hertz_material(t, kTip), Vec3(0, 0, -0.002), 8.0);
  const tissue::TissueField& field = *model->field;
  for (std::size_t k = 500; k < f.size(); k += 50) {
    const double time = static_cast<double>(k) * 1e-3;
    const double d = 0.002 + 0.004 * field.breathing_value(time);
    EXPECT_NEAR(f[k], tissue::hertz_force(t, kTip, d), 0.1 * tissue::hertz_force(t, kTip, d) + 0.002) << time;
  }
  // Largest at end inspiration (phase 0.4 of each breath: 1.6 s, 5.6 s).
  const auto peak = std::max_element(f.begin() + 4000, f.end()) - f.begin();
  EXPECT_NEAR(static_cast<double>(peak) * 1e-3, 5.6, 0.1);
}

TEST(BreathingFeel, ReplayFromASnapshotIsBitIdentical) {
  auto m = plane(61);
  tissue::Breathing b;
  b.enabled = true;
  b.translation = Vec3(0, 0, 0.003);
  tissue::Pulse p;
  p.name = "vessel";
  p.path = {Vec3(-0.05, 0, -0.003), Vec3(0.05, 0, -0.003)};
  p.radius = 0.01;
  const auto model = model_of(m, tissue::make_field(*m, kTip, {}, {p}, b, {}, {}));
  const deform::Material mat = tissue::hertz_material(soft(), kTip);
  ProbeSetup probe;
  probe.name = "still";
  probe.spec.position_dof = 3;
  probe.safety.max_jump = 1e9;
  Session a(model, deform::MaterialArrays::uniform(m->vertex_count(), mat), {probe});
  Session c(model, deform::MaterialArrays::uniform(m->vertex_count(), mat), {probe});
  std::vector<ProbeTickInput> in(1);
  std::vector<ProbeTickResult> out(1);
  SessionState snap;
  std::vector<double> first, second;
  for (int k = 0; k < 4000; ++k) {
    const double t = k * 1e-3;
    auto& s = in[0].sample;
    s.orientation[0] = 1;
    s.position[0] = 0.002 * std::sin(t);
    s.position[1] = 0.001;
    s.position[2] = -0.002;
    s.status = PALPA_STATUS_VALID;
    s.sequence = k + 1;
    s.time = t;
    if (k == 2000) snap = a.snapshot();
    a.step(t, in, out);
    if (k >= 2000) first.push_back(out[0].normal_reaction);
  }
  c.restore(snap);
  for (int k = 2000; k < 4000; ++k) {
    const double t = k * 1e-3;
    auto& s = in[0].sample;
    s.position[0] = 0.002 * std::sin(t);
    s.position[1] = 0.001;
    s.position[2] = -0.002;
    s.sequence = k + 1;
    s.time = t;
    c.step(t, in, out);
    second.push_back(out[0].normal_reaction);
  }
  ASSERT_EQ(first.size(), second.size());
  for (std::size_t k = 0; k < first.size(); ++k) ASSERT_EQ(first[k], second[k]) << k;
}

// --- Keyframes and guarding ------------------------------------------------

TEST(DynamicFeel, AKeyframeChangesTheModulusAtItsTime) {
  auto m = plane(61);
  tissue::DynamicRegion d;
  d.region = "all";
  d.keyframes = {{1.0, 2.0, 0.0}, {2.0, 0.5, 0.5}};
  const auto model =
      model_of(m, tissue::make_field(*m, kTip, {}, {}, {}, {d}, {std::vector<float>(m->vertex_count(), 1.0f)}));
  const tissue::Tissue t = soft();
  const auto f = hold(model, tissue::hertz_material(t, kTip), Vec3(0, 0, -0.004), 3.0);
  const double base = tissue::hertz_force(t, kTip, 0.004);
  EXPECT_NEAR(f[900] / base, 1.0, 0.02);
  EXPECT_NEAR(f[1500] / base, 2.0, 0.04);
  EXPECT_NEAR(f[2250] / base, 1.25, 0.03) << "half way down the ramp from 2 to 0.5";
  EXPECT_NEAR(f[2900] / base, 0.5, 0.02);
}

TEST(DynamicFeel, GuardingStiffensForItsDurationThenReleases) {
  auto m = plane(61);
  tissue::DynamicRegion d;
  d.region = "all";
  d.guarding.enabled = true;
  d.guarding.threshold = 0.1;  // N
  d.guarding.factor = 1.5;
  d.guarding.duration = 1.0;
  d.guarding.release = 1.0;
  const auto model =
      model_of(m, tissue::make_field(*m, kTip, {}, {}, {}, {d}, {std::vector<float>(m->vertex_count(), 1.0f)}));
  const tissue::Tissue t = soft();
  const double depth = 0.004;
  const double base = tissue::hertz_force(t, kTip, depth);
  ASSERT_GT(base, 0.1);
  const auto f = hold(model, tissue::hertz_material(t, kTip), Vec3(0, 0, -depth), 3.5);
  // The force crosses 0.1 N on the way down (t < 0.2 s), and the trigger holds.
  std::size_t trigger = 0;
  for (std::size_t k = 0; k < f.size(); ++k)
    if (f[k] > 0.1 * 1.0001) {
      trigger = k;
      break;
    }
  ASSERT_GT(trigger, 0u);
  const double t0 = static_cast<double>(trigger) * 1e-3;
  auto at = [&](double s) { return f[static_cast<std::size_t>(std::lround((t0 + s) * 1e3))]; };
  EXPECT_NEAR(at(0.5) / base, 1.5, 0.03);
  EXPECT_NEAR(at(1.5) / base, 1.25, 0.03);
  // After release it may trigger again (still pressing above the threshold): factor 1.5 once more.
  EXPECT_NEAR(at(2.0 + 0.01) / base, 1.5, 0.03);
}

}  // namespace
}  // namespace palpa::haptics

namespace palpa::haptics {
namespace {

TEST(LesionFeel, ContrastTableThroughTheTick) {
  // docs/TISSUE.md's table: a 6 mm sphere, rho = 4, pressed 6 mm with an 8 mm
  // tip, its top at increasing depths; felt force with / without - 1.
  const tissue::Tissue t = soft();
  const deform::Material m = tissue::hertz_material(t, kTip);
  const double d = 0.006, a = 0.006;
  const auto plain = model_of(plane(101));
  const double f0 = press(plain, m, 0, 0, {d})[0];
  std::printf("%28s %18s %14s\n", "top of lesion below [mm]", "contrast (tick)", "formula");
  for (double top : {0.006, 0.008, 0.010, 0.012, 0.015, 0.018, 0.020, 0.023, 0.025}) {
    tissue::Lesion les;
    les.centre = Vec3(0, 0, -(top + a));
    les.semi_axes = Vec3::Constant(a);
    les.modulus_ratio = 4;
    tissue::TissueField field;
    field.lesion_count = 1;
    field.lesions[0] = tissue::lesion_data(les);
    const double f1 = press(model_of(plane(101), field), m, 0, 0, {d})[0];
    const double c = f1 / f0 - 1;
    const double ac2 = kTip * d, reach = tissue::kLesionReach * std::sqrt(ac2);
    const double gap = std::max(0.0, top - d);
    const double formula = 3.0 * (a * a / (a * a + ac2)) * tissue::lesion_falloff(gap / reach);
    std::printf("%28.0f %18.3f %14.3f\n", top * 1e3, c, formula);
    EXPECT_NEAR(c, formula, 1e-3 * (1 + formula)) << top;
  }
}

}  // namespace
}  // namespace palpa::haptics
