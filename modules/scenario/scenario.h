#pragma once
// The scenario file: one palpation case as an educator writes it down
// (docs/SCENARIO.md). A versioned JSON file with its units stated once
// (mm, kPa, N, s); SI inside the program. Unknown keys are refused; every
// error names the file and the JSON pointer of the fault, e.g.
//   case.json: /lesions/1/radius_mm: expected a positive number of millimetres, got -3

#include "core/types.h"
#include "deform/shape_function.h"
#include "tissue/field.h"
#include "tissue/lesion.h"
#include "tissue/regions.h"
#include "tissue/tissue.h"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace palpa::scenario {

/// The one version this build reads and writes.
inline constexpr int kScenarioVersion = 1;

/// A fault in a scenario file: what() is "<file>: <pointer>: <message>".
class ScenarioError : public std::runtime_error {
 public:
  ScenarioError(const std::string& file, const std::string& pointer, const std::string& message);
  const std::string& file() const { return file_; }
  const std::string& pointer() const { return pointer_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_, pointer_, message_;
};

/// How the organ file is prepared before use (modules/prep, docs/PREP.md):
/// every parameter of prep::PrepOptions that changes the prepared mesh, so
/// a session rebuilds the same mesh (through prep's cache: the second time
/// it is loaded, not prepared). The defaults are prep::PrepOptions' own.
/// Lengths in m. Exactly one of edge and probe_radius is set (> 0).
struct PrepSpec {
  double edge = 0;                    ///< target edge length, m (0: from probe_radius)
  double probe_radius = 0;            ///< m: the edge is prep::target_edge_for(it, the organ's diagonal, lesion_radius)
  double lesion_radius = 0;           ///< m, with probe_radius only: the smallest lesion to resolve (0: none)
  double speck_area_fraction = 0.01;  ///< components below this fraction of the largest one's area go
  double max_hole_area_fraction = 0.2;///< a hole patch larger than this fraction of the surface: refused
  bool autorefine = true;             ///< self-intersection repairs tried before the alpha wrap
  bool local_repair = true;
  int remesh_iterations = 5;
  int relaxation_steps = 3;
  double feature_angle_deg = 60;      ///< creases sharper than this pinned, degrees (0: none)
  int refine_rounds = 0;
  int fit_rounds = 3;
  double fit_factor = 0.75;
  std::uint64_t fit_max_triangles = 400'000;
  friend bool operator==(const PrepSpec&, const PrepSpec&) = default;
};

/// Bounds of PrepSpec's lengths the reader accepts, m.
inline constexpr double kMinPrepEdge = 1e-4;          ///< 0.1 mm
inline constexpr double kMaxPrepEdge = 0.1;           ///< 100 mm
inline constexpr double kMaxPrepProbeRadius = 0.1;    ///< 100 mm

/// What is wrong with a PrepSpec, as "<key>: <message>" with the file's key
/// (e.g. "edge_mm: expected a length from 0.1 to 100 millimetres, got 0");
/// empty when it is good. The reader gives the same message under /organ/prep.
std::string prep_spec_error(const PrepSpec& p);
/// The values as a file holds them (file units, 12 significant digits, read
/// back to SI): what a scenario saved and loaded again has, so the same
/// spec before and after saving prepares (and caches) the same mesh.
PrepSpec as_written(const PrepSpec& p);

struct OrganRef {
  std::string path;                 ///< as written, relative to the scenario file ("default" = the bundled organ)
  std::filesystem::path resolved;   ///< absolute (set by the reader)
  std::string unit = "mm";          ///< the mesh file's unit: m, cm, mm
  std::string sha256;               ///< of the mesh file's bytes (hex; empty: not checked)
  std::optional<PrepSpec> prep;     ///< prepared before use (empty: used as the file is)
  friend bool operator==(const OrganRef&, const OrganRef&) = default;
};

struct ProbeSpec {
  double tip_radius = tissue::kDefaultTipRadius;  ///< m
  deform::ShapeFunction shape;                    ///< kind and support radius (m)
  friend bool operator==(const ProbeSpec& a, const ProbeSpec& b) {
    return a.tip_radius == b.tip_radius && a.shape.kind == b.shape.kind && a.shape.radius == b.shape.radius;
  }
};

/// A lesion as written: either a centre, or a surface point and a depth
/// (of the lesion's centre, m) along the inward normal there.
struct LesionSpec {
  tissue::Lesion lesion;            ///< centre used when !from_surface
  bool from_surface = false;
  Vec3 surface_point = Vec3::Zero();  ///< m, organ frame (the nearest surface point is used)
  double depth = 0;                   ///< m, of the centre below that point
  friend bool operator==(const LesionSpec&, const LesionSpec&) = default;
};

/// Seeded random lesions: `count` lesions with radius, centre depth and
/// modulus ratio drawn uniformly from the ranges, placed below surface
/// points of `region` (a region's name; empty: anywhere on the organ).
struct RandomLesions {
  std::uint32_t count = 0;
  std::uint64_t seed = 1;
  double radius_min = 0.004, radius_max = 0.008;   ///< m
  double depth_min = 0.008, depth_max = 0.02;      ///< m, of the centre
  double ratio_min = 3, ratio_max = 6;             ///< dimensionless
  std::string region;
  tissue::Visibility visibility = tissue::Visibility::Hidden;
  friend bool operator==(const RandomLesions&, const RandomLesions&) = default;
};

/// What the trainee reports about each lesion found.
struct ReportFields {
  bool position = true;
  bool size = true;
  bool consistency = true;
  friend bool operator==(const ReportFields&, const ReportFields&) = default;
};

/// Scoring settings the assessment uses.
struct Scoring {
  double position_tolerance = 0.01;  ///< m: a reported lesion within this distance counts as found
  double size_tolerance = 0.5;       ///< fraction of the true diameter
  double pass_score = 0.7;           ///< 0..1
  double weight_found = 0.5;         ///< weights of the parts of the score (sum > 0)
  double weight_size = 0.15;
  double weight_consistency = 0.1;
  double weight_force = 0.15;        ///< staying under the force limit
  double weight_coverage = 0.1;      ///< of the organ surface palpated
  friend bool operator==(const Scoring&, const Scoring&) = default;
};

struct Task {
  std::string instructions;
  double time_limit = 300;   ///< s (0: none)
  ReportFields report;
  double force_limit = 8.0;  ///< N: above this the trainee pressed too hard
  Scoring scoring;
  friend bool operator==(const Task&, const Task&) = default;
};

struct Scenario {
  int version = kScenarioVersion;
  std::string title;
  std::string description;
  OrganRef organ;
  ProbeSpec probe;
  std::vector<tissue::Tissue> tissues;   ///< named; presets resolved to values
  /// Per tissue (same length as tissues, or empty: none): the preset key it
  /// was made from ("" for none). Saved as "preset" plus only the values
  /// that differ from the preset, so a file keeps saying where its numbers came from.
  std::vector<std::string> tissue_presets;
  std::string base_tissue;               ///< a name in tissues
  std::vector<tissue::Region> regions;   ///< in the order they combine
  std::vector<LesionSpec> lesions;
  RandomLesions random_lesions;
  std::vector<tissue::Pulse> pulses;
  tissue::Breathing breathing;
  std::vector<tissue::DynamicRegion> dynamic_regions;
  Task task;
  std::filesystem::path file;            ///< where it was read from (not written)
  friend bool operator==(const Scenario&, const Scenario&) = default;
};

/// The radius of the smallest lesion `s` can hold, m: the smallest semi-axis
/// of its lesions and, with random lesions, their smallest radius; 0 when it
/// has none. What organ.prep's lesion_radius is set from, so the prepared
/// edge resolves every lesion (prep::target_edge_for).
double smallest_lesion_radius(const Scenario& s);


/// Largest scenario file load_scenario reads, bytes.
inline constexpr std::uintmax_t kMaxScenarioBytes = 16u << 20;

/// Reads and validates a scenario file. Refuses a non-regular file or one
/// over kMaxScenarioBytes (16 MiB). The organ file (unless "default") and
/// region files must exist; the organ's SHA-256 is checked when given.
/// Throws ScenarioError.
Scenario load_scenario(const std::filesystem::path& file);
/// Parses scenario JSON text; `file` names it in messages and resolves
/// relative paths. The same checks as load_scenario but the file's own
/// (unknown and duplicate keys, types, ranges, names referred to, the organ
/// and region files, the SHA-256). Throws ScenarioError.
Scenario parse_scenario(const std::string& text, const std::filesystem::path& file);
/// The JSON text of a scenario (file units: mm, kPa, N, s), 2-space indented
/// (arrays of plain values on one line), keys in a fixed order, numbers
/// rounded to 12 significant digits: loading it and writing it again gives the same bytes.
std::string to_json_text(const Scenario& s);
/// The text with relative paths (organ, region files) written relative to
/// `base_dir` (absolute); to_json_text(s) uses the folder of s.file (paths
/// as written when s.file is empty).
std::string to_json_text(const Scenario& s, const std::filesystem::path& base_dir);
/// Writes atomically: the text goes to "<file>.tmp" in the same folder,
/// fsync'd, then renamed over `file` (and the folder fsync'd); on any
/// failure the temporary is removed and the old file is left as it was.
/// Relative paths are written relative to the new file's folder.
/// Throws ScenarioError naming the file.
void save_scenario(const Scenario& s, const std::filesystem::path& file);
/// A human summary for `palpa scenario check`.
std::string summary(const Scenario& s);

}  // namespace palpa::scenario
