#pragma once
// A valid scenario document that uses every section, for the scenario tests
// to break one key at a time.

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

namespace palpa::test {

using Json = nlohmann::ordered_json;

/// A valid scenario on the bundled organ ("default"), no files needed.
inline Json valid_scenario() {
  return Json::parse(R"({
  "version": 1,
  "units": {"length": "mm", "modulus": "kPa", "force": "N", "time": "s"},
  "title": "test case",
  "organ": {"path": "default"},
  "probe": {"tip_radius_mm": 8, "shape": {"kind": "gaussian", "radius_mm": 25}},
  "tissues": [
    {"name": "fat", "youngs_modulus_kpa": 3.2},
    {"name": "gland", "preset": "breast_gland", "stiffening_per_mm": 0.05}
  ],
  "base_tissue": "fat",
  "regions": [
    {"name": "core", "kind": "sphere", "centre_mm": [0, 0, 0], "radius_mm": 20, "tissue": "gland"}
  ],
  "lesions": [
    {"name": "a", "centre_mm": [0, 0, 10], "radius_mm": 5, "modulus_ratio": 3},
    {"name": "b", "surface_point_mm": [0, 0, 50], "depth_mm": 10, "semi_axes_mm": [4, 5, 6], "modulus_ratio": 4, "visibility": "shown"}
  ],
  "pulses": [
    {"name": "vessel", "path_mm": [[0, 0, 0], [0, 10, 0]], "radius_mm": 10, "rate_bpm": 70, "amplitude_mm": 1}
  ],
  "breathing": {"rate_bpm": 15, "translation_mm": [0, 0, 8]},
  "dynamic_regions": [
    {"region": "core", "keyframes": [{"time_s": 5, "scale": 2}], "guarding": {"threshold_n": 5}}
  ],
  "task": {"instructions": "find it", "time_limit_s": 120, "force_limit_n": 8,
           "scoring": {"pass_score": 0.7, "weights": {"found": 1}}}
})");
}

inline void write_file(const std::filesystem::path& p, const std::string& text) {
  std::filesystem::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

inline std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace palpa::test
