// The shipped scenarios (data/scenarios/*.json) load with load_scenario, are
// in the canonical layout (load and write give the same bytes), and say what
// the issue asks of them.

#include "scenario/scenario.h"
#include "scenario_fixture.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

namespace palpa::scenario {
namespace {

namespace fs = std::filesystem;

fs::path scenarios_dir() { return test::project_data_dir() / "scenarios"; }

// Loads a shipped scenario (its organ must be in data/ too).
Scenario load_shipped(const char* name) { return load_scenario(scenarios_dir() / name); }

// The organ file a scenario names (empty for "default"), read without validating.
fs::path organ_of(const fs::path& file) {
  const auto doc = test::Json::parse(test::read_file(file));
  const std::string path = doc.at("organ").at("path").get<std::string>();
  return path == "default" ? fs::path() : (file.parent_path() / path).lexically_normal();
}

TEST(ShippedScenarios, AtLeastThreeAndEachLoadsAndIsCanonical) {
  int count = 0;
  for (const auto& e : fs::directory_iterator(scenarios_dir())) {
    const fs::path f = e.path();
    if (f.extension() != ".json" || f.filename() == "scenario.schema.json") continue;
    ++count;
    const fs::path organ = organ_of(f);
    EXPECT_TRUE(organ.empty() || fs::is_regular_file(organ)) << f << " needs " << organ << ", which data/ must hold";
    Scenario s;
    ASSERT_NO_THROW(s = load_scenario(f)) << f;
    EXPECT_EQ(to_json_text(s), test::read_file(f)) << f << ": not in the canonical layout (palpa-scenario format)";
    EXPECT_FALSE(s.task.instructions.empty()) << f;
    EXPECT_GT(s.task.time_limit, 0) << f;
    EXPECT_GT(s.task.force_limit, 0) << f;
    EXPECT_FALSE(summary(s).empty());
  }
  EXPECT_GE(count, 3);
}

TEST(ShippedScenarios, BreastHasTwoHiddenNodulesOfDifferentSizeAndDepth) {
  const Scenario s = load_shipped("breast_two_nodules.json");
  ASSERT_EQ(s.lesions.size(), 2u);
  for (const auto& l : s.lesions) EXPECT_EQ(l.lesion.visibility, tissue::Visibility::Hidden);
  EXPECT_NE(s.lesions[0].lesion.semi_axes, s.lesions[1].lesion.semi_axes);
  EXPECT_NE(s.lesions[0].depth, s.lesions[1].depth);
  EXPECT_EQ(s.tissue_presets, (std::vector<std::string>{"breast_fat", "breast_gland"}));
}

TEST(ShippedScenarios, LiverHasAStiffHiddenTumourOnTheDefaultOrgan) {
  const Scenario s = load_shipped("liver_tumour.json");
  EXPECT_EQ(s.organ.path, "default");
  ASSERT_EQ(s.lesions.size(), 1u);
  EXPECT_EQ(s.lesions[0].lesion.modulus_ratio, 5.0);
  EXPECT_DOUBLE_EQ(s.lesions[0].lesion.semi_axes.x(), 0.010);
  EXPECT_DOUBLE_EQ(s.lesions[0].depth, 0.020);
  EXPECT_EQ(s.lesions[0].lesion.visibility, tissue::Visibility::Hidden);
}

TEST(ShippedScenarios, AbdomenHasAPulsingAortaUnderBreathing) {
  const Scenario s = load_shipped("abdomen_aorta.json");
  ASSERT_EQ(s.pulses.size(), 1u);
  EXPECT_EQ(s.pulses[0].rate_bpm, 72.0);
  EXPECT_DOUBLE_EQ(s.pulses[0].amplitude, 0.0015);
  EXPECT_DOUBLE_EQ(s.pulses[0].radius, 0.015);
  for (const Vec3& p : s.pulses[0].path) EXPECT_DOUBLE_EQ(p.x(), 0.02);
  EXPECT_TRUE(s.breathing.enabled);
  EXPECT_EQ(s.breathing.rate_bpm, 14.0);
  EXPECT_TRUE(s.breathing.translation.isApprox(Vec3(0, 0, 0.008)));
}

}  // namespace
}  // namespace palpa::scenario
