// The remeshing half of the CGAL steps: isotropic remeshing, tangential
// relaxation, the spatial (Hilbert) order, and the bounded-error Hausdorff
// distance. The other file of the project that includes CGAL's Polygon Mesh
// Processing headers.

#include "prep/internal_cgal_types.h"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Polygon_mesh_processing/detect_features.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polygon_mesh_processing/tangential_relaxation.h>
#include <CGAL/Spatial_sort_traits_adapter_3.h>
#include <CGAL/hilbert_sort.h>
#include <CGAL/property_map.h>

#include <numeric>

namespace palpa::prep::internal {

namespace PMP = CGAL::Polygon_mesh_processing;

namespace {
using Primitive = CGAL::AABB_face_graph_triangle_primitive<CMesh>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

// Projects a vertex of `mesh` onto the surface in `tree`.
struct Projection {
  const Tree* tree;
  const CMesh* mesh;
  Point operator()(CMesh::Vertex_index v) const { return tree->closest_point(mesh->point(v)); }
};
}  // namespace

// ---------------------------------------------------------------------------
// isotropic_remeshing: splits edges longer than 4/3 L, collapses those
// shorter than 4/5 L, flips towards valence 6, relaxes tangentially and
// projects onto the surface as it was before.
// Edges whose dihedral angle is sharper than feature_angle_deg (a crease,
// e.g. where two overlapping spheres were joined, or an organ's rim) are
// constrained: they are split and collapsed along the crease only, and their
// vertices slide along it, so the crease stays sharp.
std::size_t Work::remesh(double edge_m, int iterations, int relaxation_steps, double feature_angle_deg) {
  CMesh& m = impl_->mesh;
  impl_->reference = m;
  auto sharp = m.add_property_map<CMesh::Edge_index, bool>("e:prep_sharp", false).first;
  if (feature_angle_deg > 0) PMP::detect_sharp_edges(m, feature_angle_deg, sharp);
  std::size_t n_sharp = 0;
  for (CMesh::Edge_index e : m.edges()) n_sharp += sharp[e];
  PMP::isotropic_remeshing(faces(m), edge_m, m,
                           PMP::parameters::number_of_iterations(iterations)
                               .number_of_relaxation_steps(relaxation_steps)
                               .edge_is_constrained_map(sharp)
                               .relax_constraints(true)
                               .protect_constraints(false));
  m.collect_garbage();
  return n_sharp;
}

void Work::restore_reference() {
  if (!impl_->reference.is_empty()) impl_->mesh = impl_->reference;
}

// ---------------------------------------------------------------------------
// Tangential relaxation evens out the vertex spacing; each vertex is then
// projected back onto the surface as it was before remesh(), so the shape stays.
void Work::relax(int steps) {
  CMesh& m = impl_->mesh;
  if (steps <= 0) return;
  const CMesh& reference = impl_->reference.is_empty() ? m : impl_->reference;
  const CMesh copy = reference;  // the tree must not see m move
  Tree tree(faces(copy).first, faces(copy).second, copy);
  tree.accelerate_distance_queries();
  // Vertices on a crease (remesh()'s constrained edges) stay where they are.
  auto fixed = m.add_property_map<CMesh::Vertex_index, bool>("v:prep_fixed", false).first;
  if (const auto [sharp, found] = m.property_map<CMesh::Edge_index, bool>("e:prep_sharp"); found) {
    for (CMesh::Edge_index e : m.edges())
      if (sharp[e]) fixed[m.vertex(e, 0)] = fixed[m.vertex(e, 1)] = true;
  }
  PMP::tangential_relaxation(vertices(m), m,
                             PMP::parameters::number_of_iterations(static_cast<unsigned>(steps))
                                 .vertex_is_constrained_map(fixed));
  for (CMesh::Vertex_index v : m.vertices())
    if (!fixed[v]) m.point(v) = tree.closest_point(m.point(v));
  m.remove_property_map(fixed);
}

// ---------------------------------------------------------------------------
// Local refinement where the uniform edge is too long for a feature.
std::size_t Work::refine(double tolerance_m, double edge_m, int rounds, int& rounds_used) {
  CMesh& m = impl_->mesh;
  const CMesh& ref = impl_->reference;
  rounds_used = 0;
  if (ref.is_empty()) return 0;
  Tree ref_tree(faces(ref).first, faces(ref).second, ref);
  ref_tree.accelerate_distance_queries();
  const double tol2 = tolerance_m * tolerance_m;
  std::size_t total = 0;
  double edge = edge_m;
  for (int round = 0; round < rounds; ++round) {
    // Faces that miss the reference, and faces nearest to reference vertices they miss.
    std::vector<char> bad(m.number_of_faces(), 0);
    std::size_t n_bad = 0;
    {
      Tree out_tree(faces(m).first, faces(m).second, m);
      out_tree.accelerate_distance_queries();
      for (CMesh::Vertex_index v : ref.vertices()) {
        const auto hit = out_tree.closest_point_and_primitive(ref.point(v));
        if (CGAL::squared_distance(hit.first, ref.point(v)) > tol2 && !bad[hit.second.idx()]) {
          bad[hit.second.idx()] = 1;
          ++n_bad;
        }
      }
      for (CMesh::Face_index f : m.faces()) {
        const auto h = m.halfedge(f);
        const Point c = CGAL::centroid(m.point(m.source(h)), m.point(m.target(h)), m.point(m.target(m.next(h))));
        if (!bad[f.idx()] && ref_tree.squared_distance(c) > tol2) {
          bad[f.idx()] = 1;
          ++n_bad;
        }
      }
    }
    if (n_bad == 0) break;
    // Two rings of faces around them.
    for (int ring = 0; ring < 2; ++ring) {
      std::vector<char> grown = bad;
      for (CMesh::Face_index f : m.faces()) {
        if (!bad[f.idx()]) continue;
        for (CMesh::Vertex_index v : CGAL::vertices_around_face(m.halfedge(f), m))
          for (CMesh::Face_index g : CGAL::faces_around_target(m.halfedge(v), m))
            if (g != CMesh::null_face()) grown[g.idx()] = 1;
      }
      bad.swap(grown);
    }
    std::vector<CMesh::Face_index> patch;
    for (CMesh::Face_index f : m.faces())
      if (bad[f.idx()]) patch.push_back(f);
    edge *= 0.6;
    total += patch.size();
    ++rounds_used;
    PMP::isotropic_remeshing(patch, edge, m,
                             PMP::parameters::number_of_iterations(3)
                                 .number_of_relaxation_steps(1)
                                 .protect_constraints(false)
                                 .projection_functor(Projection{&ref_tree, &m}));
    m.collect_garbage();
  }
  return total;
}

// ---------------------------------------------------------------------------
// Vertices in Hilbert order (CGAL's hilbert_sort with the median policy,
// deterministic), triangles in the Hilbert order of their centroids, each
// triangle rotated (orientation kept) to start at its smallest index.
Soup Work::sorted_soup() const {
  const Soup in = soup();
  const std::size_t nv = in.points.size(), nt = in.triangles.size();
  std::vector<Point> pts;
  pts.reserve(nv);
  for (const Vec3& p : in.points) pts.push_back(to_cgal(p));
  using Traits = CGAL::Spatial_sort_traits_adapter_3<Kernel, CGAL::Pointer_property_map<Point>::type>;
  std::vector<std::size_t> vorder(nv);
  std::iota(vorder.begin(), vorder.end(), std::size_t{0});
  CGAL::hilbert_sort(vorder.begin(), vorder.end(), Traits(CGAL::make_property_map(pts)));

  std::vector<Point> centroids;
  centroids.reserve(nt);
  for (const auto& t : in.triangles)
    centroids.push_back(to_cgal((in.points[t[0]] + in.points[t[1]] + in.points[t[2]]) / 3.0));
  std::vector<std::size_t> torder(nt);
  std::iota(torder.begin(), torder.end(), std::size_t{0});
  CGAL::hilbert_sort(torder.begin(), torder.end(), Traits(CGAL::make_property_map(centroids)));

  Soup out;
  std::vector<Index> rank(nv);
  out.points.reserve(nv);
  for (std::size_t k = 0; k < nv; ++k) {
    rank[vorder[k]] = static_cast<Index>(k);
    out.points.push_back(in.points[vorder[k]]);
  }
  out.triangles.reserve(nt);
  for (std::size_t k = 0; k < nt; ++k) {
    const auto& t = in.triangles[torder[k]];
    mesh::Triangle r{rank[t[0]], rank[t[1]], rank[t[2]]};
    while (r[0] > r[1] || r[0] > r[2]) r = {r[1], r[2], r[0]};
    out.triangles.push_back(r);
  }
  return out;
}

// ---------------------------------------------------------------------------
// Bounded-error Hausdorff distances. Each triangle gets its own three
// vertices, so any soup (open, non-manifold) makes a valid mesh here.
namespace {
CMesh separate_triangles(const Soup& s) {
  CMesh m;
  m.reserve(static_cast<CMesh::size_type>(3 * s.triangles.size()), 0, static_cast<CMesh::size_type>(s.triangles.size()));
  for (const auto& t : s.triangles) {
    const auto a = m.add_vertex(to_cgal(s.points[t[0]]));
    const auto b = m.add_vertex(to_cgal(s.points[t[1]]));
    const auto c = m.add_vertex(to_cgal(s.points[t[2]]));
    m.add_face(a, b, c);
  }
  return m;
}
}  // namespace

double hausdorff_symmetric(const Soup& a, const Soup& b, double error_m) {
  const CMesh ma = separate_triangles(a), mb = separate_triangles(b);
  return PMP::bounded_error_symmetric_Hausdorff_distance<CGAL::Sequential_tag>(ma, mb, error_m);
}

double hausdorff_one_sided(const Soup& from, const Soup& to, double error_m) {
  const CMesh ma = separate_triangles(from), mb = separate_triangles(to);
  return PMP::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(ma, mb, error_m);
}

}  // namespace palpa::prep::internal
