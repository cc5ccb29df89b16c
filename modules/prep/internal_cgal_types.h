#pragma once
// Internal to prep: the CGAL types behind internal::Work. Included only by
// internal_cgal_repair.cpp and internal_cgal_remesh.cpp.

#include "prep/internal_cgal.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

namespace palpa::prep::internal {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using CMesh = CGAL::Surface_mesh<Point>;

struct Work::Impl {
  std::string source;
  // The soup before repair_soup(); the mesh after it.
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> polygons;
  CMesh mesh;
  // The surface before remeshing: what remesh(), relax() and refine() project onto.
  CMesh reference;
};

inline Point to_cgal(const Vec3& p) { return Point(p.x(), p.y(), p.z()); }
inline Vec3 from_cgal(const Point& p) { return Vec3(p.x(), p.y(), p.z()); }

/// A surface mesh from a soup of triangles (indices valid).
CMesh mesh_from_soup(const Soup& soup);
/// The surface mesh as a soup (vertices in index order; garbage collected).
Soup soup_from_mesh(const CMesh& mesh);

}  // namespace palpa::prep::internal
