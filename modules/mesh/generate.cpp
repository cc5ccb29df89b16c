// Procedural meshes. Spheres and the default organ share one construction: a
// cube whose faces are split into n x n cells, with the lattice points pushed
// onto the unit sphere (equi-angular, so cells are nearly square). A sphere
// scales those directions by its radius; the organ shapes (the default organ,
// the breast, the abdomen) move each one out along its ray from the shape's
// centre to where the shape's implicit function changes sign.

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

constexpr double kFar = 0.30;  // beyond every organ shape in every direction from its centre, m

// A shape star-shaped around `centre`: along each cube-sphere ray the function
// is negative at the centre and positive at kFar, with one sign change: bisect
// to it (2^-45 of 0.3 m is far below float precision). The triangles keep the
// cube-sphere's outward orientation, since the radial map preserves it.
SurfaceMesh sample_star_shape(std::size_t target_vertices, double (*implicit)(const Vec3&), const Vec3& centre) {
  CubeSphere s = make_cube_sphere(cells_for(target_vertices));
  SurfaceMesh mesh;
  mesh.positions.resize(s.directions.size());
  for (std::size_t i = 0; i < s.directions.size(); ++i) {
    const Vec3& d = s.directions[i];
    double inside = 0.0, outside = kFar;
    for (int it = 0; it < 45; ++it) {
      const double mid = 0.5 * (inside + outside);
      (implicit(centre + mid * d) < 0 ? inside : outside) = mid;
    }
    mesh.positions[i] = centre + 0.5 * (inside + outside) * d;
  }
  mesh.triangles = std::move(s.triangles);
  finalize(mesh);
  return mesh;
}

// ---------------------------------------------------------------------------
// Building blocks of the organ shapes' implicit functions (all lengths in m).

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
// The breast: the upper half of an ellipsoid standing on the chest wall (the
// z = 0 plane), its lower pole (-y) fuller than the upper and its apex sheared
// towards -y (the droop), a raised areola and a nipple added as height bumps
// on the apex, and the chest-wall side cut flat with a rounded rim.
namespace {
constexpr double kBreastHalfX = 0.070;      // half width at the base, m
constexpr double kBreastUpper = 0.066;      // base radius towards +y (cranial), m
constexpr double kBreastLower = 0.072;      // base radius towards -y (the fuller lower pole), m
constexpr double kBreastDome = 0.0535;      // dome height without areola and nipple, m
constexpr double kBreastDroop = 0.010;      // apex offset towards -y, m
constexpr double kBreastRim = 0.008;        // blend width of the rim rounding, m
constexpr double kAreolaHeight = 0.0015;    // m
constexpr double kAreolaRadius = 0.016;     // flat top, then a smooth edge out to kAreolaEdge, m
constexpr double kAreolaEdge = 0.022;       // m
constexpr double kNippleHeight = 0.005;     // m
constexpr double kNippleRadius = 0.0075;    // support radius of its (1 - r^2/R^2)^3 profile, m
const Vec3 kBreastCenter(0.0, -0.004, 0.025);

// The nipple-areola complex as a height above the dome, at horizontal distance r from the apex axis.
double nipple_areola_height(double r) {
  const double u2 = std::min(1.0, (r * r) / (kNippleRadius * kNippleRadius));
  const double nipple = kNippleHeight * (1.0 - u2) * (1.0 - u2) * (1.0 - u2);
  const double areola = kAreolaHeight * (1.0 - smoothstep(kAreolaRadius, kAreolaEdge, r));
  return nipple + areola;
}
}  // namespace

double breast_implicit(const Vec3& p) {
  // The dome in sheared coordinates (y + shear z): the z = 0 section stays the
  // base ellipse and the apex (z = kBreastDome) moves to y = -kBreastDroop. A
  // shear keeps the volume and the convexity of the half ellipsoid.
  const double shear = kBreastDroop / kBreastDome;
  const Vec3 q(p.x(), p.y() + shear * p.z(), p.z());
  const Vec3 radii(kBreastHalfX, q.y() > 0 ? kBreastUpper : kBreastLower, kBreastDome);
  double dome = ellipsoid(q, Vec3::Zero(), radii);
  // Near the apex the dome's value is close to the height above its surface,
  // so subtracting a height raises the surface by about that much.
  const double r = std::hypot(p.x(), p.y() + kBreastDroop);
  if (r < kAreolaEdge) dome -= nipple_areola_height(r);
  // The chest-wall side: the half-space z >= 0, the rim rounded.
  return smooth_max(dome, -p.z(), kBreastRim);
}

Vec3 breast_center() { return kBreastCenter; }

// ---------------------------------------------------------------------------
// The abdomen: a vertical prism over a rounded rectangle (the flanks), cut by
// the flat back below and by a concave paraboloid (the belly) above, the
// edges rounded by smooth maxima. Each piece is a convex function and the
// smooth maximum is convex and non-decreasing in both arguments, so the
// function is convex and the abdomen star-shaped around any inner point.
namespace {
constexpr double kAbdomenHalfX = 0.15;     // m
constexpr double kAbdomenHalfY = 0.11;     // m
constexpr double kAbdomenCorner = 0.05;    // plan-view corner radius, m
constexpr double kAbdomenBack = -0.06;     // z of the flat back, m
constexpr double kAbdomenTop = 0.06;       // z of the belly at the centre, m
constexpr double kBellyDropX = 0.020;      // belly lower by this at x = +-kAbdomenHalfX, m
constexpr double kBellyDropY = 0.012;      // and by this at y = +-kAbdomenHalfY, m
constexpr double kFlankBlend = 0.03;       // blend width belly-flank, m
constexpr double kBackBlend = 0.01;        // blend width back-flank, m
// Nearer the belly than the back, so more of the cube-sphere's rays land on the belly.
const Vec3 kAbdomenCenter(0.0, 0.0, 0.01);

double belly_height(double x, double y) {
  const double u = x / kAbdomenHalfX, v = y / kAbdomenHalfY;
  return kAbdomenTop - kBellyDropX * u * u - kBellyDropY * v * v;
}
}  // namespace

double abdomen_implicit(const Vec3& p) {
  // Signed distance to the rounded rectangle in the (x, y) plane.
  const double qx = std::abs(p.x()) - (kAbdomenHalfX - kAbdomenCorner);
  const double qy = std::abs(p.y()) - (kAbdomenHalfY - kAbdomenCorner);
  const double flank = std::hypot(std::max(qx, 0.0), std::max(qy, 0.0)) + std::min(std::max(qx, qy), 0.0) - kAbdomenCorner;
  const double back = kAbdomenBack - p.z();
  const double belly = p.z() - belly_height(p.x(), p.y());  // the slope stays below 0.3: close to a distance
  return smooth_max(smooth_max(flank, back, kBackBlend), belly, kFlankBlend);
}

Vec3 abdomen_center() { return kAbdomenCenter; }

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
  return sample_star_shape(target_vertices, organ_implicit, kCenter);
}

SurfaceMesh make_breast(std::size_t target_vertices) {
  return sample_star_shape(target_vertices, breast_implicit, kBreastCenter);
}

SurfaceMesh make_abdomen(std::size_t target_vertices) {
  return sample_star_shape(target_vertices, abdomen_implicit, kAbdomenCenter);
}

}  // namespace palpa::mesh
