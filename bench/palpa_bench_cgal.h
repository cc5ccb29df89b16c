#pragma once
// The CGAL reference of palpa-bench: CGAL's AABB tree of triangles with
// accelerated distance queries, behind a small interface so that CGAL's
// headers are compiled in palpa_bench_cgal.cpp only. Used only by the benchmark.

#include "core/types.h"
#include "mesh/surface_mesh.h"

#include <memory>

namespace palpa::bench {

/// A point on the triangle soup and the triangle it lies on.
struct CgalHit {
  Vec3 point = Vec3::Zero();  ///< m
  Index triangle = kNoIndex;
};

/// CGAL::AABB_tree over the mesh's triangles (AABB_triangle_primitive,
/// Simple_cartesian<double>), built and accelerated (accelerate_distance_queries)
/// in the constructor. Keeps its own copy of the triangles.
class CgalClosestPoint {
 public:
  explicit CgalClosestPoint(const mesh::SurfaceMesh& mesh);
  ~CgalClosestPoint();
  CgalClosestPoint(const CgalClosestPoint&) = delete;
  CgalClosestPoint& operator=(const CgalClosestPoint&) = delete;

  /// AABB_tree::closest_point(q): closest point on the triangles, m.
  Vec3 closest_point(const Vec3& q) const;
  /// AABB_tree::closest_point(q, hint): same, starting from a hint point (m).
  Vec3 closest_point(const Vec3& q, const Vec3& hint) const;
  /// AABB_tree::closest_point_and_primitive(q): point and triangle index.
  CgalHit closest_point_and_triangle(const Vec3& q) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpa::bench
