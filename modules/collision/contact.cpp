// Contact point interpolation and the 1-D height check (section III.C).

#include "collision/contact.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace palpa::collision {

namespace {

// Barycentric weights within this of [0, 1] count as inside a triangle.
constexpr double kInsideTolerance = 1e-9;
// Newton iterations for the interpolated-normal equation; it is linear when
// the normals are equal and converges quadratically otherwise.
constexpr int kNewtonIterations = 8;

// One triangle's candidate: barycentric weights (b0, b1, b2) and the distance
// from the probe to the candidate point.
struct Candidate {
  Index triangle = kNoIndex;
  Vec3 b = Vec3::Zero();
  double distance_sq = std::numeric_limits<double>::infinity();
};

// Solves P = C(b) + t N(b) for b = (1-u-v, u, v) and t, where C and N are the
// linearly interpolated positions and (unnormalised) normals of the triangle.
// Starts from the orthogonal projection onto the triangle's plane and runs a
// few Newton steps. Returns false when the system is degenerate.
bool solve_interpolated_normal(const mesh::SurfaceMesh& mesh, const mesh::Triangle& tri, const Vec3& probe,
                               Vec3& b) {
  const Vec3& p0 = mesh.positions[tri[0]];
  const Vec3& n0 = mesh.normals[tri[0]];
  const Vec3 e1 = mesh.positions[tri[1]] - p0;
  const Vec3 e2 = mesh.positions[tri[2]] - p0;
  const Vec3 f1 = mesh.normals[tri[1]] - n0;
  const Vec3 f2 = mesh.normals[tri[2]] - n0;
  const Vec3 d = probe - p0;

  // Orthogonal projection onto the plane: the 2x2 normal equations.
  const double a11 = e1.dot(e1), a12 = e1.dot(e2), a22 = e2.dot(e2);
  const double det = a11 * a22 - a12 * a12;
  if (!(det > 0)) return false;
  const double r1 = d.dot(e1), r2 = d.dot(e2);
  double u = (a22 * r1 - a12 * r2) / det;
  double v = (a11 * r2 - a12 * r1) / det;
  Vec3 n = n0 + u * f1 + v * f2;
  const double nn = n.squaredNorm();
  if (!(nn > 0)) return false;
  double t = (d - u * e1 - v * e2).dot(n) / nn;

  // Newton on F(u, v, t) = p0 + u e1 + v e2 + t N(u, v) - P, stopping once
  // the residual is at round-off level; each step solved by Cramer's rule.
  const double tolerance_sq = 1e-28 * (a11 + a22);
  bool converged = false;
  for (int it = 0; it <= kNewtonIterations; ++it) {
    n = n0 + u * f1 + v * f2;
    const Vec3 residual = u * e1 + v * e2 + t * n - d;
    // Round-off level, or (after the last step) close enough to use.
    converged = residual.squaredNorm() <= (it < kNewtonIterations ? tolerance_sq : 1e-16 * (a11 + a22));
    if (converged || it == kNewtonIterations) break;
    const Vec3 ju = e1 + t * f1, jv = e2 + t * f2;
    const Vec3 jv_x_n = jv.cross(n);
    const double jdet = ju.dot(jv_x_n);
    if (!(std::abs(jdet) > 0) || !std::isfinite(jdet)) return false;
    u -= residual.dot(jv_x_n) / jdet;
    v -= ju.dot(residual.cross(n)) / jdet;
    t -= ju.dot(jv.cross(residual)) / jdet;
    if (!std::isfinite(u) || !std::isfinite(v) || !std::isfinite(t)) return false;
  }
  if (!converged) return false;
  b = Vec3(1 - u - v, u, v);
  return true;
}

// Closest point of the triangle (a, b, c) to p, as barycentric weights: the
// orthogonal projection when it falls inside, else the nearest of the
// closest points on the three edges.
Vec3 closest_barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, d = p - a;
  const double a11 = e1.dot(e1), a12 = e1.dot(e2), a22 = e2.dot(e2);
  const double det = a11 * a22 - a12 * a12;
  if (det > 0) {
    const double r1 = d.dot(e1), r2 = d.dot(e2);
    const double u = (a22 * r1 - a12 * r2) / det;
    const double v = (a11 * r2 - a12 * r1) / det;
    if (u >= 0 && v >= 0 && u + v <= 1) return {1 - u - v, u, v};
  }
  // Parameter in [0, 1] of the point of segment from + s dir nearest p.
  auto along = [](const Vec3& rel, const Vec3& dir) {
    const double len2 = dir.squaredNorm();
    return len2 > 0 ? std::clamp(rel.dot(dir) / len2, 0.0, 1.0) : 0.0;
  };
  const double s_ab = along(d, e1), s_ac = along(d, e2), s_bc = along(p - b, c - b);
  const Vec3 w_ab(1 - s_ab, s_ab, 0), w_ac(1 - s_ac, 0, s_ac), w_bc(0, 1 - s_bc, s_bc);
  const double d_ab = (p - (a + s_ab * e1)).squaredNorm();
  const double d_ac = (p - (a + s_ac * e2)).squaredNorm();
  const double d_bc = (p - (b + s_bc * (c - b))).squaredNorm();
  if (d_ab <= d_ac && d_ab <= d_bc) return w_ab;
  return d_ac <= d_bc ? w_ac : w_bc;
}

inline Vec3 interpolate(const std::vector<Vec3>& values, const mesh::Triangle& tri, const Vec3& b) {
  return b[0] * values[tri[0]] + b[1] * values[tri[1]] + b[2] * values[tri[2]];
}

// Tries one triangle: keeps it in `best` when its interpolated-normal
// solution lies inside (within tolerance) and nearer the probe than before.
void try_inside(const mesh::SurfaceMesh& mesh, Index t, const Vec3& probe, Candidate& best) {
  const mesh::Triangle& tri = mesh.triangles[t];
  Vec3 b;
  if (!solve_interpolated_normal(mesh, tri, probe, b)) return;
  if (b.minCoeff() < -kInsideTolerance) return;
  b = b.cwiseMax(0.0);
  b /= b.sum();
  const double d2 = (probe - interpolate(mesh.positions, tri, b)).squaredNorm();
  if (d2 < best.distance_sq) best = {t, b, d2};
}

// Squared distance from the probe to a triangle and the barycentric
// weights of its closest point.
double closest_dist2(const mesh::SurfaceMesh& mesh, Index t, const Vec3& probe, Vec3& b) {
  const mesh::Triangle& tri = mesh.triangles[t];
  b = closest_barycentric(probe, mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]);
  return (probe - interpolate(mesh.positions, tri, b)).squaredNorm();
}

// Tries one triangle for the fallback: its closest point to the probe.
void try_closest(const mesh::SurfaceMesh& mesh, Index t, const Vec3& probe, Candidate& best) {
  Vec3 b;
  const double d2 = closest_dist2(mesh, t, probe, b);
  if (d2 < best.distance_sq) best = {t, b, d2};
}

inline bool has_vertex(const mesh::Triangle& tri, Index v) {
  return tri[0] == v || tri[1] == v || tri[2] == v;
}

// Calls f(t) for every triangle around v, then (when `wide`) for every
// triangle around v's neighbours that does not touch v.
template <class F>
void visit(const mesh::SurfaceMesh& mesh, Index v, bool ring, bool wide, F&& f) {
  if (ring)
    for (Index t : mesh.vertex_triangles.row(v)) f(t);
  if (!wide || mesh.vertex_neighbors.rows() != mesh.vertex_count()) return;
  for (Index u : mesh.vertex_neighbors.row(v))
    for (Index t : mesh.vertex_triangles.row(u))
      if (!has_vertex(mesh.triangles[t], v)) f(t);
}

}  // namespace

SurfacePoint locate_surface_point(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index nearest_vertex) {
  SurfacePoint sp;
  if (nearest_vertex >= mesh.vertex_count() || mesh.vertex_triangles.rows() != mesh.vertex_count() ||
      mesh.normals.size() != mesh.vertex_count() || !probe.allFinite())
    return sp;

  // The triangle whose interpolated normal passes through the probe: first
  // around the nearest vertex, then around its neighbours. In each set the
  // triangle nearest the probe is solved first; the others are solved only
  // when some point of theirs could be nearer than the answer so far.
  Candidate best;
  auto search_set = [&](bool ring, bool wide) {
    // Distances of the first few triangles are kept (visit order is fixed).
    std::array<double, 24> seen;
    Index first = kNoIndex;
    double first_d2 = std::numeric_limits<double>::infinity();
    std::size_t k = 0;
    Vec3 unused;
    visit(mesh, nearest_vertex, ring, wide, [&](Index t) {
      const double d2 = closest_dist2(mesh, t, probe, unused);
      if (k < seen.size()) seen[k] = d2;
      ++k;
      if (d2 < first_d2) {
        first_d2 = d2;
        first = t;
      }
    });
    if (first == kNoIndex) return;
    try_inside(mesh, first, probe, best);
    k = 0;
    visit(mesh, nearest_vertex, ring, wide, [&](Index t) {
      const std::size_t i = k++;
      if (t == first) return;
      if (best.triangle != kNoIndex &&
          (i < seen.size() ? seen[i] : closest_dist2(mesh, t, probe, unused)) >= best.distance_sq)
        return;
      try_inside(mesh, t, probe, best);
    });
  };
  search_set(true, false);
  if (best.triangle == kNoIndex) search_set(false, true);
  sp.inside = best.triangle != kNoIndex;
  // None contains it: the closest point of those triangles, clamped.
  if (!sp.inside)
    visit(mesh, nearest_vertex, true, true, [&](Index t) { try_closest(mesh, t, probe, best); });
  if (best.triangle == kNoIndex) return sp;

  // The virtual vertex: interpolated point and unit normal, and the offset
  // of the probe along that normal.
  const mesh::Triangle& tri = mesh.triangles[best.triangle];
  sp.triangle = best.triangle;
  sp.barycentric = best.b;
  sp.point = interpolate(mesh.positions, tri, best.b);
  const Vec3 n = interpolate(mesh.normals, tri, best.b);
  const double len = n.norm();
  sp.normal = len > 0 && std::isfinite(len)
                  ? Vec3(n / len)
                  : Vec3((mesh.positions[tri[1]] - mesh.positions[tri[0]])
                             .cross(mesh.positions[tri[2]] - mesh.positions[tri[0]])
                             .normalized());
  sp.offset = (probe - sp.point).dot(sp.normal);
  return sp;
}

HeightCheck height_check(const SurfacePoint& sp, const Vec3& heights) {
  // 1-D test along the interpolated normal (section III.C).
  HeightCheck hc;
  hc.surface_height = sp.barycentric.dot(heights);
  hc.depth = -sp.offset;
  hc.in_contact = sp.offset < 0 && sp.offset <= hc.surface_height;
  return hc;
}

}  // namespace palpa::collision
