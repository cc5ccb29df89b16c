// Procedural meshes. Spheres and the default organ share one construction: a
// cube whose faces are split into n x n cells, with the lattice points pushed
// onto the unit sphere (equi-angular, so cells are nearly square). A sphere
// scales those directions by its radius; the organ moves each one out along
// its ray to where the organ's implicit function changes sign.

#include "mesh/generate.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace palpa::mesh {
namespace {

// ---------------------------------------------------------------------------
// The cube surface lattice {0..n}^3 with at least one coordinate 0 or n has
// 6 n^2 + 2 points. Each gets an index without a lookup table: the bottom face
// (z = 0), then one ring of 4 n points per inner layer z = 1..n-1, then the top.
struct CubeLattice {
  Index n;

  std::size_t size() const { return 6 * std::size_t(n) * n + 2; }

  // Position of (x, y) on the boundary of the (n+1) x (n+1) square, counter-clockwise from (0, 0).
  Index ring(Index x, Index y) const {
    if (y == 0 && x < n) return x;
    if (x == n && y < n) return n + y;
    if (y == n && x > 0) return 2 * n + (n - x);
    return 3 * n + (n - y);  // x == 0, y > 0
  }

  Index index(Index x, Index y, Index z) const {
    const Index side = n + 1;
    if (z == 0) return x * side + y;
    if (z == n) return side * side + (n - 1) * 4 * n + x * side + y;
    return side * side + (z - 1) * 4 * n + ring(x, y);
  }
};

// Unit directions and outward triangles of the cube-sphere with n cells per cube edge.
struct CubeSphere {
  std::vector<Vec3> directions;
  std::vector<Triangle> triangles;
};

CubeSphere make_cube_sphere(Index n) {
  const CubeLattice lattice{n};
  CubeSphere s;
  s.directions.resize(lattice.size());
  s.triangles.reserve(12 * std::size_t(n) * n);

  // Equi-angular warp of a lattice coordinate to [-1, 1].
  std::vector<double> warp(n + 1);
  for (Index i = 0; i <= n; ++i) warp[i] = std::tan((2.0 * i / n - 1.0) * std::numbers::pi / 4);

  // The six faces: which lattice axis is fixed and at which end, and which
  // axes the face's (u, v) run along, chosen so that u x v points outward.
  struct Face {
    int fixed, u, v;
    Index at;
  };
  const Face faces[6] = {{0, 1, 2, n}, {0, 2, 1, 0}, {1, 2, 0, n}, {1, 0, 2, 0}, {2, 0, 1, n}, {2, 1, 0, 0}};

  for (const Face& f : faces) {
    auto point = [&](Index u, Index v) {
      Index c[3];
      c[f.fixed] = f.at;
      c[f.u] = u;
      c[f.v] = v;
      return std::array<Index, 3>{c[0], c[1], c[2]};
    };
    // Directions of this face's lattice points (shared points get the same value twice).
    for (Index u = 0; u <= n; ++u)
      for (Index v = 0; v <= n; ++v) {
        const auto c = point(u, v);
        s.directions[lattice.index(c[0], c[1], c[2])] = Vec3(warp[c[0]], warp[c[1]], warp[c[2]]).normalized();
      }
    // Two counter-clockwise triangles per cell; the diagonal mirrors across the
    // face centre so the pattern is symmetric.
    for (Index u = 0; u < n; ++u)
      for (Index v = 0; v < n; ++v) {
        auto id = [&](Index a, Index b) {
          const auto c = point(a, b);
          return lattice.index(c[0], c[1], c[2]);
        };
        const Index a = id(u, v), b = id(u + 1, v), c = id(u + 1, v + 1), d = id(u, v + 1);
        if ((2 * u + 1 < n) == (2 * v + 1 < n)) {
          s.triangles.push_back({a, b, c});
          s.triangles.push_back({a, c, d});
        } else {
          s.triangles.push_back({a, b, d});
          s.triangles.push_back({b, c, d});
        }
      }
  }
  return s;
}

// Cells per cube edge for about `target` vertices (6 n^2 + 2 of them).
Index cells_for(std::size_t target) {
  const double n = std::round(std::sqrt(std::max(0.0, (double(target) - 2.0) / 6.0)));
  return Index(std::max(1.0, n));
}

// ---------------------------------------------------------------------------
// Building blocks of the organ's implicit function (all lengths in m).

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

// Approximate signed distance to an axis-aligned ellipsoid (exact on the
// surface, a good bound near it).
double ellipsoid(const Vec3& p, const Vec3& centre, const Vec3& radii) {
  const Vec3 q = p - centre;
  const double k0 = q.cwiseQuotient(radii).norm();
  const double k1 = q.cwiseQuotient(radii.cwiseProduct(radii)).norm();
  return k1 > 0 ? k0 * (k0 - 1.0) / k1 : -radii.minCoeff();
}

// Polynomial smooth minimum / maximum with blend width k.
double smooth_min(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - 0.25 * h * h * k;
}
double smooth_max(double a, double b, double k) { return -smooth_min(-a, -b, k); }

// Frame: x towards the patient's right (the big right lobe), y backwards
// (posterior), z up (cranial). The star centre lies in the thick part, near the middle.
const Vec3 kCenter(0.012, 0.004, 0.004);
constexpr double kFar = 0.30;  // beyond the organ in every direction, m

// The body: an ellipsoid-like wedge whose thickness, depth and height change
// along x, from the thick, rounded right lobe to the thin left lobe tip.
double body(const Vec3& p) {
  const double s = smoothstep(-0.10, 0.07, p.x());          // 0 at the left tip, 1 in the right lobe
  const double half_length = p.x() > 0 ? 0.088 : 0.122;       // right / left of the centre plane
  const double depth = 0.056 + 0.022 * s;                     // half extent front to back
  const double height = 0.016 + 0.050 * s;                    // half thickness
  const double lift = 0.022 * (1.0 - s);                      // the left lobe sits higher
  const double back = 0.012 * s;                              // the right lobe reaches further back
  const Vec3 q(p.x() / half_length, (p.y() - back) / depth, (p.z() - lift) / height);
  return (q.norm() - 1.0) * height;  // scaled by the local thickness: close to a distance near the surface
}

}  // namespace

// ---------------------------------------------------------------------------
// The default organ: a liver-like wedge with a domed diaphragmatic (upper)
// surface, a flatter visceral (lower) surface with a hollow, the falciform
// groove between the lobes on top, the umbilical notch in the front edge and
// a concave back border.
double organ_implicit(const Vec3& p) {
  double f = body(p);

  // Visceral surface: cut by a tilted plane (higher towards the right and the
  // front), then hollowed by a large sphere below the right lobe.
  const Vec3 under_normal = Vec3(0.30, -0.20, -1.0).normalized();
  f = smooth_max(f, under_normal.dot(p - Vec3(0.0, 0.0, -0.032)), 0.012);
  f = smooth_max(f, -ellipsoid(p, Vec3(0.045, 0.030, -0.150), Vec3(0.110, 0.110, 0.110)), 0.015);

  // Falciform groove across the top between the lobes, and the umbilical
  // notch where it meets the front edge.
  f = smooth_max(f, -ellipsoid(p, Vec3(-0.030, 0.0, 0.068), Vec3(0.022, 0.110, 0.024)), 0.008);
  f = smooth_max(f, -ellipsoid(p, Vec3(-0.028, -0.068, -0.008), Vec3(0.011, 0.024, 0.030)), 0.008);

  // Posterior border: the hollow where the vena cava and spine lie.
  f = smooth_max(f, -ellipsoid(p, Vec3(-0.004, 0.090, 0.000), Vec3(0.026, 0.032, 0.090)), 0.010);
  return f;
}

Vec3 organ_center() { return kCenter; }

// ---------------------------------------------------------------------------
SurfaceMesh make_sphere(std::size_t target_vertices, double radius, const Vec3& center) {
  CubeSphere s = make_cube_sphere(cells_for(target_vertices));
  SurfaceMesh mesh;
  mesh.positions.resize(s.directions.size());
  for (std::size_t i = 0; i < s.directions.size(); ++i) mesh.positions[i] = center + radius * s.directions[i];
  mesh.triangles = std::move(s.triangles);
  finalize(mesh);
  return mesh;
}

SurfaceMesh make_plane(int nx, int ny, double spacing) {
  SurfaceMesh mesh;
  nx = std::max(nx, 2);
  ny = std::max(ny, 2);
  // Vertices row by row (x fastest), centred on the origin.
  const double x0 = -0.5 * spacing * (nx - 1), y0 = -0.5 * spacing * (ny - 1);
  mesh.positions.reserve(std::size_t(nx) * ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) mesh.positions.emplace_back(x0 + spacing * i, y0 + spacing * j, 0.0);
  // Two counter-clockwise (seen from +z) triangles per cell.
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const Index a = Index(j * nx + i), b = a + 1, c = a + Index(nx) + 1, d = a + Index(nx);
      mesh.triangles.push_back({a, b, c});
      mesh.triangles.push_back({a, c, d});
    }
  finalize(mesh);
  return mesh;
}

SurfaceMesh make_organ(std::size_t target_vertices) {
  CubeSphere s = make_cube_sphere(cells_for(target_vertices));
  SurfaceMesh mesh;
  mesh.positions.resize(s.directions.size());
  // Along each ray the function is negative at the centre and positive at
  // kFar, with one sign change: bisect to it (2^-45 of 0.3 m is far below float precision).
  for (std::size_t i = 0; i < s.directions.size(); ++i) {
    const Vec3& d = s.directions[i];
    double inside = 0.0, outside = kFar;
    for (int it = 0; it < 45; ++it) {
      const double mid = 0.5 * (inside + outside);
      (organ_implicit(kCenter + mid * d) < 0 ? inside : outside) = mid;
    }
    mesh.positions[i] = kCenter + 0.5 * (inside + outside) * d;
  }
  mesh.triangles = std::move(s.triangles);
  finalize(mesh);
  return mesh;
}

}  // namespace palpa::mesh
