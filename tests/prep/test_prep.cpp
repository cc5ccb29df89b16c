// prep::prepare_file on generated meshes with known defects, checked against
// closed forms (a sphere's volume 4/3 pi r^3, its radius; the union of two
// spheres), the report, the progress and cancellation, and exact messages
// for inputs that cannot be closed.

#include "prep/prep.h"

#include "common/test_support.h"
#include "mesh/generate.h"
#include "mesh/io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <vector>

namespace palpa::prep {
namespace {

constexpr double kR = 0.05;       // m: test sphere radius
constexpr double kEdge = 0.005;   // m: target edge (a tenth of the radius)
constexpr double kSphereVolume = 4.0 / 3.0 * M_PI * kR * kR * kR;

// A raw mesh (positions, triangles; nothing finalized) written as PLY.
std::filesystem::path write(const std::filesystem::path& dir, const std::string& name, const mesh::SurfaceMesh& m) {
  const auto p = dir / name;
  mesh::save_mesh(m, p);
  return p;
}

mesh::SurfaceMesh sphere(double r = kR, const Vec3& c = Vec3::Zero(), std::size_t vertices = 2400) {
  return mesh::make_sphere(vertices, r, c);
}

// Appends b's triangles (renumbered) to a.
void append(mesh::SurfaceMesh& a, const mesh::SurfaceMesh& b) {
  const Index base = static_cast<Index>(a.positions.size());
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  for (auto t : b.triangles) a.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
}

// The edge as given, not shortened to fit (the fit has its own test).
PrepOptions options(double edge = kEdge) {
  PrepOptions o;
  o.unit_m = 1.0;
  o.edge_m = edge;
  o.fit_rounds = 0;
  return o;
}

// Largest distance of a vertex from the sphere (m).
double radial_error(const mesh::SurfaceMesh& m, double r = kR, const Vec3& c = Vec3::Zero()) {
  double e = 0;
  for (const Vec3& p : m.positions) e = std::max(e, std::abs((p - c).norm() - r));
  return e;
}

// The targets every prepared mesh must meet.
void expect_targets(const PrepReport& r) {
  EXPECT_TRUE(r.after.closed);
  EXPECT_TRUE(r.after.manifold);
  EXPECT_TRUE(r.after.outward);
  EXPECT_LE(r.after.edge_cv, 0.2);
  EXPECT_LE(r.hausdorff_m, std::max(0.5e-3, r.edge_target_m / 4));
  EXPECT_LE(std::abs(r.volume_change), 0.01);
  EXPECT_TRUE(unmet_targets(r).empty()) << report_text(r);
}

class Prep : public ::testing::Test {
 protected:
  std::filesystem::path dir = test::temp_dir("prep");
};

// ---------------------------------------------------------------------------
TEST_F(Prep, SphereWithDuplicatedVerticesIsWeldedAndRemeshed) {
  // Every triangle with its own three vertices: a soup with no shared vertex.
  const mesh::SurfaceMesh s = sphere();
  mesh::SurfaceMesh soup;
  for (const auto& t : s.triangles) {
    const Index b = static_cast<Index>(soup.positions.size());
    for (Index v : t) soup.positions.push_back(s.positions[v]);
    soup.triangles.push_back({b, b + 1, b + 2});
  }
  PrepReport r;
  const mesh::SurfaceMesh out = prepare_file(write(dir, "soup.ply", soup), options(), &r);
  EXPECT_EQ(r.before.boundary_edges, 3 * s.triangles.size());
  EXPECT_EQ(r.merged_points, soup.positions.size() - s.positions.size());
  EXPECT_TRUE(r.holes.empty());
  expect_targets(r);
  EXPECT_EQ(r.after.genus, 0);
  // Closed forms: the sphere's radius and volume.
  EXPECT_LE(radial_error(out), 0.5e-3);
  EXPECT_NEAR(r.after.volume_m3 / kSphereVolume, 1.0, 0.01);
  EXPECT_NEAR(r.after.edge_mean_m / kEdge, 1.0, 0.15);
  EXPECT_GT(r.after.min_angle_deg, 20);
}

TEST_F(Prep, FlippedSphereIsOrientedOutward) {
  mesh::SurfaceMesh s = sphere();
  for (auto& t : s.triangles) std::swap(t[1], t[2]);
  PrepReport r;
  prepare_file(write(dir, "flipped.ply", s), options(), &r);
  EXPECT_FALSE(r.before.outward);
  EXPECT_LT(r.before.volume_m3, 0);
  EXPECT_TRUE(r.reoriented);
  EXPECT_EQ(r.flipped_components, 1u);
  expect_targets(r);
  EXPECT_NEAR(r.after.volume_m3 / kSphereVolume, 1.0, 0.01);
}

TEST_F(Prep, HoleIsFilledRefinedAndFaired) {
  // Cut the cap z > 0.9 r (5% of the area) off the sphere.
  mesh::SurfaceMesh s = sphere();
  std::erase_if(s.triangles, [&](const mesh::Triangle& t) {
    return (s.positions[t[0]] + s.positions[t[1]] + s.positions[t[2]]).z() / 3 > 0.9 * kR;
  });
  PrepReport r;
  const mesh::SurfaceMesh out = prepare_file(write(dir, "holed.ply", s), options(), &r);
  EXPECT_GT(r.before.boundary_edges, 0u);
  ASSERT_EQ(r.holes.size(), 1u);
  EXPECT_EQ(r.holes[0].boundary_edges, r.before.boundary_edges);
  EXPECT_TRUE(r.holes[0].faired);
  // The patch covers about the cut cap (2 pi r h, h = 0.1 r) and its border
  // follows the cap's circle (2 pi r sqrt(1 - 0.9^2))
  EXPECT_NEAR(r.holes[0].area_m2 / (2 * M_PI * kR * 0.1 * kR), 1.0, 0.25);
  // (the cube-sphere's border zigzags, so longer than the circle, but less than twice).
  EXPECT_GT(r.holes[0].perimeter_m, 2 * M_PI * kR * std::sqrt(1 - 0.81));
  EXPECT_LT(r.holes[0].perimeter_m, 2 * 2 * M_PI * kR * std::sqrt(1 - 0.81));
  expect_targets(r);
  // Fairing restores the cap: the sphere's volume within 1%, its radius within a mm.
  EXPECT_NEAR(r.after.volume_m3 / kSphereVolume, 1.0, 0.01);
  EXPECT_LE(radial_error(out), 1e-3);
}

TEST_F(Prep, SpeckIsDroppedAndReported) {
  mesh::SurfaceMesh s = sphere();
  const mesh::SurfaceMesh speck = sphere(0.001, Vec3(0.2, 0, 0), 26);
  append(s, speck);
  PrepReport r;
  prepare_file(write(dir, "speck.ply", s), options(), &r);
  EXPECT_EQ(r.before.components, 2u);
  ASSERT_EQ(r.dropped.size(), 1u);
  EXPECT_EQ(r.dropped[0].triangles, speck.triangles.size());
  EXPECT_NEAR(r.dropped[0].extent_m, 2 * std::sqrt(3.0) * 0.001, 0.5e-3);
  EXPECT_EQ(r.after.components, 1u);
  expect_targets(r);
  EXPECT_NEAR(r.after.volume_m3 / kSphereVolume, 1.0, 0.01);
}

TEST_F(Prep, OverlappingSpheresBecomeTheirUnion) {
  // Two spheres of radius r with centres d apart: the union's volume is
  // 2 (4/3 pi r^3) minus the lens pi (4r + d)(2r - d)^2 / 12.
  const double r0 = 0.04, d = 0.05;
  mesh::SurfaceMesh s = sphere(r0, Vec3(-d / 2, 0, 0));
  append(s, sphere(r0, Vec3(d / 2, 0, 0)));
  PrepReport r;
  prepare_file(write(dir, "overlap.ply", s), options(0.004), &r);
  EXPECT_GT(r.self_intersections, 0u);
  EXPECT_FALSE(r.self_intersection_fix.empty());
  const double lens = M_PI * (4 * r0 + d) * (2 * r0 - d) * (2 * r0 - d) / 12;
  const double v_union = 2 * 4.0 / 3.0 * M_PI * r0 * r0 * r0 - lens;
  EXPECT_EQ(r.after.components, 1u);
  EXPECT_EQ(r.after.genus, 0);
  EXPECT_TRUE(r.after.closed);
  EXPECT_TRUE(r.after.manifold);
  EXPECT_TRUE(r.after.outward);
  EXPECT_LE(r.after.edge_cv, 0.2);
  EXPECT_NEAR(r.after.volume_m3 / v_union, 1.0, 0.01) << report_text(r);
  // The uniform remeshing rounds the crease where the spheres meet: the
  // surface stays within half an edge of the union (not the quarter edge
  // of the target, which smooth organs meet).
  EXPECT_LE(r.hausdorff_m, 0.5 * r.edge_target_m);
}

TEST_F(Prep, AlphaWrapIsTheLastResortAndSaysHowTheShapeChanged) {
  // The same overlapping spheres with the in-place repairs turned off: the
  // alpha wrap (alpha = edge, offset = edge / 20) closes the union, a little
  // larger (by about the offset), and the first warning says so.
  const double r0 = 0.04, d = 0.05;
  mesh::SurfaceMesh s = sphere(r0, Vec3(-d / 2, 0, 0));
  append(s, sphere(r0, Vec3(d / 2, 0, 0)));
  PrepOptions o = options(0.004);
  o.allow_autorefine = false;
  o.allow_local_repair = false;
  PrepReport r;
  prepare_file(write(dir, "overlap.ply", s), o, &r);
  EXPECT_EQ(r.self_intersection_fix, "alpha_wrap");
  EXPECT_TRUE(r.after.closed);
  EXPECT_TRUE(r.after.manifold);
  EXPECT_TRUE(r.after.outward);
  EXPECT_EQ(r.after.components, 1u);
  const double lens = M_PI * (4 * r0 + d) * (2 * r0 - d) * (2 * r0 - d) / 12;
  const double v_union = 2 * 4.0 / 3.0 * M_PI * r0 * r0 * r0 - lens;
  EXPECT_NEAR(r.after.volume_m3 / v_union, 1.0, 0.03) << report_text(r);
  ASSERT_FALSE(r.warnings.empty());
  const std::string prefix = "self-intersections (" + std::to_string(r.self_intersections) +
                             " triangle pairs) could not be repaired in place: the surface was alpha-wrapped (alpha 4 "
                             "mm, offset 0.2 mm), so the shape changed: the wrap lies up to ";
  EXPECT_EQ(r.warnings[0].substr(0, prefix.size()), prefix) << r.warnings[0];
  EXPECT_NE(r.warnings[0].find("mm from the input surface; the volume changed by "), std::string::npos)
      << r.warnings[0];
}

TEST_F(Prep, FitShortensTheEdgeWhereTheTargetIsMissed) {
  // Without crease pinning the crease where two spheres overlap is rounded
  // by about a third of the edge, more than the quarter edge allowed: one fit
  // round shortens the edge by 3/4 and brings the surface closer.
  const double r0 = 0.02, d = 0.025;
  mesh::SurfaceMesh s = sphere(r0, Vec3(-d / 2, 0, 0), 600);
  append(s, sphere(r0, Vec3(d / 2, 0, 0), 600));
  const auto file = write(dir, "overlap_small.ply", s);
  PrepReport plain, fitted;
  PrepOptions p = options(0.004);
  p.feature_angle_deg = 0;
  prepare_file(file, p, &plain);
  PrepOptions o = p;
  o.fit_rounds = 1;
  prepare_file(file, o, &fitted);
  EXPECT_GT(plain.hausdorff_m, std::max(0.5e-3, 0.004 / 4));
  EXPECT_EQ(fitted.fit_rounds, 1);
  EXPECT_DOUBLE_EQ(fitted.edge_requested_m, 0.004);
  EXPECT_DOUBLE_EQ(fitted.edge_target_m, 0.003);
  EXPECT_NE(fitted.edge_rule.find("shortened to 3 mm in 1 round(s)"), std::string::npos) << fitted.edge_rule;
  EXPECT_LT(fitted.hausdorff_m, plain.hausdorff_m);
  EXPECT_GT(fitted.after.triangles, plain.after.triangles);
}

TEST_F(Prep, PinnedCreasesKeepTheOverlapSharp) {
  // The same overlap at the default feature angle: the crease is split to the
  // edge and its vertices pinned, so the surface follows it within the
  // quarter edge without shortening the edge, and no triangle folds.
  const double r0 = 0.02, d = 0.025;
  mesh::SurfaceMesh s = sphere(r0, Vec3(-d / 2, 0, 0), 600);
  append(s, sphere(r0, Vec3(d / 2, 0, 0), 600));
  PrepReport r;
  prepare_file(write(dir, "overlap_small.ply", s), options(0.004), &r);
  EXPECT_GT(r.crease_edges, 0u);
  EXPECT_LE(r.hausdorff_m, 0.004 / 4) << report_text(r);
  EXPECT_TRUE(r.after.closed);
  EXPECT_TRUE(r.after.manifold);
  EXPECT_TRUE(r.after.outward);
  EXPECT_FALSE(r.self_intersecting_after);
  EXPECT_LE(r.after.edge_cv, 0.2);
  EXPECT_GT(r.after.min_angle_deg, 10.0) << report_text(r);
}

TEST_F(Prep, EdgeFromProbeRadiusFollowsTheRule) {
  EXPECT_DOUBLE_EQ(target_edge_for(0.008, 0.2), 0.002);      // a quarter of the radius
  EXPECT_DOUBLE_EQ(target_edge_for(0.008, 0.04), 0.001);     // 1/40 of a small organ's diagonal
  PrepOptions o;
  o.unit_m = 1.0;
  o.fit_rounds = 0;
  o.probe_radius_m = 0.016;  // edge 4 mm (the diagonal's 1/40 is 4.3 mm)
  PrepReport r;
  prepare_file(write(dir, "sphere.ply", sphere()), o, &r);
  EXPECT_DOUBLE_EQ(r.edge_target_m, 0.004);
  EXPECT_EQ(r.edge_rule, "a quarter of the probe radius 16 mm");
  expect_targets(r);
}

TEST_F(Prep, TheSmallestLesionBoundsTheEdge) {
  EXPECT_DOUBLE_EQ(target_edge_for(0.008, 0.2, 0.003), 0.0015);  // half the lesion's radius
  EXPECT_DOUBLE_EQ(target_edge_for(0.008, 0.2, 0.010), 0.002);   // a large lesion: the probe's rule
  EXPECT_DOUBLE_EQ(target_edge_for(0.008, 0.04, 0.003), 0.001);  // the diagonal's rule, shorter still
  EXPECT_DOUBLE_EQ(target_edge_for(0.008, 0.2, 0.0), 0.002);     // none
  PrepOptions o;
  o.unit_m = 1.0;
  o.fit_rounds = 0;
  o.probe_radius_m = 0.016;   // the probe alone: 4 mm
  o.lesion_radius_m = 0.006;  // half of it: 3 mm
  PrepReport r;
  prepare_file(write(dir, "sphere.ply", sphere()), o, &r);
  EXPECT_DOUBLE_EQ(r.edge_target_m, 0.003);
  EXPECT_EQ(r.edge_rule, "half the smallest lesion's radius 6 mm, shorter than a quarter of the probe radius 16 mm");
  EXPECT_NEAR(r.after.edge_mean_m, 0.003, 0.0006);
  o.lesion_radius_m = -0.001;
  EXPECT_THROW(prepare_file(write(dir, "sphere.ply", sphere()), o, &r), PrepError);
}

TEST_F(Prep, VerticesAndTrianglesAreInSpatialOrder) {
  // Neighbours get nearby indices: the mean index gap along edges is a small
  // fraction of what a random order gives (a third of the vertex count).
  PrepReport r;
  const mesh::SurfaceMesh out = prepare_file(write(dir, "sphere.ply", sphere()), options(), &r);
  double gap = 0, tri_gap = 0;
  std::size_t n = 0;
  for (std::size_t f = 0; f < out.triangles.size(); ++f) {
    const auto& t = out.triangles[f];
    for (int k = 0; k < 3; ++k) gap += std::abs(double(t[k]) - double(t[(k + 1) % 3]));
    n += 3;
    for (Index g : out.triangle_neighbors[f])
      if (g != kNoIndex) tri_gap += std::abs(double(g) - double(f));
  }
  EXPECT_LT(gap / n, out.vertex_count() / 30.0);
  EXPECT_LT(tri_gap / n, out.triangle_count() / 30.0);
}

TEST_F(Prep, ProgressNamesEveryStepInOrderAndCancelStops) {
  std::vector<std::string> steps;
  PrepOptions o = options();
  o.progress = [&](std::string_view step, int index, int count, double fraction) {
    EXPECT_EQ(count, 11);
    if (fraction == 0) {
      EXPECT_EQ(index, static_cast<int>(steps.size()));
      steps.emplace_back(step);
    }
  };
  PrepReport r;
  const auto file = write(dir, "sphere.ply", sphere());
  prepare_file(file, o, &r);
  const std::vector<std::string> expected = {"repair soup", "drop specks", "fill holes", "self-intersections",
                                             "orient outward", "remesh", "relax", "refine features",
                                             "fit edge", "reorder", "measure"};
  EXPECT_EQ(steps, expected);
  ASSERT_EQ(r.times.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(r.times[i].step, expected[i]);

  // A cancel flag set during step 3 stops before step 4.
  std::atomic<bool> cancel{false};
  o.cancel = &cancel;
  o.progress = [&](std::string_view step, int, int, double) {
    if (step == "fill holes") cancel = true;
  };
  try {
    prepare_file(file, o, &r);
    FAIL() << "expected PrepCancelled";
  } catch (const PrepCancelled& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": preparation cancelled");
  }
}

TEST_F(Prep, ReportRoundTripsThroughJson) {
  PrepReport r;
  prepare_file(write(dir, "sphere.ply", sphere()), options(), &r);
  const std::string json = report_json(r);
  EXPECT_NE(json.find("\"format\": \"palpa.prep-report\""), std::string::npos);
  const PrepReport back = report_from_json(json);
  EXPECT_EQ(back.after.triangles, r.after.triangles);
  EXPECT_EQ(back.times.size(), r.times.size());
  EXPECT_DOUBLE_EQ(back.hausdorff_m, r.hausdorff_m);
  EXPECT_DOUBLE_EQ(back.after.edge_cv, r.after.edge_cv);
  EXPECT_EQ(report_json(back), json);
}

// ---------------------------------------------------------------------------
// Inputs that cannot be made into a closed surface: exact messages.
TEST_F(Prep, OpenSheetIsRefusedWithTheReason) {
  const auto file = write(dir, "sheet.ply", mesh::make_plane(5, 5, 0.01));  // 4 x 4 cells, 16 border edges
  try {
    prepare_file(file, options(0.01), nullptr);
    FAIL() << "expected PrepError";
  } catch (const PrepError& e) {
    EXPECT_EQ(std::string(e.what()),
              file.string() +
                  ": cannot make a closed surface: hole 1 of 1 (16 boundary edges, perimeter 160 mm) would be 50% "
                  "of the surface (the limit is 20%); the input is an open sheet, not a closed organ with holes");
  }
}

TEST_F(Prep, OnlyDegenerateTrianglesIsRefusedWithTheReason) {
  mesh::SurfaceMesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};  // collinear
  m.triangles = {{0, 1, 2}};
  const auto file = write(dir, "flat.ply", m);
  try {
    prepare_file(file, options(0.01), nullptr);
    FAIL() << "expected an error";
  } catch (const mesh::MeshError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": has no triangles left after cleaning (1 degenerate, 0 duplicate)");
  }
}

TEST_F(Prep, TooShortAnEdgeIsRefusedWithTheReason) {
  const auto file = write(dir, "sphere.ply", sphere());
  try {
    prepare_file(file, options(1e-5), nullptr);
    FAIL() << "expected PrepError";
  } catch (const PrepError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() +
                                         ": an edge of 0.01 mm would give about 7.25e+08 triangles (more than "
                                         "5000000); choose a longer edge");
  }
}

TEST_F(Prep, MissingFileNamesTheFile) {
  const auto file = dir / "missing.obj";
  try {
    prepare_file(file, options(), nullptr);
    FAIL() << "expected MeshError";
  } catch (const mesh::MeshError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": file not found");
  }
}

}  // namespace
}  // namespace palpa::prep
