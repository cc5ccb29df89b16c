// CGAL's AABB tree for palpa-bench. The only translation unit of the project
// that includes CGAL headers (they are slow to compile).

#include "palpa_bench_cgal.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <vector>

namespace palpa::bench {

namespace {
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle3 = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle3>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Traits = CGAL::AABB_traits<Kernel, Primitive>;
using Tree = CGAL::AABB_tree<Traits>;

Point to_cgal(const Vec3& p) { return Point(p.x(), p.y(), p.z()); }
Vec3 from_cgal(const Point& p) { return Vec3(p.x(), p.y(), p.z()); }
}  // namespace

struct CgalClosestPoint::Impl {
  std::vector<Triangle3> triangles;  // must outlive the tree (primitives hold iterators)
  Tree tree;
};

CgalClosestPoint::CgalClosestPoint(const mesh::SurfaceMesh& mesh) : impl_(std::make_unique<Impl>()) {
  // Copy the triangles as CGAL triangles, build the tree and its KD-tree of
  // reference points (accelerate_distance_queries) up front, so no query pays for it.
  impl_->triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    impl_->triangles.emplace_back(to_cgal(mesh.positions[t[0]]), to_cgal(mesh.positions[t[1]]),
                                  to_cgal(mesh.positions[t[2]]));
  }
  impl_->tree.insert(impl_->triangles.cbegin(), impl_->triangles.cend());
  impl_->tree.build();
  impl_->tree.accelerate_distance_queries();
}

CgalClosestPoint::~CgalClosestPoint() = default;

Vec3 CgalClosestPoint::closest_point(const Vec3& q) const {
  return from_cgal(impl_->tree.closest_point(to_cgal(q)));
}

Vec3 CgalClosestPoint::closest_point(const Vec3& q, const Vec3& hint) const {
  return from_cgal(impl_->tree.closest_point(to_cgal(q), to_cgal(hint)));
}

CgalHit CgalClosestPoint::closest_point_and_triangle(const Vec3& q) const {
  const auto hit = impl_->tree.closest_point_and_primitive(to_cgal(q));
  return {from_cgal(hit.first), static_cast<Index>(hit.second - impl_->triangles.cbegin())};
}

}  // namespace palpa::bench
