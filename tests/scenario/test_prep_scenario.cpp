// The organ's "prep" object (docs/SCENARIO.md, docs/PREP.md): read with the
// reader's checks (exact messages), written canonically (load-save-load gives
// the same text), and a resolved scenario runs on the prepared mesh, the
// second time from the cache.

#include "mesh/generate.h"
#include "mesh/io.h"
#include "scenario/resolve.h"
#include "scenario/scenario.h"
#include "scenario_fixture.h"
#include "common/test_support.h"

#if PALPA_TEST_HAVE_PREP
#include "prep/prep.h"
#endif

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <functional>

namespace palpa::scenario {
namespace {

using test::Json;
using test::read_file;
using test::valid_scenario;
using test::write_file;

std::string error_of(const Json& doc) {
  try {
    parse_scenario(doc.dump(2), "case.json");
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "";
}

Json with_prep(const char* prep) {
  Json doc = valid_scenario();
  doc["organ"]["prep"] = Json::parse(prep);
  return doc;
}

TEST(ScenarioPrep, ReadsTheEdgeOrTheProbeRadiusInSi) {
  const Scenario a = parse_scenario(with_prep(R"({"edge_mm": 2.5})").dump(), "case.json");
  ASSERT_TRUE(a.organ.prep.has_value());
  EXPECT_DOUBLE_EQ(a.organ.prep->edge, 0.0025);
  EXPECT_EQ(a.organ.prep->probe_radius, 0);
  EXPECT_EQ(a.organ.prep->fit_rounds, PrepSpec{}.fit_rounds);

  const Scenario b = parse_scenario(
      with_prep(R"({"probe_radius_mm": 8, "fit_rounds": 0, "autorefine": false, "fit_max_triangles": 2000})").dump(),
      "case.json");
  ASSERT_TRUE(b.organ.prep.has_value());
  EXPECT_EQ(b.organ.prep->edge, 0);
  EXPECT_DOUBLE_EQ(b.organ.prep->probe_radius, 0.008);
  EXPECT_EQ(b.organ.prep->fit_rounds, 0);
  EXPECT_FALSE(b.organ.prep->autorefine);
  EXPECT_EQ(b.organ.prep->fit_max_triangles, 2000u);

  const Scenario none = parse_scenario(valid_scenario().dump(), "case.json");
  EXPECT_FALSE(none.organ.prep.has_value());
  EXPECT_EQ(to_json_text(none).find("\"prep\""), std::string::npos);
}

TEST(ScenarioPrep, SaveLoadSaveGivesTheSameTextWithEveryParameter) {
  for (const char* prep : {R"({"edge_mm": 2})", R"({"probe_radius_mm": 7.5, "feature_angle_deg": 45.5,
                                                     "fit_factor": 0.8, "relaxation_steps": 0, "local_repair": false})"}) {
    const Scenario first = parse_scenario(with_prep(prep).dump(), "case.json");
    const std::string text = to_json_text(first);
    const Scenario second = parse_scenario(text, "case.json");
    EXPECT_EQ(second, first) << prep;
    EXPECT_EQ(to_json_text(second), text) << prep;
    // Every parameter that defines the mesh is written, so the file alone rebuilds it.
    for (const char* key : {"speck_area_fraction", "max_hole_area_fraction", "autorefine", "local_repair",
                            "remesh_iterations", "relaxation_steps", "feature_angle_deg", "refine_rounds", "fit_rounds",
                            "fit_factor", "fit_max_triangles"})
      EXPECT_NE(text.find(std::string("\"") + key + "\""), std::string::npos) << key << " in\n" << text;
  }
  // The smallest lesion goes with the probe radius, and is written only when set.
  const Scenario lesion = parse_scenario(with_prep(R"({"probe_radius_mm": 8, "lesion_radius_mm": 3})").dump(), "case.json");
  EXPECT_DOUBLE_EQ(lesion.organ.prep->lesion_radius, 0.003);
  EXPECT_NE(to_json_text(lesion).find("\"probe_radius_mm\": 8,\n      \"lesion_radius_mm\": 3,"), std::string::npos)
      << to_json_text(lesion);
  EXPECT_EQ(parse_scenario(to_json_text(lesion), "case.json"), lesion);
  const std::string text = to_json_text(parse_scenario(with_prep(R"({"edge_mm": 2})").dump(), "case.json"));
  EXPECT_NE(text.find("\"prep\": {\n      \"edge_mm\": 2,\n      \"speck_area_fraction\": 0.01,"), std::string::npos)
      << text;
  EXPECT_EQ(text.find("probe_radius_mm"), std::string::npos);
  EXPECT_EQ(text.find("lesion_radius_mm"), std::string::npos);
}

// The smallest lesion of a scenario: the smallest semi-axis of its lesions
// and the random lesions' smallest radius.
TEST(ScenarioPrep, TheSmallestLesionRadiusIsTheSmallestSemiAxisOrRandomRadius) {
  Scenario s = parse_scenario(valid_scenario().dump(), "case.json");
  s.lesions.clear();
  s.random_lesions.count = 0;
  EXPECT_EQ(smallest_lesion_radius(s), 0.0);
  LesionSpec a;
  a.lesion.semi_axes = Vec3(0.006, 0.004, 0.005);
  LesionSpec b;
  b.lesion.semi_axes = Vec3::Constant(0.0045);
  s.lesions = {a, b};
  EXPECT_DOUBLE_EQ(smallest_lesion_radius(s), 0.004);
  s.random_lesions.count = 2;
  s.random_lesions.radius_min = 0.003;
  EXPECT_DOUBLE_EQ(smallest_lesion_radius(s), 0.003);
}

TEST(ScenarioPrep, EachBadValueGivesItsExactMessage) {
  const std::pair<const char*, std::string> cases[] = {
      {R"(2)", "case.json: /organ/prep: expected an object, got 2"},
      {R"({})", "case.json: /organ/prep: missing required key \"edge_mm\" (or \"probe_radius_mm\")"},
      {R"({"edge_mm": 2, "probe_radius_mm": 8})",
       "case.json: /organ/prep: expected \"edge_mm\" or \"probe_radius_mm\", not both"},
      {R"({"edge_mm": 0})", "case.json: /organ/prep/edge_mm: expected a length from 0.1 to 100 millimetres, got 0"},
      {R"({"edge_mm": 250})", "case.json: /organ/prep/edge_mm: expected a length from 0.1 to 100 millimetres, got 250"},
      {R"({"edge_mm": "2"})",
       "case.json: /organ/prep/edge_mm: expected a length from 0.1 to 100 millimetres, got \"2\""},
      {R"({"probe_radius_mm": -8})",
       "case.json: /organ/prep/probe_radius_mm: expected a positive length up to 100 millimetres, got -8"},
      {R"({"edge_mm": 2, "remesh_iterations": 2.5})",
       "case.json: /organ/prep/remesh_iterations: expected an integer from 1 to 50, got 2.5"},
      {R"({"edge_mm": 2, "remesh_iterations": 0})",
       "case.json: /organ/prep/remesh_iterations: expected an integer from 1 to 50, got 0"},
      {R"({"edge_mm": 2, "fit_factor": 1})", "case.json: /organ/prep/fit_factor: expected a factor in (0, 1), got 1"},
      {R"({"edge_mm": 2, "speck_area_fraction": 1})",
       "case.json: /organ/prep/speck_area_fraction: expected a fraction in [0, 1), got 1"},
      {R"({"edge_mm": 2, "feature_angle_deg": 180})",
       "case.json: /organ/prep/feature_angle_deg: expected an angle in [0, 180) degrees (0: no creases), got 180"},
      {R"({"edge_mm": 2, "fit_max_triangles": 10})",
       "case.json: /organ/prep/fit_max_triangles: expected an integer from 1000 to 5000000, got 10"},
      {R"({"edge_mm": 2, "autorefine": "yes"})", "case.json: /organ/prep/autorefine: expected true or false, got \"yes\""},
      {R"({"edge_mm": 2, "lesion_radius_mm": 3})",
       "case.json: /organ/prep: \"lesion_radius_mm\" chooses the edge with \"probe_radius_mm\"; with \"edge_mm\" the "
       "edge is given"},
      {R"({"probe_radius_mm": 8, "lesion_radius_mm": 0})",
       "case.json: /organ/prep/lesion_radius_mm: expected a positive length up to 100 millimetres, got 0"},
      {R"({"edge": 2})",
       "case.json: /organ/prep/edge: unknown key (expected one of: edge_mm, probe_radius_mm, lesion_radius_mm, "
       "speck_area_fraction, "
       "max_hole_area_fraction, autorefine, local_repair, remesh_iterations, relaxation_steps, feature_angle_deg, "
       "refine_rounds, fit_rounds, fit_factor, fit_max_triangles)"},
  };
  for (const auto& [prep, message] : cases) EXPECT_EQ(error_of(with_prep(prep)), message) << prep;

  Json doc = valid_scenario();
  doc["organ"]["preparation"] = Json::object();
  EXPECT_EQ(error_of(doc), "case.json: /organ/preparation: unknown key (expected one of: path, unit, sha256, prep)");
}

TEST(ScenarioPrep, TheSpecCheckGivesTheReadersMessages) {
  PrepSpec p;
  EXPECT_EQ(prep_spec_error(p), "missing required key \"edge_mm\" (or \"probe_radius_mm\")");
  p.edge = 0.002;
  EXPECT_EQ(prep_spec_error(p), "");
  p.edge = -0.001;
  EXPECT_EQ(prep_spec_error(p), "edge_mm: expected a length from 0.1 to 100 millimetres, got -1");
  p.edge = 0.002;
  p.probe_radius = 0.008;
  EXPECT_EQ(prep_spec_error(p), "expected \"edge_mm\" or \"probe_radius_mm\", not both");
  p.edge = 0;
  p.fit_rounds = 11;
  EXPECT_EQ(prep_spec_error(p), "fit_rounds: expected an integer from 0 to 10, got 11");
}

TEST(ScenarioPrep, AsWrittenIsWhatALoadedFileHolds) {
  PrepSpec p;
  p.edge = 2.3456789012345678 * 1e-3;
  p.fit_factor = 0.1 + 0.2;
  Json doc = valid_scenario();
  Scenario s = parse_scenario(doc.dump(), "case.json");
  s.organ.prep = p;
  const Scenario back = parse_scenario(to_json_text(s), "case.json");
  ASSERT_TRUE(back.organ.prep.has_value());
  EXPECT_EQ(*back.organ.prep, as_written(p));
  EXPECT_EQ(as_written(as_written(p)), as_written(p));
}

#if PALPA_TEST_HAVE_PREP
// The scenario's defaults are prep's: a file that leaves a key out prepares
// what palpa-prep does with the same edge.
TEST(ScenarioPrep, DefaultsArePrepsDefaults) {
  const PrepSpec s;
  const prep::PrepOptions o;
  EXPECT_EQ(s.speck_area_fraction, o.speck_area_fraction);
  EXPECT_EQ(s.max_hole_area_fraction, o.max_hole_area_fraction);
  EXPECT_EQ(s.autorefine, o.allow_autorefine);
  EXPECT_EQ(s.local_repair, o.allow_local_repair);
  EXPECT_EQ(s.remesh_iterations, o.remesh_iterations);
  EXPECT_EQ(s.relaxation_steps, o.relaxation_steps);
  EXPECT_EQ(s.feature_angle_deg, o.feature_angle_deg);
  EXPECT_EQ(s.lesion_radius, o.lesion_radius_m);
  EXPECT_EQ(s.refine_rounds, o.refine_rounds);
  EXPECT_EQ(s.fit_rounds, o.fit_rounds);
  EXPECT_EQ(s.fit_factor, o.fit_factor);
  EXPECT_EQ(s.fit_max_triangles, o.fit_max_triangles);
}

// A small organ file (a 1500-vertex sphere of radius 40 mm, in m) and a
// private prep cache.
struct PrepFolder {
  std::filesystem::path dir = test::temp_dir("scenario_prep");
  std::filesystem::path organ = dir / "sphere.ply";
  std::filesystem::path cache = dir / "cache";
  PrepFolder() {
    std::filesystem::create_directories(dir);
    mesh::save_mesh(mesh::make_sphere(1500, 0.04), organ);
    ::setenv("PALPA_PREP_CACHE", cache.c_str(), 1);
  }
  ~PrepFolder() {
    ::unsetenv("PALPA_PREP_CACHE");
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
};

Scenario sphere_scenario(const PrepFolder& f, const char* prep) {
  Json doc = valid_scenario();
  doc["organ"] = Json::parse(std::string(R"({"path": "sphere.ply", "unit": "m", "prep": )") + prep + "}");
  return parse_scenario(doc.dump(), f.dir / "case.json");
}

TEST(ScenarioPrep, AResolvedScenarioRunsOnThePreparedMeshAndTheSecondOpenUsesTheCache) {
  PrepFolder f;
  const Scenario s = sphere_scenario(f, R"({"edge_mm": 6, "fit_rounds": 0})");
  const mesh::Organ raw = mesh::load_organ(f.organ, mesh::MeshUnit::Metre);

  const Resolved first = resolve(s);
  const mesh::SurfaceMesh& m = *first.organ.mesh;
  EXPECT_NE(m.vertex_count(), raw.mesh->vertex_count());
  EXPECT_TRUE(first.organ.facts.closed()) << first.organ.note;
  // The mean edge near the 6 mm asked for (the remeshing's tolerance).
  double sum = 0;
  std::size_t n = 0;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k, ++n) sum += (m.positions[t[k]] - m.positions[t[(k + 1) % 3]]).norm();
  EXPECT_NEAR(sum / static_cast<double>(n), 0.006, 0.0012);
  EXPECT_NE(first.organ.note.find("prepared: "), std::string::npos) << first.organ.note;
  EXPECT_EQ(first.organ.note.find("from the cache"), std::string::npos) << first.organ.note;
  // Everything placed on it: one tissue entry per prepared vertex.
  EXPECT_EQ(first.materials->tissue_of.size(), m.vertex_count());
  EXPECT_EQ(first.lesions.size(), 2u);

  // The second open loads the same mesh from the cache.
  const Resolved second = resolve(s);
  EXPECT_NE(second.organ.note.find("from the cache"), std::string::npos) << second.organ.note;
  ASSERT_EQ(second.organ.mesh->vertex_count(), m.vertex_count());
  EXPECT_EQ(second.organ.mesh->positions, m.positions);
  EXPECT_EQ(second.organ.mesh->triangles, m.triangles);

  // Another edge is another mesh.
  const Resolved coarse = resolve(sphere_scenario(f, R"({"edge_mm": 10, "fit_rounds": 0})"));
  EXPECT_LT(coarse.organ.mesh->vertex_count(), m.vertex_count());
}

TEST(ScenarioPrep, AnOrganThatCannotBeClosedNamesTheFileAndThePrepObject) {
  PrepFolder f;
  mesh::save_mesh(mesh::make_plane(6, 6, 0.01), f.dir / "sheet.ply");
  Json doc = valid_scenario();
  doc["organ"] = Json::parse(R"({"path": "sheet.ply", "unit": "m", "prep": {"edge_mm": 5}})");
  const Scenario s = parse_scenario(doc.dump(), f.dir / "case.json");
  try {
    resolve(s);
    FAIL() << "an open sheet was prepared";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(e.pointer(), "/organ/prep");
    EXPECT_NE(e.message().find("sheet.ply: cannot make a closed surface"), std::string::npos) << e.what();
  }
}

TEST(ScenarioPrep, ACancelledPreparationThrowsPrepCancelled) {
  PrepFolder f;
  const Scenario s = sphere_scenario(f, R"({"edge_mm": 6, "fit_rounds": 0})");
  std::atomic<bool> cancel{true};
  PrepHooks hooks;
  hooks.cancel = &cancel;
  EXPECT_THROW(load_scenario_organ(s.organ, "case.json", hooks), PrepCancelled);
}
#endif

}  // namespace
}  // namespace palpa::scenario
