// Inward thickness and convex radius against closed forms (spheres,
// ellipsoids, open planes) and a brute-force ray cast on the default organ.

#include "mesh/thickness.h"
#include "common/test_support.h"
#include "mesh/generate.h"
#include "mesh/io.h"

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>

namespace palpa::mesh {
namespace {

double longest_edge(const SurfaceMesh& m) {
  double h = 0;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) h = std::max(h, (m.positions[t[k]] - m.positions[t[(k + 1) % 3]]).norm());
  return h;
}

TEST(Thickness, SphereIsItsDiameterAndItsRadius) {
  // Radial normals: the inward ray goes through the centre to the antipode,
  // which lies within a sagitta h^2 / 8R of the sphere; neighbours' normals
  // converge at the centre, so the convex radius is R exactly.
  const double r = 0.04;
  SurfaceMesh m = make_sphere(6000, r);
  for (std::size_t i = 0; i < m.vertex_count(); ++i) m.normals[i] = m.positions[i].normalized();
  const double h = longest_edge(m);
  const auto t = inward_thickness(m);
  const auto c = convex_radius(m);
  ASSERT_EQ(t.size(), m.vertex_count());
  for (std::size_t i = 0; i < m.vertex_count(); ++i) {
    EXPECT_LE(t[i], 2 * r * (1 + 1e-12)) << i;
    EXPECT_GE(t[i], 2 * r - h * h / (8 * r)) << i;
    EXPECT_NEAR(c[i], r, 1e-12) << i;
  }
}

TEST(Thickness, FlattenedSphereIsThinAtItsPoles) {
  // An ellipsoid with semi-axes R, R, R/10: through the poles 2R/10 thick,
  // through the equator 2R wide; curvature radius at the poles R^2/c = 10 R,
  // at the equator (across the thin way) c^2/R = R/100.
  const double r = 0.05, c = 0.005;
  SurfaceMesh m = make_sphere(20000, r);
  for (Vec3& p : m.positions) p.z() *= c / r;
  finalize(m);
  const auto t = inward_thickness(m);
  const auto k = convex_radius(m);
  Index top = 0, side = 0;
  for (Index i = 0; i < m.vertex_count(); ++i) {
    if (m.positions[i].z() > m.positions[top].z()) top = i;
    if (m.positions[i].x() > m.positions[side].x()) side = i;
  }
  EXPECT_NEAR(t[top], 2 * c, 0.01 * c);
  EXPECT_NEAR(t[side], 2 * r, 0.01 * r);
  EXPECT_GT(k[top], 5 * r);
  EXPECT_LT(k[side], 0.05 * r);
}

TEST(Thickness, SharedByMeshObjectWhileHeld) {
  const auto mesh = std::make_shared<const SurfaceMesh>(make_sphere(2000, 0.05));
  const std::vector<double> direct = inward_thickness(*mesh);
  auto first = shared_inward_thickness(mesh);
  EXPECT_EQ(*first, direct);  // the same values, bit for bit
  // Held: the same result for the same object.
  EXPECT_EQ(shared_inward_thickness(mesh).get(), first.get());
  // Another object with the same vertices is another mesh: its own result.
  const auto copy = std::make_shared<const SurfaceMesh>(*mesh);
  auto other = shared_inward_thickness(copy);
  EXPECT_NE(other.get(), first.get());
  EXPECT_EQ(*other, direct);
  // Released by everyone: computed again, the same values.
  first.reset();
  EXPECT_EQ(*shared_inward_thickness(mesh), direct);
}

TEST(Thickness, OpenPlaneHasNoOppositeSide) {
  const SurfaceMesh m = make_plane(10, 10, 0.01);
  for (double t : inward_thickness(m)) EXPECT_EQ(t, std::numeric_limits<double>::infinity());
  for (double k : convex_radius(m)) EXPECT_EQ(k, std::numeric_limits<double>::infinity());
}

TEST(Thickness, MatchesABruteForceRayCastOnTheDefaultOrgan) {
  const SurfaceMesh m = load_mesh(test::project_data_dir() / "default_organ.ply");
  const auto t0 = std::chrono::steady_clock::now();
  const auto t = inward_thickness(m);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("  inward_thickness: %zu vertices, %zu triangles in %.0f ms\n", m.vertex_count(), m.triangle_count(),
              ms);
  const double inf = std::numeric_limits<double>::infinity();
  int finite = 0;
  for (std::size_t i = 0; i < m.vertex_count(); i += 97) {
    const Vec3 o = m.positions[i], d = -m.normals[i] / m.normals[i].norm();
    double best = inf;
    for (const auto& tri : m.triangles) {
      if (tri[0] == i || tri[1] == i || tri[2] == i) continue;
      const Vec3 a = m.positions[tri[0]], e1 = m.positions[tri[1]] - a, e2 = m.positions[tri[2]] - a;
      const Vec3 q = d.cross(e2);
      const double det = e1.dot(q);
      if (!(std::abs(det) > 0)) continue;
      const Vec3 s = o - a;
      const double u = s.dot(q) / det;
      if (u < -1e-9 || u > 1 + 1e-9) continue;
      const Vec3 r = s.cross(e1);
      const double v = d.dot(r) / det;
      if (v < -1e-9 || u + v > 1 + 1e-9) continue;
      const double h = e2.dot(r) / det;
      if (h > 0) best = std::min(best, h);
    }
    EXPECT_EQ(t[i], best) << "vertex " << i;
    finite += std::isfinite(best);
  }
  EXPECT_GT(finite, 300);  // a closed organ: every inward ray meets the other side
}

}  // namespace
}  // namespace palpa::mesh
