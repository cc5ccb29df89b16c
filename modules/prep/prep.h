#pragma once
// Mesh preparation: turns an organ file as found (a polygon soup with
// duplicates, specks, holes, inward normals, self-intersections, uneven
// triangles) into the surface the method wants: closed, manifold, oriented
// outward, with near-uniform vertex spacing matched to the probe (each vertex
// is one spring) and vertices and triangles in a spatially local order (the
// contact search and the GPU both read neighbours).
//
// The steps run CGAL's Polygon Mesh Processing (Debian's CGAL 5.5), kept in
// this module's internal_cgal_*.cpp files; this header needs no CGAL.
// Reading and writing go through mesh/io.h, so every format Palpa loads works.

#include "mesh/surface_mesh.h"

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace palpa::prep {

/// An input that cannot be made into a closed surface (or a bad option). The
/// message starts with the input's name and says why, e.g.
/// "open.ply: cannot make a closed surface: hole 1 of 1 (64 boundary edges) would be 50% of the surface ...".
class PrepError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Thrown by prepare() when PrepOptions::cancel was set; nothing is written.
class PrepCancelled : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Palpa's default probe tip radius, m (tissue::kDefaultTipRadius).
inline constexpr double kDefaultProbeRadius = 0.008;

/// How to prepare a mesh. Lengths in metres.
struct PrepOptions {
  /// Length of one input file unit in metres; 0: guess among m, cm, mm from
  /// the size (mesh::auto_unit_metres, an organ is about 0.15 m).
  double unit_m = 0;
  /// Target edge length of the remeshed surface, m; 0: chosen from the probe
  /// radius (target_edge_for()).
  double edge_m = 0;
  /// Radius of the probe tip the mesh is prepared for, m (used when edge_m is 0).
  double probe_radius_m = kDefaultProbeRadius;
  /// Radius of the smallest lesion the mesh must resolve, m (a scenario's
  /// smallest lesion semi-axis; 0: none). Used when edge_m is 0: the edge is
  /// then also at most half of it, so a lesion spans several vertices.
  double lesion_radius_m = 0;
  /// A component whose area is below this fraction of the largest component's
  /// area is a speck and is dropped.
  double speck_area_fraction = 0.01;
  /// A hole whose filling would be more than this fraction of the surface
  /// area means the input is an open sheet, not a closed organ with holes: error.
  double max_hole_area_fraction = 0.2;
  /// Self-intersection repairs tried before the alpha wrap (the last resort,
  /// always allowed): exact autorefinement, then CGAL's local repair.
  bool allow_autorefine = true;
  bool allow_local_repair = true;
  /// Isotropic remeshing iterations (split, collapse, flip, relax, project).
  int remesh_iterations = 5;
  /// Tangential relaxation steps inside each iteration, and after the last.
  int relaxation_steps = 3;
  /// Edges whose normals differ by more than this (degrees) are creases the
  /// remeshing keeps sharp; 0: none. The creases are split to the edge and
  /// their vertices pinned (their ends and junctions fixed), so the output
  /// follows a coarse input's fold crests: the large intestine's Hausdorff
  /// distance 1.09 -> 0.40 mm at a 1.13 mm edge.
  double feature_angle_deg = 60;
  /// Rounds of local refinement where a feature is thinner than the edge
  /// (each with 0.6 times the previous edge); 0: none, the edge stays
  /// uniform (refinement lowers the Hausdorff distance at fissures and thin
  /// rims, and raises the edge-length CV).
  int refine_rounds = 0;
  /// Rounds of shortening the uniform edge (by fit_factor each) while the
  /// Hausdorff or volume target is missed; 0: keep the edge as chosen.
  int fit_rounds = 3;
  double fit_factor = 0.75;
  /// The edge is not shortened past the length that would give more triangles than this.
  std::size_t fit_max_triangles = 400'000;
  /// When set, receives the repaired, closed, outward surface before
  /// remeshing (the reference of the Hausdorff distance), in metres.
  mesh::SurfaceMesh* repaired = nullptr;
  /// Called at the start of each step (name, 0-based index, step count) and
  /// with its duration at the end (fraction 1). May be empty.
  std::function<void(std::string_view step, int index, int count, double fraction)> progress;
  /// When set during prepare(), it stops at the next step with PrepCancelled.
  const std::atomic<bool>* cancel = nullptr;
};

/// The rule that picks the edge length from the probe radius: a quarter of
/// the radius (so a contact's support reaches several rings of vertices),
/// never more than 1/40 of the bounding-box diagonal (so a small organ keeps
/// its shape) nor, when `lesion_radius_m` > 0, more than half the smallest
/// lesion's radius (so the lesion spans several vertices). Returns metres;
/// `diagonal_m` is the organ's bounding-box diagonal, m.
double target_edge_for(double probe_radius_m, double diagonal_m, double lesion_radius_m = 0);

/// A component dropped as a speck.
struct DroppedComponent {
  std::size_t triangles = 0;
  double area_m2 = 0;
  double extent_m = 0;  ///< bounding-box diagonal
};

/// A hole that was filled.
struct FilledHole {
  std::size_t boundary_edges = 0;
  double perimeter_m = 0;
  double area_m2 = 0;          ///< area of the patch that closes it
  std::size_t added_triangles = 0;
  bool faired = true;          ///< false: triangulated and refined, fairing failed
};

/// Facts measured on a mesh (input or output).
struct MeshSummary {
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  std::size_t components = 0;
  std::size_t boundary_edges = 0;
  std::size_t nonmanifold_edges = 0;
  bool closed = false;
  bool manifold = false;
  bool outward = false;      ///< closed, consistently oriented and positive volume
  long euler = 0;            ///< V - E + F
  long genus = -1;           ///< (2 C - euler) / 2 when closed, else -1
  double volume_m3 = 0;      ///< signed
  double area_m2 = 0;
  double edge_mean_m = 0;
  double edge_cv = 0;        ///< standard deviation / mean of edge lengths
  double edge_min_m = 0;
  double edge_max_m = 0;
  double min_angle_deg = 0;  ///< smallest triangle angle
  double extent_m = 0;       ///< bounding-box diagonal
};

/// How long one step took.
struct StepTime {
  std::string step;
  double seconds = 0;
};

/// What preparation did and measured.
struct PrepReport {
  std::string input;            ///< file name (or source name)
  double unit_m = 1;            ///< metres per input unit used
  bool unit_guessed = false;
  double edge_target_m = 0;     ///< the edge used, m
  double edge_requested_m = 0;  ///< the edge given or chosen by the rule, before fitting, m
  int fit_rounds = 0;           ///< rounds that shortened the edge to meet the targets
  std::string edge_rule;        ///< how the edge length was chosen, in words
  MeshSummary before;           ///< the input as loaded (no welding, no reorientation)
  MeshSummary after;            ///< the prepared mesh

  // Repair.
  std::size_t loader_degenerate = 0;     ///< degenerate triangles the loader dropped
  std::size_t loader_duplicate = 0;      ///< duplicate triangles the loader dropped
  std::size_t merged_points = 0;         ///< duplicate points merged (repair_polygon_soup)
  std::size_t removed_polygons = 0;      ///< degenerate or duplicate polygons removed by the soup repair
  std::size_t nonmanifold_duplicated = 0;///< points duplicated to split non-manifold vertices
  std::vector<DroppedComponent> dropped;
  std::vector<FilledHole> holes;
  std::size_t flipped_components = 0;    ///< components reoriented outward (0 or more)
  bool reoriented = false;               ///< orientation changed by orient_to_bound_a_volume
  std::size_t self_intersections = 0;    ///< intersecting triangle pairs found
  std::string self_intersection_fix;     ///< "" (none), "autorefine", "local", "alpha_wrap"
  double volume_repaired_m3 = 0;         ///< volume of the closed, repaired surface before remeshing
  std::size_t crease_edges = 0;          ///< input edges kept as creases (feature_angle_deg)
  // Local refinement.
  double refine_tolerance_m = 0;         ///< distance from the repaired surface that triggers it
  std::size_t refined_triangles = 0;     ///< triangles remeshed with a shorter edge, all rounds
  int refine_rounds = 0;                 ///< rounds used

  // Fidelity.
  double hausdorff_m = 0;        ///< symmetric, output vs the repaired input (kept components, holes filled)
  double hausdorff_input_m = 0;  ///< one-sided: from the input's kept triangles to the output
  double hausdorff_bound_m = 0;  ///< error bound of the bounded-error Hausdorff computation
  double volume_change = 0;      ///< (V_out - V_repaired) / V_repaired
  double volume_change_input = 0;///< (V_out - V_in) / |V_in| when the input was closed, else 0
  bool self_intersecting_after = false;  ///< the prepared surface intersects itself
  std::vector<std::string> warnings;
  std::vector<StepTime> times;
  double seconds = 0;
  bool from_cache = false;
  std::string cache_key;         ///< hex hash of the input bytes and the parameters (prepare_cached)
};

/// Targets of issue 10 on a report: closed, manifold, outward; edge CV <= 0.2;
/// Hausdorff <= max(0.5 mm, edge / 4); volume change <= 1%. Returns the
/// unmet ones in words (empty: all met).
std::vector<std::string> unmet_targets(const PrepReport& report);

/// Prepares a mesh in metres (already loaded; `source` names it in messages
/// and the report). Throws PrepError when it cannot make a closed surface,
/// PrepCancelled when options.cancel is set.
mesh::SurfaceMesh prepare(const mesh::SurfaceMesh& input, const PrepOptions& options, PrepReport* report,
                          const std::string& source);

/// Loads `path` through mesh::load_mesh (any format Palpa reads; without its
/// welding, orientation or component pass, so the repair sees the file as it
/// is), in options.unit_m (or the guessed unit), and prepares it. Throws
/// mesh::MeshError for an unreadable file, PrepError as prepare() does.
mesh::SurfaceMesh prepare_file(const std::filesystem::path& path, const PrepOptions& options,
                               PrepReport* report);

/// The cache folder: $PALPA_PREP_CACHE if set, else $XDG_CACHE_HOME/palpa/prep,
/// else ~/.cache/palpa/prep (else the system temp folder's palpa/prep).
std::filesystem::path default_cache_dir();

/// Hex key of the input file's bytes and the parameters that change the
/// result (unit, edge or probe radius, speck and hole limits, iterations).
std::string cache_key(const std::filesystem::path& path, const PrepOptions& options);

/// prepare_file(), cached: the prepared mesh (binary PLY, metres) and its
/// report (JSON) are kept in `cache_dir` under cache_key(); a later call with
/// the same bytes and parameters loads them (report->from_cache = true).
/// A failed cache write is a warning, not an error.
mesh::SurfaceMesh prepare_cached(const std::filesystem::path& path, const PrepOptions& options,
                                 PrepReport* report, const std::filesystem::path& cache_dir = default_cache_dir());

/// Measures a mesh in metres (edges, angles, topology, volume).
MeshSummary summarize(const mesh::SurfaceMesh& mesh);

/// The report as JSON text (format "palpa.prep-report", version 1; lengths in m).
std::string report_json(const PrepReport& report);
/// Reads report_json()'s text back (for the cache). Throws PrepError on bad text.
PrepReport report_from_json(const std::string& text);

/// A terminal summary of the report (several lines, mm and %).
std::string report_text(const PrepReport& report);

}  // namespace palpa::prep
