// The scenario file: every validation message exactly (one broken key per
// case), unknown keys, SI inside, the round trip and the atomic save.

#include "mesh/organ.h"
#include "scenario/scenario.h"
#include "scenario_fixture.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <functional>

namespace palpa::scenario {
namespace {

using test::Json;
using test::read_file;
using test::valid_scenario;
using test::write_file;

// Parses the document as "case.json" and returns the error message ("" when it loads).
std::string error_of(const Json& doc) {
  try {
    parse_scenario(doc.dump(2), "case.json");
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "";
}

TEST(ScenarioParse, TheFixtureIsValid) { EXPECT_EQ(error_of(valid_scenario()), ""); }

// Data-driven bad input (Magnum's InvalidNumbersData[]): an edit of the
// valid document and the exact message it must give.
struct BadCase {
  const char* name;
  std::function<void(Json&)> edit;
  std::string message;
};

const std::vector<BadCase>& bad_cases() {
  static const std::vector<BadCase> cases = {
      {"negative radius", [](Json& j) { j["lesions"][1].erase("semi_axes_mm"), j["lesions"][1]["radius_mm"] = -3; },
       "case.json: /lesions/1/radius_mm: expected a positive number of millimetres, got -3"},
      {"unknown lesion key",
       [](Json& j) { j["lesions"][0].erase("radius_mm"), j["lesions"][0]["radius_nm"] = 5; },
       "case.json: /lesions/0/radius_nm: unknown key (expected one of: name, centre_mm, surface_point_mm, depth_mm, "
       "radius_mm, semi_axes_mm, modulus_ratio, visibility)"},
      {"unknown top-level key", [](Json& j) { j["lesion"] = Json::array(); },
       "case.json: /lesion: unknown key (expected one of: version, units, title, description, organ, probe, tissues, "
       "base_tissue, regions, lesions, random_lesions, pulses, breathing, dynamic_regions, task)"},
      {"unknown key in a nested object", [](Json& j) { j["task"]["scoring"]["weights"]["speed"] = 1; },
       "case.json: /task/scoring/weights/speed: unknown key (expected one of: found, size, consistency, force, "
       "coverage)"},
      {"wrong version", [](Json& j) { j["version"] = 2; },
       "case.json: /version: expected 1 (the version this build reads), got 2"},
      {"wrong unit", [](Json& j) { j["units"]["length"] = "cm"; },
       "case.json: /units/length: expected \"mm\", got \"cm\""},
      {"missing unit", [](Json& j) { j["units"].erase("time"); }, "case.json: /units: missing required key \"time\""},
      {"missing organ", [](Json& j) { j.erase("organ"); }, "case.json: missing required key \"organ\""},
      {"missing organ path", [](Json& j) { j["organ"] = Json::object(); },
       "case.json: /organ: missing required key \"path\""},
      {"bad organ unit", [](Json& j) { j["organ"]["unit"] = "inch"; },
       "case.json: /organ/unit: expected one of m, cm, mm, got \"inch\""},
      {"bundled organ in millimetres", [](Json& j) { j["organ"]["unit"] = "mm"; },
       "case.json: /organ/unit: expected \"m\" for the bundled organ (it is in metres), got \"mm\""},
      {"bad sha256", [](Json& j) { j["organ"]["sha256"] = "xyz"; },
       "case.json: /organ/sha256: expected 64 hexadecimal digits, got \"xyz\""},
      {"string for a number", [](Json& j) { j["probe"]["tip_radius_mm"] = "8"; },
       "case.json: /probe/tip_radius_mm: expected a positive number of millimetres, got \"8\""},
      {"bad shape kind", [](Json& j) { j["probe"]["shape"]["kind"] = "cone"; },
       "case.json: /probe/shape/kind: expected one of gaussian, wendland, volume_conserving, got \"cone\""},
      {"no tissues", [](Json& j) { j["tissues"] = Json::array(); },
       "case.json: /tissues: expected a non-empty array of tissues, got []"},
      {"tissue without modulus or preset", [](Json& j) { j["tissues"][0].erase("youngs_modulus_kpa"); },
       "case.json: /tissues/0: missing required key \"youngs_modulus_kpa\" (or \"preset\")"},
      {"negative modulus", [](Json& j) { j["tissues"][0]["youngs_modulus_kpa"] = -1; },
       "case.json: /tissues/0/youngs_modulus_kpa: expected a positive number of kilopascals, got -1"},
      {"poisson 0.5", [](Json& j) { j["tissues"][1]["poisson"] = 0.5; },
       "case.json: /tissues/1/poisson: expected a number in [0, 0.5), got 0.5"},
      {"duplicate tissue", [](Json& j) { j["tissues"][1]["name"] = "fat"; },
       "case.json: /tissues/1/name: duplicate tissue name \"fat\""},
      {"unknown base tissue", [](Json& j) { j["base_tissue"] = "fatt"; },
       "case.json: /base_tissue: unknown tissue \"fatt\" (expected one of: fat, gland)"},
      {"unknown region tissue", [](Json& j) { j["regions"][0]["tissue"] = "bone"; },
       "case.json: /regions/0/tissue: unknown tissue \"bone\" (expected one of: fat, gland)"},
      {"bad region kind", [](Json& j) { j["regions"][0]["kind"] = "cube"; },
       "case.json: /regions/0/kind: expected one of sphere, ellipsoid, box, half_space, geodesic_disk, vertex_array, "
       "planar_image, cylindrical_image, got \"cube\""},
      {"key of another region kind", [](Json& j) { j["regions"][0]["semi_axes_mm"] = {1, 2, 3}; },
       "case.json: /regions/0/semi_axes_mm: unknown key (expected one of: name, kind, centre_mm, radius_mm, "
       "feather_mm, tissue, scale)"},
      {"region with tissue and scale", [](Json& j) { j["regions"][0]["scale"] = 2; },
       "case.json: /regions/0: expected exactly one of \"tissue\" or \"scale\""},
      {"negative feather", [](Json& j) { j["regions"][0]["feather_mm"] = -1; },
       "case.json: /regions/0/feather_mm: expected a number >= 0 of millimetres, got -1"},
      {"box inside out",
       [](Json& j) {
         j["regions"][0] = Json::parse(R"({"name": "core", "kind": "box", "min_mm": [0, 0, 0], "max_mm": [10, -1, 10], "scale": 2})");
       },
       "case.json: /regions/0/max_mm: expected every coordinate above min_mm's, got [10,-1,10]"},
      {"zero normal",
       [](Json& j) {
         j["regions"][0] = Json::parse(R"({"name": "core", "kind": "half_space", "point_mm": [0, 0, 0], "normal": [0, 0, 0], "scale": 2})");
       },
       "case.json: /regions/0/normal: expected a direction (an array of 3 numbers, not all 0), got [0,0,0]"},
      {"centre and surface point", [](Json& j) { j["lesions"][0]["surface_point_mm"] = {0, 0, 1}; },
       "case.json: /lesions/0: expected exactly one of \"centre_mm\" or \"surface_point_mm\""},
      {"surface point without depth", [](Json& j) { j["lesions"][1].erase("depth_mm"); },
       "case.json: /lesions/1: missing required key \"depth_mm\""},
      {"depth with a centre", [](Json& j) { j["lesions"][0]["depth_mm"] = 3; },
       "case.json: /lesions/0/depth_mm: allowed only with \"surface_point_mm\""},
      {"radius and semi-axes", [](Json& j) { j["lesions"][1]["radius_mm"] = 3; },
       "case.json: /lesions/1: expected exactly one of \"radius_mm\" or \"semi_axes_mm\""},
      {"two coordinates", [](Json& j) { j["lesions"][0]["centre_mm"] = {1, 2}; },
       "case.json: /lesions/0/centre_mm: expected an array of 3 numbers of millimetres, got [1,2]"},
      {"zero semi-axis", [](Json& j) { j["lesions"][1]["semi_axes_mm"] = {4, 0, 6}; },
       "case.json: /lesions/1/semi_axes_mm: expected an array of 3 positive numbers of millimetres, got [4,0,6]"},
      {"zero ratio", [](Json& j) { j["lesions"][0]["modulus_ratio"] = 0; },
       "case.json: /lesions/0/modulus_ratio: expected a positive number, got 0"},
      {"bad visibility", [](Json& j) { j["lesions"][0]["visibility"] = "secret"; },
       "case.json: /lesions/0/visibility: expected one of hidden, shown, after_exam, got \"secret\""},
      {"random lesions in an unknown region",
       [](Json& j) { j["random_lesions"] = Json::parse(R"({"count": 2, "region": "lobe"})"); },
       "case.json: /random_lesions/region: unknown region \"lobe\" (expected one of: core)"},
      {"random range upside down",
       [](Json& j) { j["random_lesions"] = Json::parse(R"({"count": 2, "radius_mm": [8, 4]})"); },
       "case.json: /random_lesions/radius_mm: expected [min, max] with min <= max, each a positive number of "
       "millimetres, got [8,4]"},
      {"too many lesions", [](Json& j) { j["random_lesions"] = Json::parse(R"({"count": 31})"); },
       "case.json: /random_lesions/count: expected at most 32 lesions in all, got 33"},
      {"negative count", [](Json& j) { j["random_lesions"] = Json::parse(R"({"count": -1})"); },
       "case.json: /random_lesions/count: expected an integer >= 0, got -1"},
      {"one-point vessel", [](Json& j) { j["pulses"][0]["path_mm"] = Json::parse("[[0, 0, 0]]"); },
       "case.json: /pulses/0/path_mm: expected an array of at least 2 points (each 3 numbers of millimetres), got "
       "[[0,0,0]]"},
      {"bad vessel point", [](Json& j) { j["pulses"][0]["path_mm"][1] = {0, "a", 0}; },
       "case.json: /pulses/0/path_mm/1: expected an array of 3 numbers of millimetres, got [0,\"a\",0]"},
      {"zero pulse rate", [](Json& j) { j["pulses"][0]["rate_bpm"] = 0; },
       "case.json: /pulses/0/rate_bpm: expected a positive number of beats per minute, got 0"},
      {"breathing as a number", [](Json& j) { j["breathing"] = 14; },
       "case.json: /breathing: expected an object, got 14"},
      {"breathing enabled as a string", [](Json& j) { j["breathing"]["enabled"] = "yes"; },
       "case.json: /breathing/enabled: expected true or false, got \"yes\""},
      {"unknown dynamic region", [](Json& j) { j["dynamic_regions"][0]["region"] = "lobe"; },
       "case.json: /dynamic_regions/0/region: unknown region \"lobe\" (expected one of: core)"},
      {"keyframes out of order",
       [](Json& j) { j["dynamic_regions"][0]["keyframes"].push_back(Json::parse(R"({"time_s": 2, "scale": 1})")); },
       "case.json: /dynamic_regions/0/keyframes/1/time_s: expected keyframes in time order (a time >= the previous "
       "keyframe's), got 2"},
      {"missing keyframe scale", [](Json& j) { j["dynamic_regions"][0]["keyframes"][0].erase("scale"); },
       "case.json: /dynamic_regions/0/keyframes/0: missing required key \"scale\""},
      {"pass score over 1", [](Json& j) { j["task"]["scoring"]["pass_score"] = 1.5; },
       "case.json: /task/scoring/pass_score: expected a number in [0, 1], got 1.5"},
      {"weights summing to 0",
       [](Json& j) {
         j["task"]["scoring"]["weights"] = Json::parse(R"({"found": 0, "size": 0, "consistency": 0, "force": 0, "coverage": 0})");
       },
       "case.json: /task/scoring/weights: expected weights with a positive sum, got "
       "{\"found\":0,\"size\":0,\"consistency\":0,\"force\":0,\"coverage\":0}"},
      {"zero force limit", [](Json& j) { j["task"]["force_limit_n"] = 0; },
       "case.json: /task/force_limit_n: expected a positive number of newtons, got 0"},
      {"report field as a number", [](Json& j) { j["task"]["report"] = Json::parse(R"({"size": 1})"); },
       "case.json: /task/report/size: expected true or false, got 1"},
      {"not an object", [](Json& j) { j = Json::array({1}); }, "case.json: expected an object, got [1]"},
      {"key with a slash", [](Json& j) { j["task"]["a/b~c"] = 1; },
       "case.json: /task/a~1b~0c: unknown key (expected one of: instructions, time_limit_s, force_limit_n, report, "
       "scoring)"},
  };
  return cases;
}

TEST(ScenarioParse, EachFaultGivesItsExactMessage) {
  for (const BadCase& c : bad_cases()) {
    Json doc = valid_scenario();
    c.edit(doc);
    EXPECT_EQ(error_of(doc), c.message) << "case: " << c.name;
  }
}

TEST(ScenarioParse, ErrorCarriesFilePointerAndMessage) {
  Json doc = valid_scenario();
  doc["lesions"][0]["modulus_ratio"] = -2;
  try {
    parse_scenario(doc.dump(), "case.json");
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(e.file(), "case.json");
    EXPECT_EQ(e.pointer(), "/lesions/0/modulus_ratio");
    EXPECT_EQ(e.message(), "expected a positive number, got -2");
  }
}

TEST(ScenarioParse, UnknownPresetListsThePresets) {
  Json doc = valid_scenario();
  doc["tissues"][1]["preset"] = "livr";
  std::string keys;
  for (const auto& p : tissue::presets()) keys += (keys.empty() ? "" : ", ") + p.key;
  EXPECT_EQ(error_of(doc), "case.json: /tissues/1/preset: unknown preset \"livr\" (expected one of: " + keys + ")");
}

TEST(ScenarioParse, InvalidJsonGivesLineAndColumn) {
  const std::string text = "{\n  \"version\": 1,\n  \"units\": }\n";
  try {
    parse_scenario(text, "case.json");
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(std::string(e.what()),
              "case.json: invalid JSON at line 3, column 12: syntax error while parsing value - unexpected '}'; "
              "expected '[', '{', or a literal");
  }
}

// Found by fuzz_scenario: a number beyond a double's range made the JSON
// library throw its out_of_range exception, which escaped as a crash.
TEST(ScenarioParse, ANumberBeyondADoubleIsInvalidJson) {
  const std::string text = "{\n \"version\": 11111111111E1111111\n}\n";
  try {
    parse_scenario(text, "case.json");
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(std::string(e.what()),
              "case.json: invalid JSON: number overflow parsing '11111111111E1111111' (a number beyond the range of a double)");
  }
}

// The input fuzz_scenario crashed on, as it found it (fuzz/regressions/scenario/).
TEST(ScenarioParse, TheFuzzersNumberOverflowInputGetsItsMessage) {
  const auto file = std::filesystem::path(PALPA_SOURCE_DIR) / "fuzz/regressions/scenario/number-overflow.json";
  try {
    load_scenario(file);
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() +
                                         ": invalid JSON: number overflow parsing '11111111111E1111111' (a number "
                                         "beyond the range of a double)");
  }
}

TEST(ScenarioParse, DuplicateKeysAreRefusedWithTheirPointer) {
  // The parser would keep one of the two silently; the second one is named.
  std::string text = valid_scenario().dump(2);
  const std::string once = "\"modulus_ratio\": 4,";
  const auto at = text.find(once);
  ASSERT_NE(at, std::string::npos);
  text.insert(at, "\"depth_mm\": 12, ");
  try {
    parse_scenario(text, "case.json");
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(std::string(e.what()),
              "case.json: /lesions/1/depth_mm: duplicate key (each key may appear once in an object)");
  }
  // In an array of arrays too (the index counts finished elements).
  text = valid_scenario().dump();
  const std::string key = "\"amplitude_mm\":1";
  ASSERT_NE(text.find(key), std::string::npos);
  text.replace(text.find(key), key.size(), key + "," + key);
  EXPECT_THROW(
      {
        try {
          parse_scenario(text, "case.json");
        } catch (const ScenarioError& e) {
          EXPECT_EQ(e.pointer(), "/pulses/0/amplitude_mm");
          throw;
        }
      },
      ScenarioError);
}

TEST(ScenarioParse, ValuesAreSiInside) {
  Scenario s = parse_scenario(valid_scenario().dump(), "case.json");
  EXPECT_EQ(s.probe.tip_radius, 8e-3);
  EXPECT_EQ(s.probe.shape.kind, deform::ShapeKind::Gaussian);
  EXPECT_EQ(s.probe.shape.radius, 25e-3);
  ASSERT_EQ(s.tissues.size(), 2u);
  EXPECT_DOUBLE_EQ(s.tissues[0].youngs_modulus, 3200.0);
  EXPECT_DOUBLE_EQ(s.tissues[1].stiffening, 50.0);  // 0.05 / mm = 50 / m
  const tissue::Preset* gland = tissue::find_preset("breast_gland");
  ASSERT_NE(gland, nullptr);
  EXPECT_EQ(s.tissues[1].youngs_modulus, gland->tissue.youngs_modulus);
  EXPECT_EQ(s.tissues[1].source, gland->tissue.source);
  EXPECT_EQ(s.tissue_presets, (std::vector<std::string>{"", "breast_gland"}));
  EXPECT_EQ(s.organ.resolved, mesh::default_organ_path());
  EXPECT_EQ(s.organ.unit, "m");
  ASSERT_EQ(s.lesions.size(), 2u);
  EXPECT_FALSE(s.lesions[0].from_surface);
  EXPECT_TRUE(s.lesions[0].lesion.centre.isApprox(Vec3(0, 0, 0.01)));
  EXPECT_TRUE(s.lesions[0].lesion.semi_axes.isApprox(Vec3::Constant(0.005)));
  EXPECT_EQ(s.lesions[0].lesion.visibility, tissue::Visibility::Hidden);
  EXPECT_TRUE(s.lesions[1].from_surface);
  EXPECT_DOUBLE_EQ(s.lesions[1].depth, 0.01);
  EXPECT_TRUE(s.lesions[1].lesion.semi_axes.isApprox(Vec3(0.004, 0.005, 0.006)));
  EXPECT_EQ(s.lesions[1].lesion.visibility, tissue::Visibility::Shown);
  ASSERT_EQ(s.pulses.size(), 1u);
  EXPECT_DOUBLE_EQ(s.pulses[0].amplitude, 0.001);
  EXPECT_TRUE(s.breathing.enabled);
  EXPECT_TRUE(s.breathing.translation.isApprox(Vec3(0, 0, 0.008)));
  ASSERT_EQ(s.dynamic_regions.size(), 1u);
  EXPECT_TRUE(s.dynamic_regions[0].guarding.enabled);
  EXPECT_EQ(s.dynamic_regions[0].guarding.threshold, 5.0);
  EXPECT_EQ(s.task.time_limit, 120.0);
  EXPECT_EQ(s.task.scoring.weight_found, 1.0);
  EXPECT_EQ(s.task.scoring.weight_size, Scoring{}.weight_size);  // not given: the default
}

// A scenario in a folder with files for every region kind.
struct Folder {
  std::filesystem::path dir = test::temp_dir("scenario");
  std::filesystem::path file = dir / "cases" / "case.json";
  Folder() {
    write_file(dir / "organ.ply", "abc");
    write_file(dir / "maps" / "labels.vtp", "x");
    write_file(dir / "maps" / "stiff.png", "x");
  }
  ~Folder() {
    std::error_code ec;
    std::filesystem::permissions(file.parent_path(), std::filesystem::perms::owner_all, ec);
    std::filesystem::remove_all(dir, ec);
  }
};

Json every_region_kind() {
  Json doc = valid_scenario();
  doc["organ"] = Json::parse(R"({"path": "../organ.ply", "unit": "mm",
    "sha256": "BA7816BF8F01CFEA414140DE5DAE2223B00361A396177A9CB410FF61F20015AD"})");
  doc["regions"] = Json::parse(R"([
    {"name": "core", "kind": "sphere", "centre_mm": [0, 0, 0], "radius_mm": 20, "tissue": "gland"},
    {"name": "egg", "kind": "ellipsoid", "centre_mm": [1, 2, 3], "semi_axes_mm": [10, 20, 30], "feather_mm": 2.5, "scale": 1.5},
    {"name": "block", "kind": "box", "min_mm": [-10, -10, -10], "max_mm": [10, 10, 0.1], "scale": 0.8},
    {"name": "upper", "kind": "half_space", "point_mm": [0, 0, 5], "normal": [0, 0, 1], "tissue": "fat"},
    {"name": "patch", "kind": "geodesic_disk", "centre_mm": [0, 0, 50], "radius_mm": 15, "feather_mm": 3, "scale": 2},
    {"name": "labels", "kind": "vertex_array", "file": "../maps/labels.vtp", "array": "label", "label_tissues": {"1": "gland", "-2": "fat"}},
    {"name": "values", "kind": "vertex_array", "file": "../maps/labels.vtp", "array": "stiffness", "scale_min": 0.5, "scale_max": 3},
    {"name": "plane", "kind": "planar_image", "file": "../maps/stiff.png", "origin_mm": [-50, -50, 0], "u_axis_mm": [100, 0, 0], "v_axis_mm": [0, 100, 0], "scale_min": 1, "scale_max": 4},
    {"name": "wrap", "kind": "cylindrical_image", "file": "../maps/stiff.png", "origin_mm": [0, 0, -40], "axis": [0, 0, 1], "reference": [1, 0, 0], "height_mm": 80, "scale_min": 1, "scale_max": 2}
  ])");
  doc["random_lesions"] = Json::parse(R"({"count": 3, "seed": 42, "radius_mm": [3, 6], "depth_mm": [5, 15], "modulus_ratio": [2, 5], "region": "patch", "visibility": "after_exam"})");
  doc["dynamic_regions"].push_back(Json::parse(R"({"region": "egg", "keyframes": [{"time_s": 0, "scale": 1}, {"time_s": 30, "scale": 3, "ramp_s": 10}]})"));
  doc["breathing"] = Json::parse(R"({"enabled": false, "rate_bpm": 12, "translation_mm": [0, 0, 5], "axis": [0, 0, 2], "centre_mm": [0, 0, 0], "scale": 0.02})");
  return doc;
}

TEST(ScenarioFiles, EveryRegionKindResolvesFilesAndChecksTheHash) {
  Folder f;
  write_file(f.file, every_region_kind().dump(2));
  Scenario s = load_scenario(f.file);
  EXPECT_EQ(s.organ.resolved, (f.dir / "organ.ply").lexically_normal());
  EXPECT_EQ(s.organ.sha256, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  ASSERT_EQ(s.regions.size(), 9u);
  EXPECT_EQ(s.regions[5].file, (f.dir / "maps" / "labels.vtp").lexically_normal());
  EXPECT_TRUE(s.regions[5].file.is_absolute());
  EXPECT_EQ(s.regions[5].label_tissues, (std::map<int, std::string>{{-2, "fat"}, {1, "gland"}}));
  EXPECT_EQ(s.regions[7].kind, tissue::RegionKind::PlanarImage);
  EXPECT_TRUE(s.regions[7].u_axis.isApprox(Vec3(0.1, 0, 0)));
  EXPECT_EQ(s.regions[8].kind, tissue::RegionKind::CylindricalImage);
  EXPECT_DOUBLE_EQ(s.regions[8].height, 0.08);
  EXPECT_DOUBLE_EQ(s.regions[1].feather, 0.0025);
  EXPECT_EQ(s.random_lesions.count, 3u);
  EXPECT_EQ(s.random_lesions.seed, 42u);
  EXPECT_EQ(s.random_lesions.visibility, tissue::Visibility::AfterExam);
  EXPECT_FALSE(s.breathing.enabled);
  EXPECT_TRUE(s.breathing.axis.isApprox(Vec3::UnitZ()));  // normalised
}

TEST(ScenarioFiles, WrongHashNamesBoth) {
  Folder f;
  Json doc = every_region_kind();
  doc["organ"]["sha256"] = std::string(64, '0');
  write_file(f.file, doc.dump(2));
  EXPECT_THROW(
      {
        try {
          load_scenario(f.file);
        } catch (const ScenarioError& e) {
          EXPECT_EQ(std::string(e.what()),
                    f.file.string() + ": /organ/sha256: expected " + std::string(64, '0') +
                        " (the SHA-256 given), got ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad for " +
                        (f.dir / "organ.ply").lexically_normal().string());
          throw;
        }
      },
      ScenarioError);
}

// The message of loading `file`.
std::string load_error(const std::filesystem::path& file) {
  try {
    load_scenario(file);
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "";
}

TEST(ScenarioFiles, MissingFilesAreNamed) {
  Folder f;
  Json doc = every_region_kind();
  doc["organ"] = Json::parse(R"({"path": "../nowhere.ply", "unit": "m"})");
  write_file(f.file, doc.dump(2));
  EXPECT_EQ(load_error(f.file),
            f.file.string() + ": /organ/path: file not found: " + (f.dir / "nowhere.ply").lexically_normal().string());
  doc = every_region_kind();
  doc["regions"][7]["file"] = "stiff.png";
  write_file(f.file, doc.dump(2));
  EXPECT_EQ(load_error(f.file), f.file.string() + ": /regions/7/file: file not found: " +
                                    (f.dir / "cases" / "stiff.png").lexically_normal().string());
  doc["regions"][7]["file"] = "../maps";
  write_file(f.file, doc.dump(2));
  EXPECT_EQ(load_error(f.file), f.file.string() + ": /regions/7/file: not a regular file: " +
                                    (f.dir / "maps").lexically_normal().string());
  EXPECT_EQ(load_error(f.dir / "absent.json"), (f.dir / "absent.json").string() + ": cannot open: no such file");
}

TEST(ScenarioFiles, RefusesADirectoryAndAFileOver16MiB) {
  Folder f;
  EXPECT_EQ(load_error(f.dir / "maps"), (f.dir / "maps").string() + ": not a regular file");
  const auto big = f.dir / "big.json";
  {
    std::ofstream out(big, std::ios::binary);
    out << "{}";
    out.seekp(static_cast<std::streamoff>(kMaxScenarioBytes));
    out << ' ';
  }
  EXPECT_EQ(load_error(big), big.string() + ": file is 16777217 bytes, over the limit of 16 MiB (16777216 bytes)");
}

TEST(ScenarioRoundTrip, LoadSaveLoadIsByteIdenticalAndEqual) {
  Folder f;
  write_file(f.file, every_region_kind().dump(2));
  const Scenario first = load_scenario(f.file);
  save_scenario(first, f.file);
  const std::string saved = read_file(f.file);
  const Scenario second = load_scenario(f.file);
  EXPECT_EQ(second, first);
  save_scenario(second, f.file);
  EXPECT_EQ(read_file(f.file), saved);
  EXPECT_EQ(to_json_text(second), saved);
  // The written form keeps the preset and only what overrides it.
  EXPECT_NE(saved.find("\"preset\": \"breast_gland\",\n      \"stiffening_per_mm\": 0.05\n"), std::string::npos)
      << saved;
  EXPECT_NE(saved.find("\"path\": \"../organ.ply\""), std::string::npos);
}

TEST(ScenarioRoundTrip, SavingElsewhereRewritesRelativePaths) {
  Folder f;
  write_file(f.file, every_region_kind().dump(2));
  const Scenario s = load_scenario(f.file);
  const auto moved = f.dir / "deeper" / "still" / "moved.json";
  std::filesystem::create_directories(moved.parent_path());
  save_scenario(s, moved);
  const std::string text = read_file(moved);
  EXPECT_NE(text.find("\"path\": \"../../organ.ply\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"file\": \"../../maps/stiff.png\""), std::string::npos) << text;
  Scenario back = load_scenario(moved);
  EXPECT_EQ(back.organ.resolved, s.organ.resolved);
  EXPECT_EQ(back.regions, s.regions);
  back.file = s.file;
  back.organ.path = s.organ.path;
  EXPECT_EQ(back, s);
}

TEST(ScenarioSave, AFailedSaveLeavesTheOldFile) {
  Folder f;
  write_file(f.file, every_region_kind().dump(2));
  const Scenario s = load_scenario(f.file);
  const std::string before = read_file(f.file);
  Scenario changed = s;
  changed.title = "changed";
  // A directory where the temporary file goes: creating it fails.
  const auto tmp = std::filesystem::path(f.file.string() + ".tmp");
  std::filesystem::create_directory(tmp);
  try {
    save_scenario(changed, f.file);
    FAIL() << "the save did not fail";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(e.file(), f.file.string());
    EXPECT_EQ(std::string(e.what()), f.file.string() + ": cannot save (creating " + tmp.string() +
                                         "): Is a directory; the previous file is unchanged");
  }
  EXPECT_EQ(read_file(f.file), before);
  EXPECT_TRUE(std::filesystem::is_directory(tmp));  // not ours to remove
  std::filesystem::remove(tmp);

  // A read-only folder (meaningful only when not root: root writes anyway).
  if (::geteuid() != 0) {
    std::filesystem::permissions(f.file.parent_path(),
                                 std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec);
    EXPECT_THROW(save_scenario(changed, f.file), ScenarioError);
    std::filesystem::permissions(f.file.parent_path(), std::filesystem::perms::owner_all);
    EXPECT_EQ(read_file(f.file), before);
  }
  // And the same save succeeds once the way is clear, leaving no temporary.
  save_scenario(changed, f.file);
  EXPECT_EQ(load_scenario(f.file).title, "changed");
  EXPECT_FALSE(std::filesystem::exists(tmp));
}

TEST(ScenarioSave, ARenameOntoADirectoryFailsAndRemovesTheTemporary) {
  Folder f;
  write_file(f.file, every_region_kind().dump(2));
  const Scenario s = load_scenario(f.file);
  const auto target = f.file.parent_path() / "occupied.json";
  std::filesystem::create_directories(target / "inside");  // a non-empty directory: rename fails
  EXPECT_THROW(save_scenario(s, target), ScenarioError);
  EXPECT_FALSE(std::filesystem::exists(target.string() + ".tmp"));
  EXPECT_TRUE(std::filesystem::is_directory(target / "inside"));
}

TEST(ScenarioSummary, NamesEverySection) {
  Folder f;
  write_file(f.file, every_region_kind().dump(2));
  const std::string text = summary(load_scenario(f.file));
  for (const char* part : {"test case (scenario version 1)", "organ: ../organ.ply (mm)", "SHA-256 checked",
                           "probe: tip radius 8 mm, gaussian shape function, support radius 25 mm",
                           "gland: E 3.2 kPa, nu 0.49, stiffening 0.05/mm, preset breast_gland",
                           "regions (9), combined in this order:", "egg: ellipsoid, modulus x1.5",
                           "b: semi-axes (4, 5, 6) mm, centre 10 mm below the surface near (0, 0, 50) mm",
                           "random lesions: 3 (seed 42)", "vessel: 2-point path, radius 10 mm, 70 bpm, amplitude 1 mm",
                           "breathing: off", "core: 1 keyframes, guarding above 5 N",
                           "task: time limit 120 s, force limit 8 N; reports position, size, consistency"})
    EXPECT_NE(text.find(part), std::string::npos) << "missing: " << part << "\n" << text;
}

}  // namespace
}  // namespace palpa::scenario
