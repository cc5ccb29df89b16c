// Procedural meshes against closed forms: sphere area, volume and normals,
// the flat plane, the default organ's topology and star shape, and the
// breast's and abdomen's topology, extents, volume and star shape.

#include "common/test_support.h"
#include "mesh/generate.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <functional>

namespace palpa::mesh {
namespace {

double longest_edge(const SurfaceMesh& m) {
  double h = 0;
  for (const Triangle& t : m.triangles)
    for (int k = 0; k < 3; ++k) h = std::max(h, (m.positions[t[k]] - m.positions[t[(k + 1) % 3]]).norm());
  return h;
}

TEST(Sphere, VertexCountTopologyAndRadius) {
  const Vec3 c(0.01, -0.02, 0.03);
  for (std::size_t n : {1, 2, 5, 13}) {
    const std::size_t target = 6 * n * n + 2;
    const SurfaceMesh m = make_sphere(target, 0.05, c);
    const MeshFacts f = analyse(m);
    EXPECT_EQ(f.vertices, target);
    EXPECT_EQ(f.triangles, 12 * n * n);
    EXPECT_TRUE(f.closed());
    EXPECT_TRUE(f.consistently_oriented);
    EXPECT_EQ(f.components, 1u);
    EXPECT_EQ(f.euler_characteristic, 2);
    for (const Vec3& p : m.positions) EXPECT_NEAR((p - c).norm(), 0.05, 1e-15);
  }
  EXPECT_EQ(make_sphere(0, 1.0).vertex_count(), 8u);  // at least the cube
}

// The mesh is convex with its vertices on the sphere, so it lies between the
// sphere and the ball of radius d (the smallest distance from the centre to a
// triangle's plane): 4 pi d^2 <= A <= 4 pi r^2 and 4/3 pi d^3 <= V <= 4/3 pi r^3.
TEST(Sphere, AreaAndVolumeWithinTheInscribedBounds) {
  const double r = 0.04;
  const Vec3 c(0.1, 0.0, -0.1);
  const SurfaceMesh m = make_sphere(1200, r, c);
  double d = r;
  for (const Triangle& t : m.triangles) {
    const Vec3 n = (m.positions[t[1]] - m.positions[t[0]]).cross(m.positions[t[2]] - m.positions[t[0]]).normalized();
    d = std::min(d, n.dot(m.positions[t[0]] - c));
    // Convexity, brute force: every vertex is on the inner side of every face's plane.
    for (const Vec3& p : m.positions) ASSERT_LE(n.dot(p - m.positions[t[0]]), 1e-15);
  }
  ASSERT_GT(d, 0.9 * r);
  const MeshFacts f = analyse(m);
  EXPECT_LE(f.area, 4 * M_PI * r * r);
  EXPECT_GE(f.area, 4 * M_PI * d * d);
  EXPECT_LE(f.signed_volume, 4.0 / 3.0 * M_PI * r * r * r);
  EXPECT_GE(f.signed_volume, 4.0 / 3.0 * M_PI * d * d * d);
}

// The discretisation error is second order: quadrupling the vertex count
// (halving the edge length) divides the area and volume errors by about 4.
TEST(Sphere, ErrorsShrinkSecondOrder) {
  auto errors = [](std::size_t n) {
    const MeshFacts f = analyse(make_sphere(6 * n * n + 2, 1.0));
    return std::pair{4 * M_PI - f.area, 4.0 / 3.0 * M_PI - f.signed_volume};
  };
  const auto [a1, v1] = errors(16);
  const auto [a2, v2] = errors(32);
  EXPECT_GT(a1, 0);
  EXPECT_GT(v1, 0);
  EXPECT_NEAR(a1 / a2, 4.0, 0.3);
  EXPECT_NEAR(v1 / v2, 4.0, 0.3);
}

// Area-weighted normals are first-order accurate: the angle to the exact
// radial normal stays below a quarter of (longest edge / radius) and halves
// when the edges halve.
TEST(Sphere, NormalsMatchTheRadialDirection) {
  auto worst_angle = [](std::size_t n, double* h_over_r) {
    const Vec3 c(1, 2, 3);
    const SurfaceMesh m = make_sphere(6 * n * n + 2, 2.0, c);
    double worst = 0;
    for (std::size_t i = 0; i < m.vertex_count(); ++i) {
      EXPECT_NEAR(m.normals[i].norm(), 1.0, 1e-14);
      const Vec3 exact = (m.positions[i] - c).normalized();
      worst = std::max(worst, std::atan2(exact.cross(m.normals[i]).norm(), exact.dot(m.normals[i])));
    }
    *h_over_r = longest_edge(m) / 2.0;
    return worst;
  };
  double h1 = 0, h2 = 0;
  const double w1 = worst_angle(12, &h1), w2 = worst_angle(24, &h2);
  EXPECT_LT(w1, 0.25 * h1);
  EXPECT_LT(w2, 0.25 * h2);
  EXPECT_NEAR(w1 / w2, 2.0, 0.3);
}

// Timed in CPU seconds (std::clock) so that a busy machine does not fail it.
// How fast it builds is a benchmark's business (palpa-bench builds 1M and
// 2M spheres and prints the time); the test checks what it builds.
TEST(Sphere, TwoMillionVertices) {
  const SurfaceMesh m = make_sphere(2'000'000, 0.1);
  EXPECT_NEAR(double(m.vertex_count()), 2e6, 0.01 * 2e6);
  EXPECT_EQ(m.normals.size(), m.vertex_count());
  EXPECT_EQ(m.vertex_neighbors.rows(), m.vertex_count());
}

TEST(Plane, GridNormalsAndTopologyAreExact) {
  const int nx = 7, ny = 5;
  const double s = 0.002;
  const SurfaceMesh m = make_plane(nx, ny, s);
  const MeshFacts f = analyse(m);
  EXPECT_EQ(f.vertices, std::size_t(nx * ny));
  EXPECT_EQ(f.triangles, std::size_t(2 * (nx - 1) * (ny - 1)));
  EXPECT_EQ(f.boundary_edges, std::size_t(2 * (nx - 1) + 2 * (ny - 1)));
  EXPECT_EQ(f.euler_characteristic, 1);
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_NEAR(f.area, (nx - 1) * (ny - 1) * s * s, 1e-18);
  for (const Vec3& n : m.normals) EXPECT_EQ(n, Vec3(0, 0, 1));
  // Centred on the origin in z = 0.
  EXPECT_NEAR((f.bbox_min + f.bbox_max).norm(), 0.0, 1e-18);
  EXPECT_EQ(f.bbox_min.z(), 0.0);
  EXPECT_EQ(f.bbox_max.z(), 0.0);
}

TEST(Organ, ClosedGenusZeroOutwardAndOrganSized) {
  const SurfaceMesh m = make_organ(20'000);
  const MeshFacts f = analyse(m);
  EXPECT_EQ(f.vertices, make_sphere(20'000, 1.0).vertex_count());
  EXPECT_TRUE(f.closed());
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_EQ(f.components, 1u);
  EXPECT_EQ(f.euler_characteristic, 2);
  const Vec3 size = f.bbox_max - f.bbox_min;
  EXPECT_NEAR(size.x(), 0.21, 0.02);
  EXPECT_NEAR(size.y(), 0.14, 0.02);
  EXPECT_NEAR(size.z(), 0.09, 0.02);
  // An adult liver holds roughly 1 to 2 litres.
  EXPECT_GT(f.signed_volume, 0.8e-3);
  EXPECT_LT(f.signed_volume, 2.0e-3);
  // Every vertex lies on the zero set: the function changes sign within 1 micrometre along its ray.
  const Vec3 c = organ_center();
  for (const Vec3& p : m.positions) {
    const Vec3 d = (p - c).normalized();
    ASSERT_LT(organ_implicit(p - 1e-6 * d), 0.0);
    ASSERT_GT(organ_implicit(p + 1e-6 * d), 0.0);
  }
}

// make_organ relies on this: along any ray from the centre the implicit
// function changes sign exactly once (sampled every 0.1 mm out to 0.3 m).
TEST(Organ, StarShapedAroundItsCentre) {
  const Vec3 c = organ_center();
  ASSERT_LT(organ_implicit(c), 0.0);
  int bad = 0;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 120; ++j) {
      const double theta = M_PI * (i + 0.5) / 60, phi = 2 * M_PI * j / 120;
      const Vec3 d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      int changes = 0;
      bool inside = true;
      for (int k = 1; k <= 3000; ++k) {
        const bool now = organ_implicit(c + (1e-4 * k) * d) < 0;
        changes += now != inside;
        inside = now;
      }
      bad += changes != 1;
    }
  EXPECT_EQ(bad, 0);
}

// ---------------------------------------------------------------------------
// The scenario shapes (breast, abdomen): checks shared by both.
using Implicit = std::function<double(const Vec3&)>;

// Rays (60 x 120, over the sphere) from c along which f does not change sign
// exactly once, sampled every 0.1 mm out to 0.3 m (beyond either shape).
int rays_not_crossing_once(const Implicit& f, const Vec3& c) {
  int bad = 0;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 120; ++j) {
      const double theta = M_PI * (i + 0.5) / 60, phi = 2 * M_PI * j / 120;
      const Vec3 d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      int changes = 0;
      bool inside = true;
      for (int k = 1; k <= 3000; ++k) {
        const bool now = f(c + (1e-4 * k) * d) < 0;
        changes += now != inside;
        inside = now;
      }
      bad += changes != 1;
    }
  return bad;
}

// The volume where f < 0 in the box [lo, hi], by the midpoint rule on cubic
// cells of edge h (m^3): independent of the ray sampling and the triangles.
double sampled_volume(const Implicit& f, const Vec3& lo, const Vec3& hi, double h) {
  const int nx = int(std::ceil((hi.x() - lo.x()) / h)), ny = int(std::ceil((hi.y() - lo.y()) / h)),
            nz = int(std::ceil((hi.z() - lo.z()) / h));
  long inside = 0;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) inside += f(lo + h * Vec3(i + 0.5, j + 0.5, k + 0.5)) < 0;
  return double(inside) * h * h * h;
}

// Closed, manifold, one genus-0 component, outward, make_sphere's vertex
// count, and every vertex on the zero set (a sign change within 1 micrometre
// along its ray).
void expect_closed_outward_on_the_zero_set(const SurfaceMesh& m, std::size_t target, const Implicit& f,
                                           const Vec3& c) {
  const MeshFacts facts = analyse(m);
  EXPECT_EQ(facts.vertices, make_sphere(target, 1.0).vertex_count());
  EXPECT_TRUE(facts.closed());
  EXPECT_TRUE(facts.manifold());
  EXPECT_TRUE(facts.consistently_oriented);
  EXPECT_EQ(facts.components, 1u);
  EXPECT_EQ(facts.euler_characteristic, 2);
  EXPECT_GT(facts.signed_volume, 0.0);
  for (const Vec3& p : m.positions) {
    const Vec3 d = (p - c).normalized();
    ASSERT_LT(f(p - 1e-6 * d), 0.0);
    ASSERT_GT(f(p + 1e-6 * d), 0.0);
  }
  // Outward vertex normals: each points away from the centre.
  for (std::size_t i = 0; i < m.vertex_count(); ++i) ASSERT_GT(m.normals[i].dot(m.positions[i] - c), 0.0) << i;
}

TEST(Breast, ClosedGenusZeroOutwardWithVerticesOnTheSurface) {
  for (std::size_t target : {200, 20'000})
    expect_closed_outward_on_the_zero_set(make_breast(target), target, breast_implicit, breast_center());
}

TEST(Breast, StarShapedAroundItsCentre) {
  ASSERT_LT(breast_implicit(breast_center()), 0.0);
  EXPECT_EQ(rays_not_crossing_once(breast_implicit, breast_center()), 0);
}

// A dome about 0.14 m across and 0.06 m high on the z = 0 plane, centred in
// x, with the nipple (the highest point) on the drooped apex.
TEST(Breast, DomeOnTheChestWallWithTheNippleOnTop) {
  const SurfaceMesh m = make_breast(20'000);
  const MeshFacts f = analyse(m);
  const Vec3 size = f.bbox_max - f.bbox_min;
  EXPECT_NEAR(size.x(), 0.14, 0.003);
  EXPECT_NEAR(size.y(), 0.14, 0.005);
  EXPECT_NEAR(size.z(), 0.06, 0.001);
  EXPECT_NEAR(f.bbox_min.z(), 0.0, 1e-9);
  EXPECT_NEAR(f.bbox_min.x() + f.bbox_max.x(), 0.0, 1e-6);  // symmetric in x
  EXPECT_NEAR(0.5 * (f.bbox_min.y() + f.bbox_max.y()), 0.0, 0.005);
  const auto top = std::max_element(m.positions.begin(), m.positions.end(),
                                    [](const Vec3& a, const Vec3& b) { return a.z() < b.z(); });
  EXPECT_NEAR(top->x(), 0.0, 0.002);
  EXPECT_NEAR(top->y(), -0.010, 0.002);  // drooped towards -y
  // The chest-wall side is flat: inside the rim the vertices lie in z = 0 with normals -z.
  std::size_t base = 0;
  for (std::size_t i = 0; i < m.vertex_count(); ++i) {
    const Vec3& p = m.positions[i];
    ASSERT_GE(p.z(), -1e-12);
    if (std::hypot(p.x(), p.y()) < 0.05) {
      if (p.z() < 0.01) {
        EXPECT_NEAR(p.z(), 0.0, 1e-12);
        EXPECT_NEAR(m.normals[i].z(), -1.0, 1e-9);
        ++base;
      }
    }
  }
  EXPECT_GT(base, 1000u);
}

// Volume: the mesh against the implicit function sampled on 1 mm cells, and
// against the closed form of the sheared half ellipsoid without the rim
// rounding, areola and nipple (pi / 3 a c (b_upper + b_lower); a shear keeps volumes).
TEST(Breast, VolumeMatchesTheImplicitAndTheHalfEllipsoid) {
  const double mesh_volume = analyse(make_breast(20'000)).signed_volume;
  const double sampled = sampled_volume(breast_implicit, Vec3(-0.08, -0.09, -0.001), Vec3(0.08, 0.08, 0.07), 0.001);
  const double half_ellipsoid = M_PI / 3 * 0.070 * 0.0535 * (0.066 + 0.072);
  EXPECT_NEAR(mesh_volume / sampled, 1.0, 0.01);
  EXPECT_NEAR(mesh_volume / half_ellipsoid, 1.0, 0.03);
}

TEST(Abdomen, ClosedGenusZeroOutwardWithVerticesOnTheSurface) {
  for (std::size_t target : {200, 20'000})
    expect_closed_outward_on_the_zero_set(make_abdomen(target), target, abdomen_implicit, abdomen_center());
}

TEST(Abdomen, StarShapedAroundItsCentre) {
  ASSERT_LT(abdomen_implicit(abdomen_center()), 0.0);
  EXPECT_EQ(rays_not_crossing_once(abdomen_implicit, abdomen_center()), 0);
}

// A 0.30 x 0.22 x 0.12 m slab centred at the origin, flat back at z = -0.06.
TEST(Abdomen, SlabExtentsAndFlatBack) {
  const SurfaceMesh m = make_abdomen(20'000);
  const MeshFacts f = analyse(m);
  EXPECT_NEAR(f.bbox_min.x(), -0.15, 2e-4);
  EXPECT_NEAR(f.bbox_max.x(), 0.15, 2e-4);
  EXPECT_NEAR(f.bbox_min.y(), -0.11, 2e-4);
  EXPECT_NEAR(f.bbox_max.y(), 0.11, 2e-4);
  EXPECT_NEAR(f.bbox_min.z(), -0.06, 1e-9);
  EXPECT_NEAR(f.bbox_max.z(), 0.06, 2e-4);
  std::size_t back = 0;
  for (std::size_t i = 0; i < m.vertex_count(); ++i) {
    const Vec3& p = m.positions[i];
    if (std::abs(p.x()) < 0.12 && std::abs(p.y()) < 0.08 && p.z() < 0) {
      EXPECT_NEAR(p.z(), -0.06, 1e-12);
      EXPECT_NEAR(m.normals[i].z(), -1.0, 1e-9);
      ++back;
    }
  }
  EXPECT_GT(back, 1000u);
}

// Where a scenario lays the aorta (along y, 3 cm under the belly near
// x = 0.02 m) the belly is the paraboloid itself, untouched by the edge
// roundings: vertices on it and normals close to its exact normal.
TEST(Abdomen, BellyIsSmoothOverTheAorta) {
  const SurfaceMesh m = make_abdomen(20'000);
  std::size_t checked = 0;
  double worst_angle = 0;
  for (std::size_t i = 0; i < m.vertex_count(); ++i) {
    const Vec3& p = m.positions[i];
    if (p.z() < 0.02 || std::abs(p.x() - 0.02) > 0.04 || std::abs(p.y()) > 0.07) continue;
    const double u = p.x() / 0.15, v = p.y() / 0.11;
    EXPECT_NEAR(p.z(), 0.06 - 0.020 * u * u - 0.012 * v * v, 1e-9);
    const Vec3 exact = Vec3(2 * 0.020 * p.x() / (0.15 * 0.15), 2 * 0.012 * p.y() / (0.11 * 0.11), 1.0).normalized();
    worst_angle = std::max(worst_angle, std::acos(std::min(1.0, exact.dot(m.normals[i]))));
    ++checked;
  }
  EXPECT_GT(checked, 500u);
  EXPECT_LT(worst_angle, 0.003);  // radians
}

// Volume: the mesh against the implicit function sampled on 2 mm cells, and
// against the closed form of the slab with sharp belly and back edges
// (the roundings take about 2 % off it): the integral of belly height minus
// back over the rounded rectangle, from its area and second moments.
TEST(Abdomen, VolumeMatchesTheImplicitAndTheSharpSlab) {
  const double mesh_volume = analyse(make_abdomen(20'000)).signed_volume;
  const double sampled = sampled_volume(abdomen_implicit, Vec3(-0.152, -0.112, -0.062), Vec3(0.152, 0.112, 0.062), 0.002);
  // Rounded rectangle: half sizes X, Y, corner radius r; centre cross plus four quarter discs.
  const double X = 0.15, Y = 0.11, r = 0.05, xs = X - r, ys = Y - r;
  const double aq = M_PI * r * r / 4, su = r * r * r / 3, suu = M_PI * r * r * r * r / 16;
  const double area = 4 * X * ys + 4 * xs * r + 4 * aq;
  const double ixx = std::pow(2 * X, 3) / 12 * 2 * ys + 2 * std::pow(2 * xs, 3) / 12 * r +
                     4 * (xs * xs * aq + 2 * xs * su + suu);
  const double iyy = 2 * X * std::pow(2 * ys, 3) / 12 + 2 * 2 * xs * (Y * Y * Y - ys * ys * ys) / 3 +
                     4 * (ys * ys * aq + 2 * ys * su + suu);
  const double sharp = 0.12 * area - 0.020 / (X * X) * ixx - 0.012 / (Y * Y) * iyy;
  EXPECT_NEAR(sharp, 7.016e-3, 1e-6);  // the same sum done by hand
  EXPECT_NEAR(mesh_volume / sampled, 1.0, 0.01);
  EXPECT_LT(mesh_volume, sharp);
  EXPECT_NEAR(mesh_volume / sharp, 1.0, 0.04);
}

}  // namespace
}  // namespace palpa::mesh
