// The repair half of the CGAL steps: polygon soup, specks, holes,
// self-intersections, orientation. One of the two files of the project that
// include CGAL's Polygon Mesh Processing headers (they compile slowly).

#include "prep/internal_cgal_types.h"

#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/repair_self_intersections.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/alpha_wrap_3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <map>

namespace palpa::prep::internal {

namespace PMP = CGAL::Polygon_mesh_processing;
using face_descriptor = CMesh::Face_index;
using halfedge_descriptor = CMesh::Halfedge_index;
using vertex_descriptor = CMesh::Vertex_index;

namespace {

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// Signed volume of the faces of one component (or all: component < 0) by
// the divergence theorem about `origin`.
double signed_volume(const CMesh& m, const CMesh::Property_map<face_descriptor, std::size_t>* cc,
                     long component, const Point& origin) {
  double v = 0;
  for (face_descriptor f : m.faces()) {
    if (cc && static_cast<long>((*cc)[f]) != component) continue;
    const halfedge_descriptor h = m.halfedge(f);
    const Vec3 o = from_cgal(origin);
    const Vec3 a = from_cgal(m.point(m.target(h))) - o;
    const Vec3 b = from_cgal(m.point(m.target(m.next(h)))) - o;
    const Vec3 c = from_cgal(m.point(m.target(m.next(m.next(h))))) - o;
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v;
}

Point bbox_centre(const CMesh& m) {
  const CGAL::Bbox_3 b = PMP::bbox(m);
  return Point((b.xmin() + b.xmax()) / 2, (b.ymin() + b.ymax()) / 2, (b.zmin() + b.zmax()) / 2);
}

// Per-component signed volumes (face component map filled here).
std::vector<double> component_volumes(CMesh& m) {
  auto cc = m.add_property_map<face_descriptor, std::size_t>("f:prep_cc", 0).first;
  const std::size_t n = PMP::connected_components(m, cc);
  const Point o = bbox_centre(m);
  std::vector<double> vol(n);
  for (std::size_t c = 0; c < n; ++c) vol[c] = signed_volume(m, &cc, static_cast<long>(c), o);
  m.remove_property_map(cc);
  return vol;
}

}  // namespace

// ---------------------------------------------------------------------------
CMesh mesh_from_soup(const Soup& soup) {
  CMesh m;
  std::vector<vertex_descriptor> v;
  v.reserve(soup.points.size());
  for (const Vec3& p : soup.points) v.push_back(m.add_vertex(to_cgal(p)));
  for (const auto& t : soup.triangles) m.add_face(v[t[0]], v[t[1]], v[t[2]]);
  return m;
}

Soup soup_from_mesh(const CMesh& in) {
  CMesh m = in;
  m.collect_garbage();
  Soup s;
  s.points.reserve(m.number_of_vertices());
  for (vertex_descriptor v : m.vertices()) s.points.push_back(from_cgal(m.point(v)));
  s.triangles.reserve(m.number_of_faces());
  for (face_descriptor f : m.faces()) {
    mesh::Triangle t{};
    int k = 0;
    for (vertex_descriptor v : CGAL::vertices_around_face(m.halfedge(f), m)) t[k++] = static_cast<Index>(v.idx());
    s.triangles.push_back(t);
  }
  return s;
}

Work::Work(const Soup& soup, std::string source) : impl_(std::make_unique<Impl>()) {
  impl_->source = std::move(source);
  impl_->points.reserve(soup.points.size());
  for (const Vec3& p : soup.points) impl_->points.push_back(to_cgal(p));
  impl_->polygons.reserve(soup.triangles.size());
  for (const auto& t : soup.triangles) impl_->polygons.push_back({t[0], t[1], t[2]});
}

Work::~Work() = default;

double Work::volume() const { return signed_volume(impl_->mesh, nullptr, -1, bbox_centre(impl_->mesh)); }

Soup Work::soup() const { return soup_from_mesh(impl_->mesh); }

bool Work::self_intersects() const { return PMP::does_self_intersect(impl_->mesh); }

// ---------------------------------------------------------------------------
// Duplicate points and polygons, degenerate polygons, isolated points
// (repair_polygon_soup); a consistent orientation, splitting non-manifold
// vertices and edges where none exists (orient_polygon_soup); then the mesh.
SoupRepair Work::repair_soup() {
  Impl& I = *impl_;
  SoupRepair r;
  const std::size_t p0 = I.points.size(), f0 = I.polygons.size();
  PMP::repair_polygon_soup(I.points, I.polygons);
  r.merged_points = p0 - I.points.size();
  r.removed_polygons = f0 - I.polygons.size();
  if (I.polygons.empty())
    throw PrepError(I.source + ": cannot make a closed surface: no triangles are left after removing " +
                    std::to_string(r.removed_polygons) + " degenerate or duplicate ones");
  const std::size_t p1 = I.points.size();
  PMP::orient_polygon_soup(I.points, I.polygons);
  r.nonmanifold_duplicated = I.points.size() - p1;
  I.mesh.clear();
  PMP::polygon_soup_to_polygon_mesh(I.points, I.polygons, I.mesh);
  I.points.clear();
  I.polygons.clear();
  return r;
}

// ---------------------------------------------------------------------------
// Components by shared edges; those with less than area_fraction of the
// largest one's area go, and are listed.
std::vector<DroppedComponent> Work::drop_specks(double area_fraction) {
  CMesh& m = impl_->mesh;
  auto cc = m.add_property_map<face_descriptor, std::size_t>("f:prep_cc", 0).first;
  const std::size_t n = PMP::connected_components(m, cc);
  std::vector<DroppedComponent> stats(n);
  std::vector<CGAL::Bbox_3> box(n);
  for (face_descriptor f : m.faces()) {
    const std::size_t c = cc[f];
    stats[c].triangles += 1;
    stats[c].area_m2 += PMP::face_area(f, m);
    for (vertex_descriptor v : CGAL::vertices_around_face(m.halfedge(f), m)) box[c] += m.point(v).bbox();
  }
  double largest = 0;
  for (const auto& s : stats) largest = std::max(largest, s.area_m2);
  std::vector<std::size_t> drop;
  std::vector<DroppedComponent> dropped;
  for (std::size_t c = 0; c < n; ++c) {
    stats[c].extent_m = std::sqrt(std::pow(box[c].xmax() - box[c].xmin(), 2) + std::pow(box[c].ymax() - box[c].ymin(), 2) +
                                  std::pow(box[c].zmax() - box[c].zmin(), 2));
    if (stats[c].area_m2 < area_fraction * largest) {
      drop.push_back(c);
      dropped.push_back(stats[c]);
    }
  }
  if (!drop.empty()) PMP::remove_connected_components(m, drop, cc);
  m.remove_property_map(cc);
  m.collect_garbage();
  return dropped;
}

// ---------------------------------------------------------------------------
// Every boundary cycle is triangulated, refined to the density around it and
// faired (triangulate_refine_and_fair_hole). A patch larger than
// max_area_fraction of the surface means an open sheet: refused.
std::vector<FilledHole> Work::fill_holes(double max_area_fraction) {
  CMesh& m = impl_->mesh;
  const std::string& source = impl_->source;
  std::vector<halfedge_descriptor> cycles;
  PMP::extract_boundary_cycles(m, std::back_inserter(cycles));
  std::vector<FilledHole> holes;
  const double surface_area = PMP::area(m);
  const std::size_t count = cycles.size();
  double patches = 0;
  for (std::size_t i = 0; i < count; ++i) {
    // The hole's size along its border.
    FilledHole hole;
    for (halfedge_descriptor h : CGAL::halfedges_around_face(cycles[i], m)) {
      hole.boundary_edges += 1;
      hole.perimeter_m += PMP::edge_length(h, m);
    }
    const std::string which = "hole " + std::to_string(i + 1) + " of " + std::to_string(count) + " (" +
                              std::to_string(hole.boundary_edges) + " boundary edges, perimeter " +
                              fmt("%.3g", hole.perimeter_m * 1e3) + " mm)";
    // Triangulate, refine, fair.
    std::vector<face_descriptor> faces;
    std::vector<vertex_descriptor> verts;
    bool faired = false;
    try {
      faired = std::get<0>(PMP::triangulate_refine_and_fair_hole(m, cycles[i], std::back_inserter(faces),
                                                                 std::back_inserter(verts)));
    } catch (const std::exception& e) {
      throw PrepError(source + ": cannot make a closed surface: " + which + " could not be filled (" + e.what() + ")");
    }
    if (faces.empty())
      throw PrepError(source + ": cannot make a closed surface: " + which + " could not be triangulated");
    hole.faired = faired;
    hole.added_triangles = faces.size();
    for (face_descriptor f : faces) hole.area_m2 += PMP::face_area(f, m);
    patches += hole.area_m2;
    const double fraction = hole.area_m2 / (surface_area + patches);
    if (fraction > max_area_fraction)
      throw PrepError(source + ": cannot make a closed surface: " + which + " would be " +
                      fmt("%.0f", fraction * 100) + "% of the surface (the limit is " +
                      fmt("%.0f", max_area_fraction * 100) +
                      "%); the input is an open sheet, not a closed organ with holes");
    holes.push_back(hole);
  }
  if (!CGAL::is_closed(m))
    throw PrepError(source + ": cannot make a closed surface: boundary edges remain after filling " +
                    std::to_string(count) + " holes");
  return holes;
}

// ---------------------------------------------------------------------------
// Self-intersections: exact autorefinement first (it keeps the outer
// surface, e.g. the union of two overlapping spheres), then CGAL's local
// repair (smoothing and hole filling of the intersecting patches), then an
// alpha wrap, which remeshes the whole shape: the caller warns by how much.
IntersectionFix Work::fix_self_intersections(double wrap_alpha_m, double wrap_offset_m, bool autorefine,
                                             bool local_repair) {
  CMesh& m = impl_->mesh;
  IntersectionFix fix;
  std::vector<std::pair<face_descriptor, face_descriptor>> pairs;
  PMP::self_intersections(m, std::back_inserter(pairs));
  fix.pairs = pairs.size();
  if (pairs.empty()) return fix;

  const auto good = [](const CMesh& c) {
    return !c.is_empty() && CGAL::is_valid_polygon_mesh(c) && CGAL::is_closed(c) && !PMP::does_self_intersect(c);
  };

  // 1. Autorefinement.
  if (autorefine) {
    CMesh trial = m;
    bool ok = false;
    try {
      ok = PMP::experimental::autorefine_and_remove_self_intersections(trial);
      trial.collect_garbage();
    } catch (const std::exception& e) {
      fix.notes.push_back(std::string("autorefinement failed: ") + e.what());
    }
    if (ok && good(trial)) {
      m = std::move(trial);
      fix.method = "autorefine";
      return fix;
    }
    if (ok) fix.notes.push_back("autorefinement left an open or still self-intersecting surface");
  }

  // 2. Local repair.
  if (local_repair) {
    CMesh trial = m;
    bool ok = false;
    try {
      ok = PMP::experimental::remove_self_intersections(trial, PMP::parameters::preserve_genus(false));
      trial.collect_garbage();
    } catch (const std::exception& e) {
      fix.notes.push_back(std::string("local repair failed: ") + e.what());
    }
    if (ok && good(trial)) {
      m = std::move(trial);
      fix.method = "local";
      return fix;
    }
    if (ok) fix.notes.push_back("local repair left an open or still self-intersecting surface");
  }

  // 3. Alpha wrapping.
  CMesh wrap;
  CGAL::alpha_wrap_3(m, wrap_alpha_m, wrap_offset_m, wrap);
  if (!good(wrap))
    throw PrepError(impl_->source + ": cannot make a closed surface: " + std::to_string(fix.pairs) +
                    " pairs of triangles intersect and neither autorefinement, local repair nor alpha wrapping "
                    "removed them");
  m = std::move(wrap);
  fix.method = "alpha_wrap";
  return fix;
}

// ---------------------------------------------------------------------------
// orient_to_bound_a_volume: every closed component outward, nested ones
// (cavities) inward. Returns how many components were flipped.
std::size_t Work::orient_outward() {
  CMesh& m = impl_->mesh;
  if (!CGAL::is_closed(m))
    throw PrepError(impl_->source + ": cannot make a closed surface: it still has boundary edges before orientation");
  const std::vector<double> before = component_volumes(m);
  PMP::orient_to_bound_a_volume(m);
  const std::vector<double> after = component_volumes(m);
  std::size_t flipped = 0;
  for (std::size_t c = 0; c < std::min(before.size(), after.size()); ++c) flipped += (before[c] < 0) != (after[c] < 0);
  return flipped;
}

}  // namespace palpa::prep::internal
