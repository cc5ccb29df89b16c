#pragma once
// The assessment of a recorded session (docs/ASSESSMENT.md gives every
// definition). Input: the recorded ticks with their results (the recorder
// stores them; a session without them is replayed first), the events (the
// trainee's marks), the scenario's lesions, task and scoring. Output: the
// numbers, as a struct, JSON and a self-contained HTML page.

#include "assess/coverage.h"
#include "haptics/loop.h"
#include "record/format.h"
#include "tissue/lesion.h"

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace palpa::assess {

/// The scenario's task and scoring as the assessment uses them (copied from
/// scenario::Task so this module needs no scenario file).
struct Task {
  double force_limit = 0;            ///< N (0: none)
  double time_limit = 0;             ///< s (0: none)
  double position_tolerance = 0.01;  ///< m: a mark within this of a lesion (mark_distance) finds it
  double size_tolerance = 0.5;       ///< fraction of the true diameter
  double pass_score = 0.7;           ///< 0..1
  double weight_found = 0.5, weight_size = 0.15, weight_consistency = 0.1, weight_force = 0.15, weight_coverage = 0.1;
};

struct Options {
  double tip_radius = 0.008;       ///< m
  double glide_speed = 0.005;      ///< m/s: tangential speed at or above which contact is "search" (gliding)
  double speed_window = 0.02;      ///< s over which the probe speed is estimated
  double felt_contrast = 0.10;     ///< lesion force contrast (fraction) at which it counts as felt
  std::vector<float> roi;          ///< per-vertex weights of the region of interest (empty: the whole surface)
};

struct LesionResult {
  std::string name;
  Vec3 centre = Vec3::Zero();
  double diameter = 0;             ///< m, 2 (a_x a_y a_z)^(1/3)
  bool found = false;
  int mark = -1;                   ///< index into marks when found
  double localisation_error = 0;   ///< m, mark_distance: to the centre or the surface point above it
  double size_error = 0;           ///< |reported - true| / true diameter
  double time_to_detection = 0;    ///< s after the first tick
  double max_contrast = 0;         ///< largest force contrast the probe reached over it
  double max_contrast_time = 0;    ///< s
  std::string missed;              ///< "", "felt but missed" or "never adequately probed"
};

struct MarkResult {
  Vec3 point = Vec3::Zero();
  double diameter = 0;             ///< m as reported
  std::string consistency;
  double time = 0;                 ///< s after the first tick
  int lesion = -1;                 ///< matched lesion (-1: false positive)
};

struct Report {
  // Time.
  double exam_time = 0;                          ///< s, first to last tick
  double contact_time = 0;                       ///< s with any probe in contact
  std::array<double, kLevels> level_time{};      ///< s per level (probe-seconds; None = not in contact)
  // Coverage (of the region of interest, by area).
  double roi_area = 0;                           ///< m^2
  std::array<double, kLevels> coverage{};        ///< fraction covered at exactly each level (None: at any level)
  double largest_gap_area = 0;                   ///< m^2, the largest connected uncovered patch of the ROI
  double largest_gap_diameter = 0;               ///< m, of a disk of that area
  double revisited = 0;                          ///< fraction of the covered area covered by 2+ contact episodes
  // Path and phases.
  double path_length = 0;                        ///< m, of the probe tips while in contact
  double search_time = 0, palpation_time = 0;    ///< s (probe-seconds) gliding / pressing slowly
  double search_force = 0, palpation_force = 0;  ///< N, mean |F| in each
  double force_ratio = 0;                        ///< palpation / search mean force (0 when either is empty)
  // Force.
  double peak_force = 0;                         ///< N
  double peak_force_time = 0;                    ///< s
  double time_over_limit = 0;                    ///< s (probe-seconds) with |F| over the task's limit
  double mean_contact_force = 0;                 ///< N
  std::size_t reactions = 0;                     ///< reaction events recorded
  std::size_t faults = 0;                        ///< fault events recorded
  // Detection.
  std::vector<LesionResult> lesions;
  std::vector<MarkResult> marks;                 ///< the marks standing at the end (deleted ones left out)
  std::size_t marks_deleted = 0;                 ///< Unmark events that withdrew a mark
  double sensitivity = 0;                        ///< found / lesions (0 with no lesion)
  std::size_t false_positives = 0;
  // Verdict.
  double score = 0;                              ///< 0..1
  bool passed = false;
  std::string verdict;                           ///< a sentence
  std::array<double, 5> parts{};                 ///< found, size, consistency, force, coverage (0..1 each; -1: not scored)
  // Provenance.
  std::uint64_t ticks = 0;
  std::size_t probes = 0;
  std::string session_status;
};

/// The per-tick input: the recorded ticks and their results (both
/// tick-indexed, same length, ticks consecutive).
struct TickInput {
  const haptics::TickRecord* tick = nullptr;
  const haptics::ProbeTickResult* results = nullptr;  ///< tick->probe_count entries
};

/// Accumulates the assessment tick by tick, then finish() gives the report.
class Assessor {
 public:
  Assessor(std::shared_ptr<const mesh::SurfaceMesh> mesh, std::vector<tissue::Lesion> lesions, Task task,
           Options options);
  ~Assessor();
  void add(const haptics::TickRecord& tick, std::span<const haptics::ProbeTickResult> results);
  Report finish(const std::vector<record::EventRecord>& events);
  const Coverage& coverage() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The surface point above a lesion: the vertex of `mesh` nearest its
/// centre (organ frame, m). Brute force, O(vertices).
Vec3 surface_point_above(const mesh::SurfaceMesh& mesh, const tissue::Lesion& lesion);
/// How far a mark misses a lesion, m: the smaller of its distances to the
/// lesion's centre and to `surface_point` (surface_point_above). A trainee
/// palpates from the surface and marks there, so a mark straight above a
/// buried lesion is on it whatever the lesion's depth.
double mark_distance(const Vec3& mark, const tissue::Lesion& lesion, const Vec3& surface_point);

/// The report as JSON (2-space indented, SI units in the key names).
std::string to_json(const Report& r);
/// One self-contained HTML page: the table, the force plot (inline SVG),
/// and `coverage_png` (a PNG image of the coverage map, embedded as base64;
/// empty: none). `title` heads it.
std::string to_html(const Report& r, const std::string& title, const std::vector<std::uint8_t>& coverage_png,
                    const std::vector<std::pair<double, double>>& force_curve, double force_limit);

}  // namespace palpa::assess
