#pragma once
// Internal to prep: the CGAL steps behind an opaque handle, so prep.cpp (the
// driver, its timing and report) includes no CGAL header. The handle's
// implementation (internal_cgal_types.h) is shared by the two files that run
// CGAL: internal_cgal_repair.cpp and internal_cgal_remesh.cpp.

#include "prep/prep.h"

#include <memory>
#include <string>
#include <vector>

namespace palpa::prep::internal {

/// Positions (m) and triangles, in no particular state.
struct Soup {
  std::vector<Vec3> points;
  std::vector<mesh::Triangle> triangles;
};

/// What the polygon-soup repair changed.
struct SoupRepair {
  std::size_t merged_points = 0;
  std::size_t removed_polygons = 0;
  std::size_t nonmanifold_duplicated = 0;
};

/// What the self-intersection step did.
struct IntersectionFix {
  std::size_t pairs = 0;  ///< intersecting triangle pairs found
  std::string method;     ///< "" none needed, "autorefine", "local" or "alpha_wrap"
  std::vector<std::string> notes;
};

/// One mesh going through the CGAL steps (a CGAL::Surface_mesh inside).
class Work {
 public:
  /// Starts from a soup (points m, triangles as loaded).
  explicit Work(const Soup& soup, std::string source);
  ~Work();
  Work(const Work&) = delete;
  Work& operator=(const Work&) = delete;

  // ---- internal_cgal_repair.cpp
  /// repair_polygon_soup, orient_polygon_soup (splits non-manifold vertices),
  /// polygon_soup_to_polygon_mesh. Throws PrepError when nothing is left.
  SoupRepair repair_soup();
  /// Drops components below `area_fraction` of the largest one's area.
  std::vector<DroppedComponent> drop_specks(double area_fraction);
  /// Fills every hole (triangulate_refine_and_fair_hole). Throws PrepError
  /// when a hole cannot be filled or its patch exceeds max_area_fraction of the surface.
  std::vector<FilledHole> fill_holes(double max_area_fraction);
  /// Finds self-intersections and repairs them: autorefinement (exact, keeps
  /// the outer surface), then local repair, then alpha wrapping (alpha and
  /// offset in m) as the last resort.
  IntersectionFix fix_self_intersections(double wrap_alpha_m, double wrap_offset_m, bool autorefine = true,
                                         bool local_repair = true);
  /// Orients every closed component to bound a volume (outward). Returns
  /// how many components were flipped. Throws PrepError when not closed.
  std::size_t orient_outward();
  /// True when two triangles of the surface intersect.
  bool self_intersects() const;
  /// Enclosed volume, m^3 (signed).
  double volume() const;
  /// A copy of the current surface.
  Soup soup() const;

  // ---- internal_cgal_remesh.cpp
  /// Isotropic remeshing to edge_m (m), each iteration with relaxation_steps
  /// tangential relaxation steps, projected on the surface as it was; edges
  /// sharper than feature_angle_deg (0: none) are kept as creases. Returns
  /// how many edges were creases before remeshing.
  std::size_t remesh(double edge_m, int iterations, int relaxation_steps, double feature_angle_deg);
  /// Back to the surface as it was before remesh() (to remesh it again).
  void restore_reference();
  /// Tangential relaxation of every vertex, projected back onto the surface
  /// as it was before remesh().
  void relax(int steps);
  /// Local refinement where the remeshed surface misses a feature thinner
  /// than the edge: faces farther than tolerance_m from the surface before
  /// remesh() (at their centroids), or nearest to one of its vertices that
  /// is farther than that, are remeshed with 0.6, 0.36, ... of edge_m (at
  /// most `rounds` rounds) with two rings around them. Returns how many
  /// faces were remeshed in all and sets `rounds_used`.
  std::size_t refine(double tolerance_m, double edge_m, int rounds, int& rounds_used);
  /// The surface with vertices in Hilbert order (CGAL::spatial_sort) and
  /// triangles in the Hilbert order of their centroids.
  Soup sorted_soup() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Hausdorff distances between two closed or open triangle surfaces (m),
/// bounded-error (error_m): symmetric and one-sided from `from` to `to`.
double hausdorff_symmetric(const Soup& a, const Soup& b, double error_m);
double hausdorff_one_sided(const Soup& from, const Soup& to, double error_m);

}  // namespace palpa::prep::internal
