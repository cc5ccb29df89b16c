// The tissue presets (data/tissues.json): the file loads, every preset names
// its source, and the values are the ones MATERIALS.md gives (kPa to Pa;
// MRE's shear modulus to Young's, E = 3 G).

#include "mesh/organ.h"
#include "scenario_fixture.h"
#include "common/test_support.h"
#include "tissue/tissue.h"

#include <gtest/gtest.h>

namespace palpa::tissue {
namespace {

TEST(TissuePresets, LoadAndEveryPresetNamesItsSource) {
  const auto& list = presets();
  ASSERT_GE(list.size(), 10u);
  for (const Preset& p : list) {
    EXPECT_FALSE(p.key.empty());
    EXPECT_FALSE(p.tissue.name.empty()) << p.key;
    EXPECT_GE(p.tissue.source.size(), 20u) << p.key << ": a source names a publication";
    EXPECT_NO_THROW(validate_tissue(p.tissue, p.key));
  }
}

TEST(TissuePresets, ValuesFromThePublishedSources) {
  struct Expect {
    const char* key;
    double kpa;
    const char* source_part;
  };
  for (const Expect& e : {Expect{"liver", 4.1, "Fung"}, Expect{"liver_mre", 3 * 2.09, "jmri.24084"},
                          Expect{"breast_fat", 3.2, "Samani"}, Expect{"breast_gland", 3.2, "Samani"},
                          Expect{"breast_fibroadenoma", 2 * 3.2, "Samani"}, Expect{"breast_carcinoma", 4.5 * 3.2, "Samani"},
                          Expect{"skin", 56.3, "aspiration"}, Expect{"prostate", 17.0, "Ahn"},
                          Expect{"prostate_cancer", 24.1, "Ahn"}, Expect{"brain_grey", 1.39, "Budday"},
                          Expect{"brain_white", 1.90, "Budday"}}) {
    const Preset* p = find_preset(e.key);
    ASSERT_NE(p, nullptr) << e.key;
    EXPECT_NEAR(p->tissue.youngs_modulus, e.kpa * 1e3, 1e-9 * e.kpa * 1e3) << e.key;
    EXPECT_EQ(p->tissue.poisson, 0.49) << e.key;
    EXPECT_NE(p->tissue.source.find(e.source_part), std::string::npos) << e.key << ": " << p->tissue.source;
  }
  EXPECT_EQ(find_preset("no such tissue"), nullptr);
}

// A broken presets file names the file, the pointer and the fault.
TEST(TissuePresets, BadFileNamesTheFault) {
  const auto dir = test::temp_dir("presets");
  const auto file = dir / "tissues.json";
  auto error_of = [&](const std::string& text) {
    test::write_file(file, text);
    try {
      load_presets(file);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string head = R"({"version": 1, "units": {"modulus": "kPa"}, "presets": [)";
  EXPECT_EQ(error_of(head + R"({"key": "a", "name": "A", "youngs_modulus_kpa": 3}]})"),
            file.string() + ": /presets/0/source: expected a non-empty string, got nothing");
  EXPECT_EQ(error_of(head + R"({"key": "a", "name": "A", "youngs_modulus_kpa": 3, "source": "x", "colour": 1}]})"),
            file.string() + ": /presets/0/colour: unknown key (expected one of: key, name, youngs_modulus_kpa, poisson, "
                            "damping_ratio, relaxation_time_s, relaxation_fraction, stiffening_per_mm, source, note)");
  EXPECT_EQ(error_of(R"({"version": 1, "units": {"modulus": "Pa"}, "presets": []})"),
            file.string() + ": /units: expected {\"modulus\":\"kPa\"}, got {\"modulus\":\"Pa\"}");
  EXPECT_EQ(error_of(head + R"({"key": "a", "name": "A", "youngs_modulus_kpa": -3, "source": "x"}]})").rfind(
                file.string() + ": /presets/0: preset \"a\": ", 0),
            0u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace palpa::tissue
