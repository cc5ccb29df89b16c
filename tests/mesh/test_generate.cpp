// Procedural meshes against closed forms: sphere area, volume and normals,
// the flat plane, and the default organ's topology and star shape.

#include "common/test_support.h"
#include "mesh/generate.h"

#include <Eigen/Geometry>

#include <cmath>
#include <ctime>

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
TEST(Sphere, TwoMillionVerticesQuickly) {
  const std::clock_t start = std::clock();
  const SurfaceMesh m = make_sphere(2'000'000, 0.1);
  const double seconds = double(std::clock() - start) / CLOCKS_PER_SEC;
  EXPECT_NEAR(double(m.vertex_count()), 2e6, 0.01 * 2e6);
  EXPECT_EQ(m.normals.size(), m.vertex_count());
  EXPECT_EQ(m.vertex_neighbors.rows(), m.vertex_count());
#ifdef NDEBUG
  EXPECT_LT(seconds, 2.0) << "make_sphere(2M) took " << seconds << " s";
#endif
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

}  // namespace
}  // namespace palpa::mesh
