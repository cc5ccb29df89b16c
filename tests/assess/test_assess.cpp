// The assessment on sessions whose answers are known by construction
// (docs/ASSESSMENT.md): a raster over the whole patch at a constant depth
// covers all of it at that depth's level; a path that avoids a lesion
// leaves it "never adequately probed", a press over it at depth makes it
// "felt but missed"; one mark on it gives sensitivity 1 and no false
// positive; force over the limit, phases and levels by their definitions.

#include "assess/assess.h"
#include "mesh/generate.h"

#include <gtest/gtest.h>

#include <cmath>

namespace palpa::assess {
namespace {

constexpr double kDt = 1e-3;  // s per tick

std::shared_ptr<const mesh::SurfaceMesh> plane() {
  return std::make_shared<const mesh::SurfaceMesh>(mesh::make_plane(41, 41, 1e-3));  // 40 x 40 mm at z = 0
}

// A scripted probe: one contact point per tick (organ frame), depth and force.
struct Step {
  Vec3 point;
  double depth;
  double force = 1.0;
  bool contact = true;
};

Report run(std::shared_ptr<const mesh::SurfaceMesh> m, const std::vector<Step>& steps,
           std::vector<tissue::Lesion> lesions = {}, Task task = {}, std::vector<record::EventRecord> events = {},
           Assessor** keep = nullptr) {
  static std::unique_ptr<Assessor> a;
  a = std::make_unique<Assessor>(std::move(m), std::move(lesions), task, Options{});
  for (std::size_t n = 0; n < steps.size(); ++n) {
    haptics::TickRecord t;
    t.tick = n;
    t.time = static_cast<double>(n) * kDt;
    t.probe_count = 1;
    haptics::ProbeTickResult r;
    r.in_contact = steps[n].contact;
    r.depth = steps[n].contact ? steps[n].depth : 0;
    r.contact_point = haptics::to_triple(steps[n].point);
    r.force_world = {0, 0, steps[n].force};
    a->add(t, std::span<const haptics::ProbeTickResult>(&r, 1));
  }
  if (keep) *keep = a.get();
  return a->finish(events);
}

// Rows 2 mm apart over [x0, x1] x [-20, 20] mm, 0.2 mm per tick, at `depth`.
std::vector<Step> raster(double depth, double x0 = -0.020, double x1 = 0.020) {
  std::vector<Step> s;
  int row = 0;
  for (double y = -0.020; y <= 0.020 + 1e-9; y += 0.002, ++row)
    for (double k = 0; k <= 1.0 + 1e-9; k += 0.2e-3 / (x1 - x0)) {
      const double x = row % 2 ? x1 - k * (x1 - x0) : x0 + k * (x1 - x0);
      s.push_back({Vec3(x, y, 0), depth});
    }
  return s;
}

TEST(Assess, RasterAtConstantDepthCoversTheWholePatchAtItsLevel) {
  // a = sqrt(8 mm * 2 mm) = 4 mm > the 1 mm a row leaves on each side.
  const Report r = run(plane(), raster(0.002));
  EXPECT_DOUBLE_EQ(r.coverage[0], 1.0);
  EXPECT_DOUBLE_EQ(r.coverage[static_cast<int>(Level::Light)], 1.0);  // an open patch has no thickness: light
  EXPECT_DOUBLE_EQ(r.coverage[static_cast<int>(Level::Deep)], 0.0);
  EXPECT_DOUBLE_EQ(r.largest_gap_area, 0.0);
  EXPECT_NEAR(r.roi_area, 0.04 * 0.04, 1e-12);
  EXPECT_NEAR(r.contact_time, (static_cast<double>(raster(0.002).size()) - 1) * kDt, 1e-9);
  // 0.2 mm per ms = 0.2 m/s: all search, none palpation.
  EXPECT_GT(r.search_time, 0.99 * r.contact_time);
  EXPECT_NEAR(r.path_length, 21 * 0.040 + 20 * 0.002, 2e-3);  // the rows, plus the steps between them
}

TEST(Assess, HalfARasterLeavesTheOtherHalfAsTheLargestGap) {
  const Report r = run(plane(), raster(0.002, -0.020, -0.002));
  // Covered: x up to -2 mm + a = 2 mm; the gap is x in (2, 20] mm.
  EXPECT_NEAR(r.coverage[0], 23.0 / 41.0, 0.03);
  EXPECT_NEAR(r.largest_gap_area, 0.018 * 0.040, 0.002 * 0.040);
}

TEST(Assess, LevelsFollowTheThicknessFraction) {
  // A sphere of radius 30 mm: thickness 60 mm along the inward normal.
  auto sphere = std::make_shared<const mesh::SurfaceMesh>(mesh::make_sphere(4000, 0.03));
  const Vec3 top(0, 0, 0.03);
  std::vector<Step> s;
  for (int n = 0; n < 1000; ++n) s.push_back({top, 0.002});    // 3% of 60 mm: light
  for (int n = 0; n < 1000; ++n) s.push_back({top, 0.006});    // 10%: medium
  for (int n = 0; n < 1000; ++n) s.push_back({top, 0.0120});   // 20%: deep
  const Report r = run(sphere, s);
  EXPECT_NEAR(r.level_time[1], 0.999, 1e-9);
  EXPECT_NEAR(r.level_time[2], 1.0, 1e-9);
  EXPECT_NEAR(r.level_time[3], 1.0, 1e-9);
  EXPECT_DOUBLE_EQ(r.search_time, 0.0);  // pressing still: all palpation
  EXPECT_NEAR(r.palpation_time, 2.999, 1e-9);
  EXPECT_EQ(level_of(0.002, 0.06, true), Level::Light);
  EXPECT_EQ(level_of(0.006, 0.06, true), Level::Medium);
  EXPECT_EQ(level_of(0.012, 0.06, true), Level::Deep);
  EXPECT_EQ(level_of(0.012, 0.06, false), Level::None);
}

tissue::Lesion lesion() {
  tissue::Lesion l;
  l.name = "lump";
  l.centre = Vec3(0.010, 0.010, -0.005);
  l.semi_axes = Vec3::Constant(0.003);
  l.modulus_ratio = 5;
  return l;
}

TEST(Assess, APathThatAvoidsALesionLeavesItNeverProbed) {
  const Report r = run(plane(), raster(0.002, -0.020, -0.008), {lesion()});
  ASSERT_EQ(r.lesions.size(), 1u);
  EXPECT_FALSE(r.lesions[0].found);
  EXPECT_DOUBLE_EQ(r.lesions[0].max_contrast, 0.0);
  EXPECT_EQ(r.lesions[0].missed, "never adequately probed");
  EXPECT_DOUBLE_EQ(r.sensitivity, 0.0);
}

TEST(Assess, APressOverALesionAtDepthMakesItFelt) {
  std::vector<Step> s(500, Step{Vec3(0.010, 0.010, 0), 0.004});  // the tip inside the lesion's top
  const Report r = run(plane(), s, {lesion()});
  EXPECT_GT(r.lesions[0].max_contrast, 0.10);
  EXPECT_EQ(r.lesions[0].missed, "felt but missed");
}

TEST(Assess, OneMarkOnTheLesionFindsIt) {
  std::vector<Step> s(500, Step{Vec3(0.010, 0.010, 0), 0.004});
  auto m = record::EventRecord::make(record::EventKind::Mark, 300, 0.3, "hard");
  m.point = {0.010, 0.011, -0.005};
  m.value = 0.006;
  const Report r = run(plane(), s, {lesion()}, Task{}, {m});
  EXPECT_DOUBLE_EQ(r.sensitivity, 1.0);
  EXPECT_EQ(r.false_positives, 0u);
  EXPECT_TRUE(r.lesions[0].found);
  EXPECT_NEAR(r.lesions[0].localisation_error, 0.001, 1e-12);
  EXPECT_NEAR(r.lesions[0].size_error, 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(r.lesions[0].time_to_detection, 0.3);
  EXPECT_EQ(r.marks[0].consistency, "hard");
  EXPECT_DOUBLE_EQ(r.parts[0], 1.0);
  EXPECT_DOUBLE_EQ(r.parts[1], 1.0);
}

TEST(Assess, AMarkAwayFromEveryLesionIsAFalsePositive) {
  std::vector<Step> s(100, Step{Vec3(0, 0, 0), 0.002});
  auto m = record::EventRecord::make(record::EventKind::Mark, 50, 0.05);
  m.point = {-0.015, -0.015, -0.005};
  const Report r = run(plane(), s, {lesion()}, Task{}, {m});
  EXPECT_EQ(r.false_positives, 1u);
  EXPECT_DOUBLE_EQ(r.sensitivity, 0.0);
  EXPECT_EQ(r.marks[0].lesion, -1);
}

// A deleted mark is not scored: the wrong mark the trainee withdrew is no
// false positive, and of two marks at one point one deletion leaves one.
TEST(Assess, ADeletedMarkIsNotScored) {
  std::vector<Step> s(500, Step{Vec3(0.010, 0.010, 0), 0.004});
  auto wrong = record::EventRecord::make(record::EventKind::Mark, 50, 0.05);
  wrong.point = {-0.015, -0.015, -0.005};
  auto right = record::EventRecord::make(record::EventKind::Mark, 300, 0.3, "hard");
  right.point = {0.010, 0.011, -0.005};
  right.value = 0.006;
  auto unmark = record::EventRecord::make(record::EventKind::Unmark, 400, 0.4, "mark 1 deleted");
  unmark.point = wrong.point;
  const Report r = run(plane(), s, {lesion()}, Task{}, {wrong, right, unmark});
  EXPECT_EQ(r.marks_deleted, 1u);
  ASSERT_EQ(r.marks.size(), 1u);
  EXPECT_EQ(r.false_positives, 0u);
  EXPECT_DOUBLE_EQ(r.sensitivity, 1.0);
  EXPECT_NE(to_json(r).find("\"marks_deleted\": 1"), std::string::npos);
  // Twice the same wrong mark, deleted once: one false positive stays. An
  // Unmark naming no standing mark (recording began later) changes nothing.
  auto stray = unmark;
  stray.point = {0.5, 0.5, 0.5};
  const Report twice = run(plane(), s, {lesion()}, Task{}, {wrong, wrong, right, unmark, stray});
  EXPECT_EQ(twice.marks_deleted, 1u);
  EXPECT_EQ(twice.marks.size(), 2u);
  EXPECT_EQ(twice.false_positives, 1u);
}

// A trainee marks on the surface: a mark straight above a lesion 15 mm
// deep (beyond the 10 mm tolerance from its centre) is on it, with no
// localisation error (the plane's vertex above the centre is the mark);
// 12 mm to the side of that point it is a false positive.
TEST(Assess, AMarkOnTheSurfaceAboveADeepLesionFindsIt) {
  tissue::Lesion deep = lesion();
  deep.centre = Vec3(0.010, 0.010, -0.015);
  std::vector<Step> s(100, Step{Vec3(0, 0, 0), 0.002});
  auto above = record::EventRecord::make(record::EventKind::Mark, 50, 0.05);
  above.point = {0.010, 0.010, 0.0};
  Report r = run(plane(), s, {deep}, Task{}, {above});
  ASSERT_GT(Task{}.position_tolerance, 0.0);
  ASSERT_LT(Task{}.position_tolerance, 0.015) << "the test needs a lesion deeper than the tolerance";
  EXPECT_TRUE(r.lesions[0].found);
  EXPECT_EQ(r.false_positives, 0u);
  EXPECT_NEAR(r.lesions[0].localisation_error, 0.0, 1e-12);
  auto aside = above;
  aside.point = {0.010, 0.022, 0.0};
  r = run(plane(), s, {deep}, Task{}, {aside});
  EXPECT_FALSE(r.lesions[0].found);
  EXPECT_EQ(r.false_positives, 1u);
  // The surface point is the vertex nearest the centre (brute force).
  EXPECT_TRUE(surface_point_above(*plane(), deep).isApprox(Vec3(0.010, 0.010, 0.0), 1e-12));
}

TEST(Assess, TimeOverTheForceLimit) {
  std::vector<Step> s(1000, Step{Vec3(0, 0, 0), 0.002, 2.0});
  for (int n = 200; n < 300; ++n) s[n].force = 10.0;
  Task t;
  t.force_limit = 8.0;
  const Report r = run(plane(), s, {}, t);
  EXPECT_NEAR(r.time_over_limit, 0.100, 1e-9);
  EXPECT_DOUBLE_EQ(r.peak_force, 10.0);
  EXPECT_NEAR(r.peak_force_time, 0.200, 1e-12);
  EXPECT_NEAR(r.parts[3], 1.0 - 0.1 / 0.999, 1e-9);
}

TEST(Assess, JsonAndHtmlCarryTheNumbers) {
  std::vector<Step> s(100, Step{Vec3(0, 0, 0), 0.002});
  const Report r = run(plane(), s);
  const std::string j = to_json(r);
  EXPECT_NE(j.find("\"format\": \"palpa.assessment/1\""), std::string::npos);
  EXPECT_NE(j.find("\"contact_time_s\": 0.099"), std::string::npos) << j;
  const std::string h = to_html(r, "a <test>", {1, 2, 3}, {{0, 1}, {1, 2}}, 8);
  EXPECT_NE(h.find("a &lt;test&gt;"), std::string::npos);
  EXPECT_NE(h.find("data:image/png;base64,AQID"), std::string::npos);
  EXPECT_NE(h.find("<polyline"), std::string::npos);
}

}  // namespace
}  // namespace palpa::assess
