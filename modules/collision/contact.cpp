// Contact point interpolation and the 1-D height check (section III.C), and
// the contact query of the haptic tick: the in-contact walk of section V.A
// with the vertex tree as its fallback.

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

// Every coordinate finite: three compares (Eigen's allFinite forms v - v).
inline bool finite(const Vec3& v) {
  constexpr double kMax = std::numeric_limits<double>::max();
  return (std::abs(v[0]) <= kMax) & (std::abs(v[1]) <= kMax) & (std::abs(v[2]) <= kMax);
}

// `b` when it is barycentric weights (none negative, sum 1 within 1e-9),
// else the centroid's. A weight that is not finite fails the test: it makes
// the sum NaN or infinite, or the least weight negative.
inline Vec3 weights_or_centroid(const Vec3& b) {
  return b.minCoeff() < 0 || !(std::abs(b.sum() - 1) <= 1e-9) ? Vec3::Constant(1.0 / 3) : b;
}

// Weights of a solution inside within kInsideTolerance, clamped to the
// triangle: the common case, all weights already >= 0 (they sum to 1 up to
// round-off from b0 = 1 - u - v), is kept as solved; only a weight just
// below zero is clamped and the rest renormalised. Every path that accepts
// a solution calls this, so they all keep the same bits.
inline Vec3 clamped_inside(const Vec3& b) {
  if (b.minCoeff() >= 0) return b;
  const Vec3 c = b.cwiseMax(0.0);
  return c / c.sum();
}
// Cramer's rule for d = u e1 + v e2 + s n: (u, v) times their common
// denominator (e1 x e2) . n, left to the caller to divide by or compare
// against.
inline Eigen::Vector2d cramer_weights_scaled(const Vec3& d, const Vec3& e1, const Vec3& e2, const Vec3& n) {
  return {d.cross(e2).dot(n), e1.cross(d).dot(n)};
}

// Newton steps on the cubic of the interpolated-normal equation, at most
// (it converges quadratically: three or four steps from the plane crossing).
constexpr int kNewtonIterations = 16;

// One triangle's candidate: barycentric weights (b0, b1, b2) and the distance
// from the probe to the candidate point.
struct Candidate {
  Index triangle = kNoIndex;
  Vec3 b = Vec3::Zero();
  double distance_sq = std::numeric_limits<double>::infinity();
};

// Prepares triangle t of the mesh (see TriangleFrame).
void make_frame(const mesh::SurfaceMesh& mesh, Index t, TriangleFrame& f) {
  const mesh::Triangle& tri = mesh.triangles[t];
  f.corners = tri;
  for (int k = 0; k < 3; ++k) {
    f.p[k] = mesh.positions[tri[k]];
    f.n[k] = mesh.normals[tri[k]];
  }
  f.p0 = f.p[0];
  f.n0 = f.n[0];
  f.e1 = f.p[1] - f.p0;
  f.e2 = f.p[2] - f.p0;
  f.f1 = f.n[1] - f.n0;
  f.f2 = f.n[2] - f.n0;
  f.a11 = f.e1.dot(f.e1);
  f.a12 = f.e1.dot(f.e2);
  f.a22 = f.e2.dot(f.e2);
  f.det = f.a11 * f.a22 - f.a12 * f.a12;
  f.flat = f.f1.isZero(0) && f.f2.isZero(0);
  f.neighbors = mesh.triangle_neighbors.size() == mesh.triangle_count();
  f.k0 = f.e1.cross(f.e2);
  f.k1 = f.f1.cross(f.e2) + f.e1.cross(f.f2);
  f.k2 = f.f1.cross(f.f2);
  f.nk0 = f.n0.dot(f.k0);
  f.inv_nk0 = std::abs(f.nk0) > 0 ? 1 / f.nk0 : 0.0;
  f.nk1 = f.n0.dot(f.k1);
  f.nk2 = f.n0.dot(f.k2);
  f.e3_sq = (f.e2 - f.e1).squaredNorm();
  f.longest_sq = std::max({f.a11, f.a22, f.e3_sq});
  f.root_scale = std::sqrt(f.a11 + f.a22);
  f.f1_sq = f.f1.squaredNorm();
  f.f2_sq = f.f2.squaredNorm();
  f.f3_sq = (f.f2 - f.f1).squaredNorm();
}

// The solve of solve_interpolated_normal for equal normals (flat
// interpolation): u and v of the projection along n0. Kept out of line: the
// walk inlines the curved case, which is the common one.
[[gnu::noinline]] bool solve_flat(const TriangleFrame& f, const Vec3& d, double scale, double& u, double& v) {
  // Equal normals: the projection along n0 onto the plane, by the 2x2
  // normal equations and the offset along n0.
  const double r1 = d.dot(f.e1), r2 = d.dot(f.e2);
  u = (f.a22 * r1 - f.a12 * r2) / f.det;
  v = (f.a11 * r2 - f.a12 * r1) / f.det;
  const double nn = f.n0.squaredNorm();
  if (!(nn > 0)) return false;
  const double t = (d - u * f.e1 - v * f.e2).dot(f.n0) / nn;
  const Vec3 residual = u * f.e1 + v * f.e2 + t * f.n0 - d;
  if (residual.squaredNorm() > 1e-28 * scale) {
    // Oblique normals: solve d = u e1 + v e2 + t n0 by Cramer's rule.
    const double den = f.nk0;
    if (!(std::abs(den) > 0)) return false;
    const Eigen::Vector2d uv = cramer_weights_scaled(d, f.e1, f.e2, f.n0);
    u = uv[0] / den;
    v = uv[1] / den;
  }
  return true;
}

// Solves P = C(b) + t N(b) for b = (1-u-v, u, v) and t, where C and N are the
// linearly interpolated positions and (unnormalised) normals of the triangle.
// With d = P - p0 it reads d - t n0 = u (e1 + t f1) + v (e2 + t f2): for
// fixed t a linear system in (u, v) that is solvable exactly when
// d - t n0 lies in the plane of A = e1 + t f1 and B = e2 + t f2, i.e. when
//   F(t) = (d - t n0) . (A x B) = (d - t n0) . (k0 + t k1 + t^2 k2) = 0,
// a cubic in t. Newton on F from the plane crossing takes a few scalar
// steps; then u = ((d - t n0) x B) . W / W.W and v = (A x (d - t n0)) . W / W.W
// with W = A x B. (A scalar Newton instead of a 3x3 one: about half the
// arithmetic, and the cubic's coefficients are per-triangle constants the
// walk keeps.) With equal normals (flat interpolation) it is the oblique
// projection, solved directly. Returns false when the system is degenerate or the residual stays above
// round-off. The answer depends only on the triangle and the probe (no
// history), so every path that solves the same triangle gets the same bits.
[[gnu::always_inline]] inline bool solve_interpolated_normal(const TriangleFrame& f, const Vec3& probe, Vec3& b) {
  if (!(f.det > 0)) return false;
  const Vec3 d = probe - f.p0;
  const double scale = f.a11 + f.a22;  // m^2
  double u = 0, v = 0;
  if (f.flat) {
    if (!solve_flat(f, d, scale, u, v)) return false;
  } else {
    // Newton on the cubic F(t) = c0 + c1 t + c2 t^2 + c3 t^3.
    const double c0 = d.dot(f.k0), c1 = d.dot(f.k1) - f.nk0, c2 = d.dot(f.k2) - f.nk1, c3 = -f.nk2;
    // Starts where the line P - t n0 meets the triangle's plane (the root
    // nearest the surface). Stops once the error left after a step, about
    // |F'' / 2F'| dt^2 for Newton near a simple root, is at round-off level;
    // near a double root (the probe near a focal point of the triangle) it
    // converges slowly, and the residual test below decides.
    //
    // A step that crosses an extremum of F (F' changes sign) while F keeps
    // its sign has passed the bottom of a valley of |F| that does not reach
    // zero: the root nearest the surface, which the solve looks for, is not
    // there (the probe is past the fold of the triangle's normals, where two
    // roots meet and vanish). Newton then bounces around that valley, and
    // where it converges at all (after 6 to 16 steps on the bench's organs,
    // where the others take 1 to 5) it is onto a root on another sheet, by
    // chance. So the solve stops there with no solution, as it does after
    // kNewtonIterations steps, and a failing solve costs 1 to 4 steps, not 16.
    double t = c0 * f.inv_nk0;  // 0 where nk0 is 0
    const double tol = 1e-14 * f.root_scale;  // m (t is in m for unit normals)
    double F_before = 0, dF_before = 0;       // at the step before (none yet: 0)
    for (int it = 0; it < kNewtonIterations; ++it) {
      const double F = ((c3 * t + c2) * t + c1) * t + c0;
      const double dF = (3 * c3 * t + 2 * c2) * t + c1;
      if (!(std::abs(dF) > 0) || !std::isfinite(dF)) return false;
      if (F * F_before > 0 && dF * dF_before < 0) return false;
      F_before = F;
      dF_before = dF;
      const double dt = F / dF;
      t -= dt;
      if (!std::isfinite(t)) return false;
      const double ddF = 6 * c3 * t + 2 * c2;
      if (std::abs(ddF) * dt * dt <= 2 * std::abs(dF) * tol && std::abs(dt) <= 1e-4 * f.root_scale) break;
    }
    // (u, v) from the cross products with W = A x B.
    const Vec3 A = f.e1 + t * f.f1, B = f.e2 + t * f.f2, r = d - t * f.n0;
    const Vec3 W = f.k0 + t * (f.k1 + t * f.k2);
    const double ww = W.squaredNorm();
    if (!(ww > 0)) return false;
    const double inv_ww = 1 / ww;  // one division for both weights
    u = r.cross(B).dot(W) * inv_ww;
    v = A.cross(r).dot(W) * inv_ww;
    if (!std::isfinite(u) || !std::isfinite(v)) return false;
    // The residual of the original equation, at round-off level (as accepted
    // by a converged Newton solve).
    const Vec3 residual = u * A + v * B - r;
    if (!(residual.squaredNorm() <= 1e-16 * scale)) return false;
  }
  b = Vec3(1 - u - v, u, v);
  return true;
}

bool solve_interpolated_normal(const mesh::SurfaceMesh& mesh, Index t, const Vec3& probe, Vec3& b) {
  TriangleFrame f;
  make_frame(mesh, t, f);
  return solve_interpolated_normal(f, probe, b);
}

// Closest point of the triangle (a, b, c) to p by its edges: the
// orthogonal projection when it falls inside, else the nearest of the
// closest points on the three edges. Five divisions; kept for triangles
// too degenerate for closest_barycentric's regions.
Vec3 closest_barycentric_by_edges(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
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

// Closest point of the triangle (a, b, c) to p, as barycentric weights, by
// the region of the triangle's plane p projects into: a corner's region
// (both edges from it point away from p), an edge's (p's projection lies
// outside that edge and between its ends: the edge's own point), or the
// inside. The regions are told apart by six dot products with the two edges
// from a, and at most one division is made. The search computes this for
// every triangle it visits; the edge-by-edge form above made five.
// Degenerate triangles (an edge of zero length, or no area), where a
// region's divisor is not positive, go to that form.
Vec3 closest_barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // The point num / den of the way from corner i to corner j (den: the
  // edge's squared length), or the edge-by-edge form for an edge of no length.
  auto on_edge = [&](double num, double den, int i, int j) {
    if (!(den > 0)) return closest_barycentric_by_edges(p, a, b, c);
    const double s = num / den;
    Vec3 w = Vec3::Zero();
    w[i] = 1 - s;
    w[j] = s;
    return w;
  };
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};  // corner a
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};  // corner b
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return on_edge(d1, d1 - d3, 0, 1);  // edge ab
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};  // corner c
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return on_edge(d2, d2 - d6, 0, 2);  // edge ac
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return on_edge(d4 - d3, (d4 - d3) + (d5 - d6), 1, 2);  // edge bc
  const double den = va + vb + vc;  // |ab x ac|^2
  if (!(den > 0) || !std::isfinite(den)) return closest_barycentric_by_edges(p, a, b, c);
  const double inv = 1 / den;
  const double v = vb * inv, w = vc * inv;
  return {1 - v - w, v, w};
}

// b[0] v0 + b[1] v1 + b[2] v2, summed in that order. The contact point, the
// proxy and the slide interpolate over a triangle's corners through here, so
// that the same weights and corners give the same bits wherever it is done:
// the proxy's path hands the slide a normal it computed on that promise.
[[gnu::always_inline]] inline Vec3 interpolate(const Vec3& v0, const Vec3& v1, const Vec3& v2, const Vec3& b) {
  return b[0] * v0 + b[1] * v1 + b[2] * v2;
}

inline Vec3 interpolate(const std::vector<Vec3>& values, const mesh::Triangle& tri, const Vec3& b) {
  return interpolate(values[tri[0]], values[tri[1]], values[tri[2]], b);
}

// False when the interpolated-normal solution of triangle t cannot lie
// inside it: a necessary condition, about a quarter of the solve's cost,
// that spares the search most of the triangles around the nearest vertex
// that do not hold the foot. With nu the face's unit normal, h the probe's
// height above the plane and Q its projection, a solution P = C(b) + t N(b)
// has h = t N.nu, so Q = C(b) + h N_tan / (N.nu), and with every corner
// normal n_m on the face's side (c_m = n_m.nu > 0) that offset is the
// convex combination, weights b_m c_m / sum b c, of g_m = n_m,tan / c_m.
// In barycentric terms b = beta(Q) - h sum_m w_m D_m with D_m the change
// of weights along g_m, so b_j >= 0 needs beta_j(Q) >= min_m h D_m[j].
// The margin (1e-6 of the terms' size) covers the solve's inside tolerance
// and round-off; near-degenerate triangles, and those with a corner normal
// not on the face's side, are always solved. No effect on which triangle a
// search picks, only on how many it solves.
bool foot_may_lie_inside(const mesh::SurfaceMesh& mesh, Index t, const Vec3& probe) {
  const mesh::Triangle& tri = mesh.triangles[t];
  const Vec3& p0 = mesh.positions[tri[0]];
  const Vec3 e1 = mesh.positions[tri[1]] - p0, e2 = mesh.positions[tri[2]] - p0;
  const double a11 = e1.dot(e1), a12 = e1.dot(e2), a22 = e2.dot(e2);
  const double det = a11 * a22 - a12 * a12;    // m^4
  if (!(det > 1e-6 * a11 * a22)) return true;  // a sliver: solve it
  const Vec3 k = e1.cross(e2);                 // nu |k|, |k| = sqrt(det)
  const Vec3 d = probe - p0;
  // det beta(Q), and h |k|.
  const double r1 = d.dot(e1), r2 = d.dot(e2);
  const double bu = a22 * r1 - a12 * r2, bv = a11 * r2 - a12 * r1;
  const double beta[3] = {det - bu - bv, bu, bv};
  const double hk = d.dot(k);
  const double beta_size = det + std::abs(beta[0]) + std::abs(beta[1]) + std::abs(beta[2]);
  // Per corner m, with c_m |k| = n_m . k > 0: h D_m = hk G_m / (det c_m |k|)
  // where G_m = det dbeta(n_m); b_j >= 0 needs, for some m,
  // det beta_j (c_m |k|) >= hk G_mj. Compared without dividing.
  bool ok[3] = {false, false, false};
  for (int m = 0; m < 3; ++m) {
    const Vec3& n = mesh.normals[tri[m]];
    const double ck = n.dot(k);
    if (!(ck > 0)) return true;
    const double g1 = n.dot(e1), g2 = n.dot(e2);
    const double G1 = a22 * g1 - a12 * g2, G2 = a11 * g2 - a12 * g1, G0 = -G1 - G2;
    const double margin = 1e-6 * (beta_size * ck + std::abs(hk) * (std::abs(G0) + std::abs(G1) + std::abs(G2)));
    ok[0] = ok[0] || beta[0] * ck >= hk * G0 - margin;
    ok[1] = ok[1] || beta[1] * ck >= hk * G1 - margin;
    ok[2] = ok[2] || beta[2] * ck >= hk * G2 - margin;
  }
  return (ok[0] && ok[1] && ok[2]) || !std::isfinite(hk * beta_size);
}

// Tries one triangle: keeps it in `best` when its interpolated-normal
// solution lies inside (within tolerance) and nearer the probe than before.
void try_inside(const mesh::SurfaceMesh& mesh, Index t, const Vec3& probe, Candidate& best) {
  const mesh::Triangle& tri = mesh.triangles[t];
  if (!foot_may_lie_inside(mesh, t, probe)) return;
  Vec3 b;
  if (!solve_interpolated_normal(mesh, t, probe, b)) return;
  if (b.minCoeff() < -kInsideTolerance) return;
  b = clamped_inside(b);
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

// Calls f(t) for every triangle around v, then (when `wide`) once for every
// triangle around v's neighbours that does not touch v: a triangle with two
// of v's neighbours as corners is visited from the first of them in v's
// (sorted) neighbour row only.
template <class F>
void visit(const mesh::SurfaceMesh& mesh, Index v, bool ring, bool wide, F&& f) {
  if (ring)
    for (Index t : mesh.vertex_triangles.row(v)) f(t);
  if (!wide || mesh.vertex_neighbors.rows() != mesh.vertex_count()) return;
  const auto around = mesh.vertex_neighbors.row(v);
  // True when w is a neighbour of v listed before u (w < u in the sorted row).
  auto earlier_neighbor = [&](Index w, Index u) {
    if (!(w < u)) return false;
    for (Index x : around)
      if (x == w) return true;
    return false;
  };
  for (Index u : around)
    for (Index t : mesh.vertex_triangles.row(u)) {
      const mesh::Triangle& tri = mesh.triangles[t];
      if (has_vertex(tri, v)) continue;
      bool seen_before = false;
      for (int k = 0; k < 3; ++k) seen_before = seen_before || (tri[k] != u && earlier_neighbor(tri[k], u));
      if (!seen_before) f(t);
    }
}

// The virtual vertex on triangle t at weights b, given its point (m) and
// unit normal: the offset of the probe along that normal.
[[gnu::always_inline]] inline void finish_at(Index t, const Vec3& b, const Vec3& point, const Vec3& normal,
                                             const Vec3& probe, bool inside, SurfacePoint& sp) {
  sp.triangle = t;
  sp.barycentric = b;
  sp.inside = inside;
  sp.point = point;
  sp.normal = normal;
  sp.offset = (probe - point).dot(normal);
}

// The virtual vertex on triangle t (corner positions p, m, and unit normals
// nrm) at weights b: interpolated point and unit normal (the interpolated
// normal over its length, where that is positive and finite), and the
// offset of the probe along that normal.
[[gnu::always_inline]] inline void finish(const Vec3 (&p)[3], const Vec3 (&nrm)[3], Index t, const Vec3& b,
                                          const Vec3& probe, bool inside, SurfacePoint& sp) {
  const Vec3 n = interpolate(nrm[0], nrm[1], nrm[2], b);
  const double len = n.norm();
  finish_at(t, b, interpolate(p[0], p[1], p[2], b),
            len > 0 && std::isfinite(len) ? Vec3(n / len) : Vec3((p[1] - p[0]).cross(p[2] - p[0]).normalized()), probe,
            inside, sp);
}

[[gnu::always_inline]] inline void finish(const mesh::SurfaceMesh& mesh, Index t, const Vec3& b, const Vec3& probe,
                                          bool inside, SurfacePoint& sp) {
  const mesh::Triangle& tri = mesh.triangles[t];
  const Vec3 p[3] = {mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]};
  const Vec3 n[3] = {mesh.normals[tri[0]], mesh.normals[tri[1]], mesh.normals[tri[2]]};
  finish(p, n, t, b, probe, inside, sp);
}

SurfacePoint finish(const mesh::SurfaceMesh& mesh, Index t, const Vec3& b, const Vec3& probe, bool inside) {
  SurfacePoint sp;
  finish(mesh, t, b, probe, inside, sp);
  return sp;
}

// The triangle on the other side of edge (a, b) of triangle t: the one other
// triangle in both vertices' rows of vertex_triangles; kNoIndex on a border
// or a non-manifold edge. (For meshes whose triangle_neighbors table was not
// built.)
Index across_edge(const mesh::SurfaceMesh& mesh, Index t, Index a, Index b) {
  Index found = kNoIndex;
  const auto ring_b = mesh.vertex_triangles.row(b);
  for (Index s : mesh.vertex_triangles.row(a)) {
    if (s == t || s == found) continue;
    for (Index r : ring_b) {
      if (r != s) continue;
      if (found != kNoIndex) return kNoIndex;  // a third triangle on the edge
      found = s;
      break;
    }
  }
  return found;
}

// The edge of the prepared triangle f whose neighbour the probe's foot has
// likely crossed into, guessed without solving: the probe carried onto the
// triangle's plane along the interpolated normal at `hint` (the last
// answer's weights on f), where one weight of the point reached is negative
// and the other two are not. The weights are compared scaled by their
// common denominator, so no division is made. -1: no guess (the point is
// inside, near a corner, or the normal there is parallel to the plane).
// Since the normal at the new foot is not the one at `hint`, the guess can
// be wrong; the walk checks it (see walk).
int guessed_exit(const TriangleFrame& f, const Vec3& probe, const Vec3& hint) {
  const Vec3 nh = hint[0] * f.n[0] + hint[1] * f.n[1] + hint[2] * f.n[2];
  const double den = f.k0.dot(nh);  // (e1 x e2) . nh
  if (!(den > 0)) return -1;
  const Eigen::Vector2d uv = cramer_weights_scaled(probe - f.p0, f.e1, f.e2, nh);
  const double u = uv[0], v = uv[1], w = den - u - v;
  if (w < 0) return u >= 0 && v >= 0 ? 0 : -1;
  if (u < 0) return w >= 0 && v >= 0 ? 1 : -1;
  if (v < 0) return w >= 0 && u >= 0 ? 2 : -1;
  return -1;
}

// Where a walk's answer has to be for its caller to take it: within
// `radius` (m) of `center`. A triangle is beyond it when its first corner is
// farther than radius plus its longest edge: every point of the triangle is
// within the longest edge of that corner. Compared squared without a root:
// (r + l)^2 <= 2 r^2 + 2 l^2, with 1e-9 more for round-off, so a triangle
// called beyond is beyond.
struct Reach {
  Vec3 center;
  double radius_sq;  // m^2
  bool beyond(const TriangleFrame& f) const {
    return (f.p0 - center).squaredNorm() > (2 + 2e-9) * (radius_sq + f.longest_sq);
  }
};

// The walk of walk_surface_point, preparing each triangle in `frames`
// (where one already prepared for this mesh is kept). With
// `max_move_from` set, it first declines when the probe is farther from that
// point than the longest edge of the start triangle (a jump: the tree is the
// better start). Returns true with the answer in `sp` and the triangle's
// vertex nearest to the probe in `nearest_vertex`; on false `sp` holds
// nothing of use (or the foot it declined, above or too deep: written in
// place, so that an answer is never copied). With `trace`, records the
// triangles visited and which of them would repeat the answer (see
// WalkTrace).
//
// With `hint` (the last answer's weights on the start triangle) and
// `max_move_from` (where the probe was then), a probe that may have crossed
// an edge since is first looked for across the edge guessed_exit names,
// without solving the start triangle: a crossing then costs one solve, not
// two. The guess is taken only when the foot of the interpolated normal,
// which within half the focal distance moves at most twice as far as the
// probe, can have left the start triangle: when its smallest last weight,
// times the triangle's smallest height, is within twice the probe's move.
// The guess is made only from a foot (the cursor's at_foot: not from the
// proxy's point, under which the probe is deeper than half the focal
// distance). Where the neighbour's foot lies outside it across another edge
// than the one back to the start (the probe passed a corner of the start),
// the walk goes on from the neighbour, as if it had stepped there from the
// start: a crossing at a corner then costs two solves, not four (on the 1M
// sphere these crossings were 0.9% of the ticks and most of their slowest
// 1%). When the neighbour, or the walk on from it, gives no answer (the
// foot not in it, no solution, a foot above the surface or too deep, a
// border, a step back, out of steps), the walk goes back to the start and
// goes on exactly as without the guess. So it declines only where the walk
// without the guess declines, and its answer is the same, except where the
// two ways hold different feet: on a shared edge (within kInsideTolerance
// of it), where they are the same point up to round-off, or where the
// surface folds back within reach, where the answer is a foot of its own
// triangle that passed the same tests (and where the walk from the start
// declines, for example on a foot too deep, the guess may find one).
//
// With `reach`, the walk stops (declines) on the first triangle beyond it,
// before solving there: its caller takes only an answer within reach, and a
// walk that has left the reach would have to turn back to give one.
bool walk(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index start, const Vec3* max_move_from,
          FrameCache& frames, Index& nearest_vertex, SurfacePoint& sp, WalkTrace* trace = nullptr,
          const Vec3* hint = nullptr, const Reach* reach = nullptr) {
  if (trace) {
    trace->count = 0;
    trace->repeatable = false;
  }
  // Ends the walk, saying whether a new walk from a triangle visited after
  // the start would repeat its answer: yes where it stopped for what it
  // found (an answer, a decline on the last triangle, a border, a step
  // straight back, which a walk started on the last triangle takes once and
  // then stops at as this one did); no after a jump or out of steps (a new
  // walk has more).
  auto end = [&](bool repeats, WalkEnd why) {
    if (trace) {
      trace->repeatable = repeats;
      trace->end = why;
    }
    return why == WalkEnd::Answer;
  };
  // The mesh's tables, unless a walk on it has made the start's frame.
  int slot = frames.find(mesh, start);
  if (!finite(probe) || (slot < 0 && (start >= mesh.triangle_count() || mesh.normals.size() != mesh.vertex_count() ||
                                           mesh.vertex_triangles.rows() != mesh.vertex_count())))
    return end(false, WalkEnd::BadInput);
  Index t = start, previous = kNoIndex;
  // Steps: kMaxWalkSteps in all, except those that turn around a vertex of
  // valence above kFanValence (the edge crossed shares that vertex with the
  // edge crossed before), which count towards kMaxFanSteps instead.
  int steps = 0, fan_steps = 0;
  Index edge_a = kNoIndex, edge_b = kNoIndex;  // the edge crossed last
  // The start, while the walk is on the neighbour guessed_exit named
  // instead of it or gone on from there (then `previous` is set; on the
  // neighbour itself it is not); kNoIndex otherwise. (guessed_a,
  // guessed_b): the edge between them.
  Index guessed_from = kNoIndex, guessed_a = kNoIndex, guessed_b = kNoIndex;
  // Back from a wrong guess: the walk starts again on the start triangle,
  // as it would have without the guess.
  auto back = [&] {
    t = guessed_from;
    guessed_from = kNoIndex;
    previous = edge_a = edge_b = kNoIndex;
    steps = fan_steps = 0;
    if (trace) trace->count = 0;
  };
  for (bool first = true;; first = false) {
    if (trace && trace->count < WalkTrace::kCapacity) trace->triangles[trace->count++] = t;
    if (!first) slot = frames.find(mesh, t);  // (the start's was looked up above)
    if (slot < 0) {
      slot = frames.take(mesh, t);
      make_frame(mesh, t, frames.slot[slot]);
    }
    frames.last = slot;
    const TriangleFrame& f = frames.slot[slot];
    if (reach && reach->beyond(f)) {
      if (guessed_from != kNoIndex) {
        back();
        continue;
      }
      return end(false, WalkEnd::OutOfReach);
    }
    // Jump test on the start triangle: moved farther than its longest edge.
    if (first && max_move_from) {
      const double longest_sq = f.longest_sq;
      const double move_sq = (probe - *max_move_from).squaredNorm();
      if (!(move_sq <= longest_sq)) return end(false, WalkEnd::Jump);
      // The foot may have left: smallest weight times smallest height
      // (sqrt(det) / longest edge) within twice the move. Then the guess.
      if (hint && f.neighbors) {
        const double low = hint->minCoeff();
        if (!(low * low * f.det > 4 * move_sq * longest_sq)) {
          const int k = guessed_exit(f, probe, *hint);
          const Index across = k >= 0 ? mesh.triangle_neighbors[t][k] : kNoIndex;
          if (across != kNoIndex) {
            guessed_from = t;
            guessed_a = f.corners[(k + 1) % 3];
            guessed_b = f.corners[(k + 2) % 3];
            t = across;
            continue;
          }
        }
      }
    }
    Vec3 b;
    if (!solve_interpolated_normal(f, probe, b)) {
      if (guessed_from != kNoIndex) {
        back();
        continue;
      }
      return end(true, WalkEnd::Unsolved);
    }
    if (b.minCoeff() >= -kInsideTolerance) {
      // Inside: the same weights and virtual vertex as locate_surface_point's.
      b = clamped_inside(b);
      finish(f.p, f.n, t, b, probe, true, sp);
      // Still below the surface (a probe that left is for the tree to place),
      // and within half the focal distance: 4 offset^2 |dn|^2 <= |dp|^2 on every edge.
      // On the guessed neighbour only an answer is taken: a decline there
      // goes back to the start, whose own foot (where the probe is that
      // deep there may be one in each) the walk without the guess would
      // have judged.
      const double o2 = 4 * sp.offset * sp.offset;
      const bool above = !(sp.offset < 0);
      const bool too_deep = !(o2 * f.f1_sq <= f.a11 && o2 * f.f2_sq <= f.a22 && o2 * f.f3_sq <= f.e3_sq);
      if ((above || too_deep) && guessed_from != kNoIndex) {
        back();
        continue;
      }
      if (above) return end(true, WalkEnd::Above);
      if (too_deep) return end(true, WalkEnd::TooDeep);
      // The triangle's vertex nearest to the probe.
      const Vec3 d = probe - f.p0;
      const double d0 = d.squaredNorm(), d1 = (d - f.e1).squaredNorm(), d2 = (d - f.e2).squaredNorm();
      nearest_vertex = d0 <= d1 && d0 <= d2 ? f.corners[0] : (d1 <= d2 ? f.corners[1] : f.corners[2]);
      return end(true, WalkEnd::Answer);
    }
    // Outside: step across the edge opposite the most negative weight; a
    // step straight back means the solution sits in no triangle here.
    const int k = b[0] <= b[1] && b[0] <= b[2] ? 0 : (b[1] <= b[2] ? 1 : 2);
    const Index c1 = f.corners[(k + 1) % 3], c2 = f.corners[(k + 2) % 3];
    const Index next = f.neighbors ? mesh.triangle_neighbors[t][k] : across_edge(mesh, t, c1, c2);
    if (guessed_from != kNoIndex && previous == kNoIndex) {
      // On the guessed neighbour, with its foot outside it too. Where that
      // foot points back across the edge to the start (or to a border),
      // the walk starts again there, as without the guess. Otherwise the
      // foot has left both (the probe passed a corner of the start): the
      // walk goes on from the neighbour as if it had stepped there from the
      // start, so a crossing at a corner costs two solves, not four. Only
      // an answer is taken on that way; any other end goes back to the start
      // as well, so the walk declines only where the walk without the guess
      // does.
      if (next == kNoIndex || next == guessed_from) {
        back();
        continue;
      }
      previous = guessed_from;
      edge_a = guessed_a;
      edge_b = guessed_b;
      steps = 1;
    }
    const bool ends = next == kNoIndex || next == previous;
    const Index pivot = c1 == edge_a || c1 == edge_b ? c1 : (c2 == edge_a || c2 == edge_b ? c2 : kNoIndex);
    const bool fan = !ends && pivot != kNoIndex && mesh.vertex_triangles.row(pivot).size() > kFanValence;
    const bool out_of_steps = !ends && (fan ? ++fan_steps > kMaxFanSteps : ++steps >= kMaxWalkSteps);
    if ((ends || out_of_steps) && guessed_from != kNoIndex) {  // gone on from the guess
      back();
      continue;
    }
    if (next == kNoIndex) return end(true, WalkEnd::Border);
    if (next == previous) return end(true, WalkEnd::SteppedBack);
    if (out_of_steps) return end(false, WalkEnd::OutOfSteps);
    edge_a = c1;
    edge_b = c2;
    previous = t;
    t = next;
  }
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
  // when some point of theirs could be nearer than the answer so far. The
  // distances of the triangles seen are kept (in visit order) so that no
  // distance is computed twice; past kSeen triangles they are recomputed.
  // 1024: a vertex where hundreds of thin triangles meet is searched in one
  // pass (past kSeen each distance is computed twice); 12 KB of stack.
  constexpr std::size_t kSeen = 1024;
  std::array<Index, kSeen> seen_t;
  std::array<double, kSeen> seen_d2;
  std::size_t n_seen = 0;
  bool overflow = false;
  Candidate best;
  Vec3 unused;
  auto search_set = [&](bool ring, bool wide) {
    const std::size_t begin = n_seen;
    bool set_overflow = false;
    Index first = kNoIndex;
    double first_d2 = std::numeric_limits<double>::infinity();
    visit(mesh, nearest_vertex, ring, wide, [&](Index t) {
      const double d2 = closest_dist2(mesh, t, probe, unused);
      if (n_seen < kSeen) {
        seen_t[n_seen] = t;
        seen_d2[n_seen++] = d2;
      } else {
        set_overflow = true;
      }
      if (d2 < first_d2) {
        first_d2 = d2;
        first = t;
      }
    });
    overflow = overflow || set_overflow;
    if (first == kNoIndex) return;
    try_inside(mesh, first, probe, best);
    if (!set_overflow) {
      for (std::size_t i = begin; i < n_seen; ++i) {
        const Index t = seen_t[i];
        if (t == first || (best.triangle != kNoIndex && seen_d2[i] >= best.distance_sq)) continue;
        try_inside(mesh, t, probe, best);
      }
      return;
    }
    visit(mesh, nearest_vertex, ring, wide, [&](Index t) {
      if (t == first) return;
      if (best.triangle != kNoIndex && closest_dist2(mesh, t, probe, unused) >= best.distance_sq) return;
      try_inside(mesh, t, probe, best);
    });
  };
  search_set(true, false);
  if (best.triangle == kNoIndex) search_set(false, true);
  sp.inside = best.triangle != kNoIndex;
  // None contains it: the closest point of those triangles, clamped (the
  // first nearest in visit order, from the distances kept).
  if (!sp.inside) {
    if (!overflow) {
      std::size_t arg = kSeen;
      double d_min = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < n_seen; ++i)
        if (seen_d2[i] < d_min) {
          d_min = seen_d2[i];
          arg = i;
        }
      if (arg < n_seen) {
        Vec3 b;
        const double d2 = closest_dist2(mesh, seen_t[arg], probe, b);
        best = {seen_t[arg], b, d2};
      }
    } else {
      visit(mesh, nearest_vertex, true, true, [&](Index t) { try_closest(mesh, t, probe, best); });
    }
  }
  if (best.triangle == kNoIndex) return sp;

  return finish(mesh, best.triangle, best.b, probe, sp.inside);
}

SurfacePoint walk_surface_point(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index start_triangle) {
  Index unused = kNoIndex;
  FrameCache frames;
  SurfacePoint sp;
  return walk(mesh, probe, start_triangle, nullptr, frames, unused, sp) ? sp : SurfacePoint{};
}

SurfacePoint walk_surface_point(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index start_triangle,
                                WalkTrace& trace) {
  Index unused = kNoIndex;
  FrameCache frames;
  SurfacePoint sp;
  return walk(mesh, probe, start_triangle, nullptr, frames, unused, sp, &trace) ? sp : SurfacePoint{};
}

namespace {

// The walk of the contact queries from `start` (with the jump test from
// `jump_from` when given) into `sp`, not yet committed to the cursor.
bool walk_from(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index start, const Vec3* jump_from,
               ContactCursor& cursor, Index& nearest, SurfacePoint& sp, WalkTrace* trace = nullptr,
               const Reach* reach = nullptr) {
  const Vec3* hint = start == cursor.triangle && cursor.at_foot ? &cursor.barycentric : nullptr;
  return walk(mesh, probe, start, jump_from, cursor.frames, nearest, sp, trace, hint, reach);
}

// Completes `ans` (path Walk), whose surface holds a walk's answer, and
// moves the cursor there.
void commit_walk(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index nearest, ContactCursor& cursor,
                 ContactAnswer& ans) {
  const SurfacePoint& sp = ans.surface;
  ans.nearest_vertex = nearest;
  ans.path = ContactPath::Walk;
  cursor.triangle = sp.triangle;
  cursor.barycentric = sp.barycentric;
  cursor.at_foot = true;
  cursor.probe = probe;
  // Ask for the triangle across the nearest edge now, and once it has
  // arrived (the next query on this triangle) for its far corner, so that
  // stepping across costs no wait on memory. No effect on results.
  const Vec3& b = sp.barycentric;
  const int k = b[0] <= b[1] && b[0] <= b[2] ? 0 : (b[1] <= b[2] ? 1 : 2);
  const TriangleFrame& f = cursor.frames.slot[cursor.frames.last];  // the answer's triangle
  const Index next = f.neighbors ? mesh.triangle_neighbors[cursor.triangle][k] : kNoIndex;
  if (next != kNoIndex) {
    if (next == cursor.ahead) {
      const Index far = mesh.triangles[next][0] + mesh.triangles[next][1] + mesh.triangles[next][2] -
                        f.corners[(k + 1) % 3] - f.corners[(k + 2) % 3];
      if (far < mesh.vertex_count()) {
        __builtin_prefetch(&mesh.positions[far]);
        __builtin_prefetch(&mesh.normals[far]);
      }
    } else {
      __builtin_prefetch(&mesh.triangles[next]);
    }
  }
  cursor.ahead = next;
}

// The walk branch of query_contact: walks and, when it answers, commits.
bool walk_answer(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index start, const Vec3* jump_from,
                 ContactCursor& cursor, ContactAnswer& ans) {
  Index nearest = kNoIndex;
  if (!walk_from(mesh, probe, start, jump_from, cursor, nearest, ans.surface)) return false;
  commit_walk(mesh, probe, nearest, cursor, ans);
  return true;
}

}  // namespace

ContactAnswer query_contact(const mesh::SurfaceMesh& mesh, const VertexTree& tree, const Vec3& probe,
                            ContactCursor& cursor, bool in_contact) {
  ContactAnswer ans;
  if (!finite(probe)) return ans;
  // In contact: walk from the last triangle (declines on a jump).
  if (in_contact && cursor.triangle < mesh.triangle_count()) {
    if (walk_answer(mesh, probe, cursor.triangle, &cursor.probe, cursor, ans)) return ans;
  }
  // Otherwise: exact nearest vertex by the tree's local search, then the
  // surface point around it.
  const NearestVertex nv = tree.nearest_local(probe, cursor.tree);
  cursor.triangle = kNoIndex;
  if (nv.vertex == kNoIndex || nv.vertex >= mesh.vertex_count()) {
    ans = ContactAnswer{};
    return ans;
  }
  ans.nearest_vertex = nv.vertex;
  ans.surface = locate_surface_point(mesh, probe, nv.vertex);
  ans.path = ContactPath::Tree;
  cursor.triangle = ans.surface.triangle;
  cursor.barycentric = ans.surface.barycentric;
  cursor.at_foot = ans.surface.inside;
  cursor.probe = probe;
  // Above the surface: how far the probe may move before it can reach it
  // (the tree's bound, less 1 nm for round-off).
  if (ans.surface.triangle != kNoIndex && ans.surface.offset > 0) {
    const double clearance = tree.clearance(probe, kMaxClearance) - kProxyTolerance;
    if (clearance > 0) {
      cursor.clear_from = probe;
      cursor.clearance = clearance;
      cursor.clear_surface = ans.surface;
      cursor.clear_vertex = nv.vertex;
    }
  }
  return ans;
}

namespace {

// slide_surface_point into `sp`: inlined into the tick's query, so that the
// slid point does not go through memory on its way back (see walk).
// start_normal, when given: the unit interpolated normal at `barycentric` on
// `triangle`, computed as finish computes it (interpolate over the corners'
// normals, divided by its length, that length positive and finite). It is
// taken only where the weights the slide starts from are `barycentric`
// itself, bit for bit (as when they sum to exactly 1), so the answer is the
// same with it or without it; the proxy's path has it already and saves a
// square root and a division (elsewhere it is dropped, at no gain).
[[gnu::always_inline]] inline void slide(const mesh::SurfaceMesh& mesh, Index triangle, const Vec3& barycentric,
                                         const Vec3& displacement, const Vec3& probe, SurfacePoint& sp,
                                         const Vec3* start_normal = nullptr) {
  if (triangle >= mesh.triangle_count() || mesh.normals.size() != mesh.vertex_count() ||
      mesh.vertex_triangles.rows() != mesh.vertex_count() || !finite(displacement) || !finite(probe)) {
    sp = SurfacePoint{};
    return;
  }
  // Weights on the start triangle: the given ones when they are weights.
  Vec3 b = weights_or_centroid(barycentric);
  b /= b.sum();
  const bool neighbors = mesh.triangle_neighbors.size() == mesh.triangle_count();
  Index t = triangle, previous = kNoIndex;
  Vec3 d = displacement;  // motion still to make, m
  double length = -1;     // its length along the surface, m (set on the first triangle)
  // The caller's normal at the start is this one only where the weights are
  // the caller's own, bit for bit (as when they sum to exactly 1).
  if (start_normal && !(b == barycentric)) start_normal = nullptr;
  if (d.x() == 0 && d.y() == 0 && d.z() == 0) {
    // No motion: the loop below would stop on the first triangle with the
    // weights unchanged (no length to slide).
    if (!start_normal) {
      finish(mesh, t, b, probe, true, sp);
      return;
    }
    // finish's virtual vertex, with the normal the caller computed the same way.
    finish_at(t, b, interpolate(mesh.positions, mesh.triangles[t], b), *start_normal, probe, true, sp);
    return;
  }
  for (int step = 0; step < kMaxSlideSteps; ++step) {
    const mesh::Triangle& tri = mesh.triangles[t];
    const Vec3& p0 = mesh.positions[tri[0]];
    const Vec3 e1 = mesh.positions[tri[1]] - p0, e2 = mesh.positions[tri[2]] - p0;
    Vec3 nf = e1.cross(e2);
    const double area2 = nf.norm();
    if (!(area2 > 0) || !std::isfinite(area2)) break;  // degenerate: stay
    nf /= area2;
    // The motion in this triangle's plane: on the first triangle the part
    // tangent to the interpolated normal N at the point, carried into the
    // plane along N (so the motion seen across N is kept: a probe moving
    // along N does not move the point); then the remainder turned into each
    // new plane, length kept.
    Vec3 dt;
    if (length < 0) {
      Vec3 nn;
      if (start_normal) {
        nn = *start_normal;
      } else {
        const Vec3 nb = interpolate(mesh.normals, tri, b);
        const double nl = nb.norm();
        nn = nl > 0 && std::isfinite(nl) ? Vec3(nb / nl) : nf;
      }
      const double cos_nf = nn.dot(nf);
      const Vec3 across = d - d.dot(nn) * nn;
      dt = cos_nf > 0.1 ? Vec3(across - (across.dot(nf) / cos_nf) * nn) : Vec3(across - across.dot(nf) * nf);
    } else {
      dt = d - d.dot(nf) * nf;
    }
    const double l = dt.norm();
    if (length < 0) {
      length = l;
    } else if (l > 0) {
      dt *= length / l;
    } else {
      break;  // the motion is along this triangle's normal: nothing to slide
    }
    if (!(length > 0)) break;
    // The change of weights: dt = du e1 + dv e2 in the plane.
    const double a11 = e1.dot(e1), a12 = e1.dot(e2), a22 = e2.dot(e2);
    const double det = a11 * a22 - a12 * a12;
    if (!(det > 0)) break;
    const double r1 = dt.dot(e1), r2 = dt.dot(e2);
    const double du = (a22 * r1 - a12 * r2) / det, dv = (a11 * r2 - a12 * r1) / det;
    const Vec3 db(-du - dv, du, dv);
    const Vec3 bt = b + db;
    if (bt.minCoeff() >= 0) {
      b = bt;
      break;  // the motion ends in this triangle
    }
    // The first weight to reach zero along the way: the edge opposite it is crossed.
    double s = 1;
    int k = -1;
    for (int j = 0; j < 3; ++j) {
      if (db[j] < 0) {
        const double sj = b[j] / -db[j];
        if (sj < s) {
          s = sj;
          k = j;
        }
      }
    }
    if (k < 0) {
      b = bt;
      break;
    }
    b += s * db;
    b[k] = 0;
    b = b.cwiseMax(0.0);
    b /= b.sum();
    length *= 1 - s;
    d = (1 - s) * dt;
    const Index next = neighbors ? mesh.triangle_neighbors[t][k]
                                 : across_edge(mesh, t, tri[(k + 1) % 3], tri[(k + 2) % 3]);
    if (next >= mesh.triangle_count()) break;  // a border: stay on the edge
    // The point is on the shared edge: its two corners keep their weights.
    const mesh::Triangle& nt = mesh.triangles[next];
    Vec3 nb = Vec3::Zero();
    for (int m = 0; m < 3; ++m)
      for (int j = 0; j < 3; ++j)
        if (nt[m] == tri[j]) nb[m] = b[j];
    if (!(nb.sum() > 0)) break;
    b = nb / nb.sum();
    // Back across the edge it came in by, without having moved (s = 0: the
    // weight that is zero on that edge would go negative at once): at a
    // crease whose planes on both sides turn the motion towards the edge it
    // would cross back and forth with no progress until kMaxSlideSteps (the
    // point never moving). It stays on the edge, on the side it came from.
    const bool turned_back = s == 0 && next == previous;
    previous = t;
    t = next;
    if (turned_back) break;
  }
  finish(mesh, t, b, probe, true, sp);
}

}  // namespace

SurfacePoint slide_surface_point(const mesh::SurfaceMesh& mesh, Index triangle, const Vec3& barycentric,
                                 const Vec3& displacement, const Vec3& probe) {
  SurfacePoint sp;
  slide(mesh, triangle, barycentric, displacement, probe, sp);
  return sp;
}

ContactAnswer query_contact_from_root(const mesh::SurfaceMesh& mesh, const VertexTree& tree, const Vec3& probe,
                                      ContactCursor& cursor) {
  cursor.tree = SearchCursor{};
  return query_contact(mesh, tree, probe, cursor, false);
}

ContactAnswer track_contact(const mesh::SurfaceMesh& mesh, const VertexTree& tree, const Vec3& probe,
                            ContactCursor& cursor, bool in_contact) {
  // One answer, returned from every path (so that it is built in place).
  ContactAnswer ans;
  if (!finite(probe)) return ans;
  if (!in_contact || cursor.triangle >= mesh.triangle_count()) {
    // Still inside the ball around the last answer above the surface: still
    // above it, no search.
    if (!in_contact && cursor.clearance > 0 && (probe - cursor.clear_from).squaredNorm() < cursor.clearance * cursor.clearance) {
      ans.surface = cursor.clear_surface;
      ans.surface.offset = (probe - ans.surface.point).dot(ans.surface.normal);
      ans.nearest_vertex = cursor.clear_vertex;
      ans.path = ContactPath::Clear;
      return ans;
    }
    ans = query_contact(mesh, tree, probe, cursor, false);
    return ans;
  }
  // The proxy before this query, and how far a walk's answer may be from it:
  // within half the focal distance the foot of the interpolated normal moves
  // at most twice as far as the probe, so an answer farther away is another
  // foot (another sheet, a fold, another root beyond a focal point).
  const Index proxy_triangle = cursor.triangle;
  const Vec3 proxy_weights = weights_or_centroid(cursor.barycentric);
  const Vec3 last_probe = cursor.probe;
  const mesh::Triangle& pt = mesh.triangles[proxy_triangle];
  const Vec3 proxy_point = interpolate(mesh.positions, pt, proxy_weights);
  // Compared squared first: |a|^2 <= 4 |m|^2 gives |a| <= 2 |m| <= reach
  // exactly in floating point (sqrt is correctly rounded and monotone, and
  // sqrt(4 x) = 2 sqrt(x)), so the square roots are taken only otherwise.
  const double move_sq = (probe - last_probe).squaredNorm();
  auto continuous = [&](const SurfacePoint& sp) {
    const double gap_sq = (sp.point - proxy_point).squaredNorm();
    return gap_sq <= 4 * move_sq || std::sqrt(gap_sq) <= 2 * std::sqrt(move_sq) + kProxyTolerance;
  };
  // The walk from the last triangle, as query_contact's, its answer (or a
  // foot it declined) in ans.surface.
  Index nearest = kNoIndex;
  WalkTrace trace;
  const bool answered = walk_from(mesh, probe, proxy_triangle, &last_probe, cursor, nearest, ans.surface, &trace);
  if (answered && continuous(ans.surface)) {
    commit_walk(mesh, probe, nearest, cursor, ans);
    return ans;
  }
  // Declined. Where the walk answered, only farther from the proxy than
  // the foot can have moved, the proxy lags behind the foot (it held in
  // its cone during a deeper press, below): it chases the foot along the
  // surface, no more than kProxyChase times as far as the probe moved
  // across the normal this tick, and the walk takes over again once the
  // foot is within its reach (step 1), so the contact point never jumps.
  // Where the walk did not answer, the proxy stays while the probe is
  // within the cone of half angle atan(kProxyCone) below it; beyond, it
  // slides along the surface towards the probe's side by the excess, with
  // the same limit (so it cannot run away where the probe is deeper than
  // the centre of curvature), never leaving the surface.
  // (Read only from normals that are there: without them the walk above
  // declined, and the slide below declines too.)
  const Vec3 pn = mesh.normals.size() == mesh.vertex_count() ? interpolate(mesh.normals, pt, proxy_weights) : Vec3::Zero();
  const double pn_len = pn.norm();
  Vec3 move = Vec3::Zero();
  Vec3 n = Vec3::Zero();  // the unit normal at the proxy (when pn has a length), for the slide too
  const bool has_normal = pn_len > 0 && std::isfinite(pn_len);
  if (has_normal) {
    n = pn / pn_len;
    const Vec3 motion = probe - last_probe;
    // How far the probe moved across n (m), taken only where it bounds a move.
    auto across = [&] { return (motion - motion.dot(n) * n).norm(); };
    if (answered) {
      const Vec3 to_foot = ans.surface.point - proxy_point;
      const double gap = to_foot.norm();
      if (gap > 0) move = (std::min(gap, kProxyChase * across()) / gap) * to_foot;
    } else {
      const Vec3 rel = probe - proxy_point;
      const double depth = -rel.dot(n);
      const Vec3 lateral = rel + depth * n;
      const double lateral_len = lateral.norm();
      const double excess = lateral_len - kProxyCone * std::max(depth, 0.0);
      if (excess > 0 && lateral_len > 0) move = (std::min(excess, kProxyChase * across()) / lateral_len) * lateral;
    }
  }
  SurfacePoint slid;
  slide(mesh, proxy_triangle, proxy_weights, move, probe, slid, has_normal ? &n : nullptr);
  if (slid.triangle == kNoIndex) {  // unusable mesh data
    ans = query_contact(mesh, tree, probe, cursor, false);
    return ans;
  }
  // Near the slid point the walk may answer again (after a jump, or once the
  // probe is back within half the focal distance). Where the first walk
  // passed through the slid triangle and stopped for what it found, a walk
  // from there would end as it did, with an answer not taken above: skipped
  // (on the cingulate gyrus, 7 in 10 of these walks, each several triangles).
  // Only an answer within 2 |move| + kProxyTolerance of the proxy is taken
  // (continuous), so this walk stops once it is on a triangle out of that
  // reach (squared: (2 m + e)^2 <= 8 m^2 + 2 e^2). On the cingulate gyrus,
  // where a quarter of the vertices have more than kFanValence triangles
  // (steps around them do not count towards kMaxWalkSteps), it could
  // otherwise go on for ten triangles or more and end as a decline.
  if (slid.triangle != proxy_triangle && !trace.repeats_from(slid.triangle)) {
    const Reach reach{proxy_point, 8 * move_sq + 2 * kProxyTolerance * kProxyTolerance};
    if (walk_from(mesh, probe, slid.triangle, nullptr, cursor, nearest, ans.surface, nullptr, &reach) &&
        continuous(ans.surface)) {
      commit_walk(mesh, probe, nearest, cursor, ans);
      return ans;
    }
  }
  // The probe came out above the proxy. Across a convex fold it may still be
  // inside under another part of the surface: before letting go, the tree's
  // answer (the nearest vertex's surface point) decides; when the probe is
  // below that, the contact goes on there (its depth, like the proxy's, is
  // near zero at this moment, so the force does not jump).
  if (!(slid.offset < 0)) {
    // Out of contact query_contact walks no triangle, so only the cursor's
    // state is kept aside (not its prepared triangles, 8 KB).
    const ContactCursorState kept = cursor;
    const ContactAnswer fresh = query_contact_from_root(mesh, tree, probe, cursor);
    if (fresh.surface.triangle != kNoIndex && fresh.surface.offset < 0) {
      ans = fresh;
      return ans;
    }
    const SearchCursor leaf = cursor.tree;
    static_cast<ContactCursorState&>(cursor) = kept;
    cursor.tree = leaf;
  }
  ans.surface = slid;
  const mesh::Triangle& tri = mesh.triangles[slid.triangle];
  const Vec3& b = slid.barycentric;
  ans.nearest_vertex = tri[heaviest_corner(b)];
  ans.path = ContactPath::Proxy;
  cursor.triangle = slid.triangle;
  cursor.barycentric = slid.barycentric;
  cursor.at_foot = false;
  cursor.probe = probe;
  cursor.ahead = kNoIndex;
  return ans;
}

HeightCheck height_check(const SurfacePoint& sp, const Vec3& heights, bool was_in_contact) {
  // 1-D test along the interpolated normal (section III.C), hysteretic: a
  // contact that exists holds while the probe is below the rest surface.
  HeightCheck hc;
  hc.surface_height = sp.barycentric.dot(heights);
  hc.depth = -sp.offset;
  hc.in_contact = sp.offset < 0 && (was_in_contact || sp.offset <= hc.surface_height);
  return hc;
}

}  // namespace palpa::collision
