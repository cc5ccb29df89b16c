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

#include <algorithm>
#include <cmath>
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

namespace {
double min_angle_cos_free(const Point& a, const Point& b, const Point& c) {
  // The smallest angle of a triangle, in radians.
  auto angle = [](const Point& p, const Point& q, const Point& r) {
    const auto u = q - p, v = r - p;
    const double nu = std::sqrt(u * u), nv = std::sqrt(v * v);
    if (nu == 0 || nv == 0) return 0.0;
    return std::acos(std::clamp((u * v) / (nu * nv), -1.0, 1.0));
  };
  return std::min({angle(a, b, c), angle(b, c, a), angle(c, a, b)});
}

// Two creases meeting at a vertex at an angle narrower than 20 degrees would
// pin a triangle with that angle: the less sharp of the two stays free.
void unpin_narrow_crease_junctions(CMesh& m, CMesh::Property_map<CMesh::Edge_index, bool>& sharp) {
  const double narrow = std::cos(20.0 * CGAL_PI / 180.0);
  auto turn = [&](CMesh::Halfedge_index h) {  // cosine of the dihedral turn: larger is less sharp
    if (m.is_border(m.edge(h))) return -1.0;
    auto n = [&](CMesh::Halfedge_index g) {
      const Point &a = m.point(m.source(g)), &b = m.point(m.target(g)), &c = m.point(m.target(m.next(g)));
      const auto v = CGAL::cross_product(b - a, c - a);
      const double l = std::sqrt(v * v);
      return l > 0 ? v / l : v;
    };
    return n(h) * n(m.opposite(h));
  };
  for (CMesh::Vertex_index v : m.vertices()) {
    std::vector<CMesh::Halfedge_index> in;
    for (CMesh::Halfedge_index h : CGAL::halfedges_around_target(m.halfedge(v), m))
      if (sharp[m.edge(h)]) in.push_back(h);
    for (std::size_t i = 0; i < in.size(); ++i)
      for (std::size_t j = i + 1; j < in.size(); ++j) {
        if (!sharp[m.edge(in[i])] || !sharp[m.edge(in[j])]) continue;
        const auto u = m.point(m.source(in[i])) - m.point(v), w = m.point(m.source(in[j])) - m.point(v);
        const double c = (u * w) / std::sqrt((u * u) * (w * w));
        if (c <= narrow) continue;
        sharp[m.edge(turn(in[i]) > turn(in[j]) ? in[i] : in[j])] = false;
      }
  }
}

// Protected creases keep triangles whose three vertices lie on a crease (an
// input sliver whose two long edges both count as sharp): the remesher flips
// only towards valence 6. Flips the unconstrained edge opposite such a
// triangle's largest angle where that raises the smaller minimum angle of the
// two triangles and folds nothing.
void flip_slivers_at_creases(CMesh& m, const CMesh::Property_map<CMesh::Edge_index, bool>& sharp) {
  const double limit = 20.0 * CGAL_PI / 180.0;
  for (int pass = 0; pass < 5; ++pass) {
    std::size_t flips = 0;
    for (CMesh::Face_index f : m.faces()) {
      CMesh::Halfedge_index h = m.halfedge(f);
      // The halfedge opposite the largest angle: the longest edge.
      CMesh::Halfedge_index best = h;
      double longest = -1;
      for (CMesh::Halfedge_index g : CGAL::halfedges_around_face(h, m)) {
        const double l = CGAL::squared_distance(m.point(m.source(g)), m.point(m.target(g)));
        if (l > longest) longest = l, best = g;
      }
      h = best;
      const Point &a = m.point(m.source(h)), &b = m.point(m.target(h)), &c = m.point(m.target(m.next(h)));
      const double before_f = min_angle_cos_free(a, b, c);
      if (before_f >= limit || sharp[m.edge(h)] || m.is_border(m.edge(h))) continue;
      const CMesh::Halfedge_index o = m.opposite(h);
      const CMesh::Vertex_index vc = m.target(m.next(h)), vd = m.target(m.next(o));
      if (vc == vd || CGAL::halfedge(vc, vd, m).second) continue;
      const Point& d = m.point(vd);
      const double before = std::min(before_f, min_angle_cos_free(b, a, d));
      // After the flip: triangles (c, a, d) and (c, d, b) in the face's orientation.
      const double after = std::min(min_angle_cos_free(c, a, d), min_angle_cos_free(c, d, b));
      if (after <= before) continue;
      const auto n1 = CGAL::cross_product(a - c, d - c), n2 = CGAL::cross_product(d - c, b - c);
      const auto n0 = CGAL::cross_product(b - a, c - a) + CGAL::cross_product(a - b, d - b);
      if (n1 * n2 <= 0 || n1 * n0 <= 0 || n2 * n0 <= 0) continue;
      CGAL::Euler::flip_edge(h, m);
      ++flips;
    }
    if (flips == 0) break;
  }
}
}  // namespace

// ---------------------------------------------------------------------------
// isotropic_remeshing: splits edges longer than 4/3 L, collapses those
// shorter than 4/5 L, flips towards valence 6, relaxes tangentially and
// projects onto the surface as it was before.
// Edges whose dihedral angle is sharper than feature_angle_deg (a crease,
// e.g. where two overlapping spheres were joined, an organ's rim, a coarse
// input's fold crest) are constrained and their vertices pinned to them: the
// creases are first split to at most the target edge (split_long_edges with
// the same constraint map, so the pieces stay constrained), then remeshing
// splits and collapses them only along the crease and never relaxes their
// vertices off it, the last iteration neither splits nor collapses them
// (protect_constraints), and crease end points and junctions (vertices with
// other than two crease edges) are fixed corners. Without the pinning, remeshing cut the crests (the output's
// vertices lie on the input, its triangles straddle the crease).
std::size_t Work::remesh(double edge_m, int iterations, int relaxation_steps, double feature_angle_deg) {
  CMesh& m = impl_->mesh;
  impl_->reference = m;
  auto sharp = m.add_property_map<CMesh::Edge_index, bool>("e:prep_sharp", false).first;
  auto corner = m.add_property_map<CMesh::Vertex_index, bool>("v:prep_corner", false).first;
  for (CMesh::Edge_index e : m.edges()) sharp[e] = false;
  for (CMesh::Vertex_index v : m.vertices()) corner[v] = false;
  if (feature_angle_deg > 0) PMP::detect_sharp_edges(m, feature_angle_deg, sharp);
  unpin_narrow_crease_junctions(m, sharp);
  std::vector<CMesh::Edge_index> creases;
  for (CMesh::Edge_index e : m.edges())
    if (sharp[e]) creases.push_back(e);
  const std::size_t n_sharp = creases.size();
  if (n_sharp == 0) {
    PMP::isotropic_remeshing(faces(m), edge_m, m,
                             PMP::parameters::number_of_iterations(iterations)
                                 .number_of_relaxation_steps(relaxation_steps));
    m.collect_garbage();
    return 0;
  }
  for (CMesh::Vertex_index v : m.vertices()) {
    int k = 0;
    for (CMesh::Halfedge_index h : CGAL::halfedges_around_target(m.halfedge(v), m)) k += sharp[m.edge(h)];
    corner[v] = k != 0 && k != 2;
  }
  // First the creases' own spacing evens out (constrained edges split and
  // collapsed along the crease, their vertices kept on it), then a last
  // iteration with the creases protected lets the flips and the relaxation
  // even out the triangles beside them.
  PMP::split_long_edges(creases, edge_m, m, PMP::parameters::edge_is_constrained_map(sharp));
  PMP::isotropic_remeshing(faces(m), edge_m, m,
                           PMP::parameters::number_of_iterations(std::max(1, iterations - 1))
                               .number_of_relaxation_steps(relaxation_steps)
                               .edge_is_constrained_map(sharp)
                               .vertex_is_constrained_map(corner)
                               .protect_constraints(false)
                               .relax_constraints(false));
  m.collect_garbage();
  creases.clear();
  for (CMesh::Edge_index e : m.edges())
    if (sharp[e]) creases.push_back(e);
  PMP::split_long_edges(creases, edge_m, m, PMP::parameters::edge_is_constrained_map(sharp));
  PMP::isotropic_remeshing(faces(m), edge_m, m,
                           PMP::parameters::number_of_iterations(1)
                               .number_of_relaxation_steps(relaxation_steps)
                               .edge_is_constrained_map(sharp)
                               .vertex_is_constrained_map(corner)
                               .protect_constraints(true)
                               .relax_constraints(false));
  m.collect_garbage();
  flip_slivers_at_creases(m, sharp);
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
  // The nearest point may lie across a crease: such a move would fold a
  // triangle, so a vertex keeps its relaxed place where one of its triangles
  // would turn by more than 90 degrees.
  auto normal = [&](CMesh::Halfedge_index h) {
    const Point& a = m.point(m.source(h));
    const Point& b = m.point(m.target(h));
    const Point& c = m.point(m.target(m.next(h)));
    return CGAL::cross_product(b - a, c - a);
  };
  std::vector<Kernel::Vector_3> before;
  for (CMesh::Vertex_index v : m.vertices()) {
    if (fixed[v]) continue;
    before.clear();
    for (CMesh::Halfedge_index h : CGAL::halfedges_around_target(m.halfedge(v), m))
      if (!m.is_border(h)) before.push_back(normal(h));
    const Point old = m.point(v);
    m.point(v) = tree.closest_point(old);
    std::size_t k = 0;
    bool folds = false;
    for (CMesh::Halfedge_index h : CGAL::halfedges_around_target(m.halfedge(v), m))
      if (!m.is_border(h)) folds = folds || normal(h) * before[k++] <= 0;
    if (folds) m.point(v) = old;
  }
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
