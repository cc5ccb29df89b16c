// Contact point interpolation and the height check on hand-worked cases.

#include "collision/contact.h"
#include "common/test_support.h"
#include "mesh/generate.h"

#include <cmath>
#include <limits>
#include <random>

namespace palpa::collision {
namespace {

// The right triangle (0,0,0), (1,0,0), (0,1,0) with the given vertex normals.
mesh::SurfaceMesh one_triangle(const Vec3& n0, const Vec3& n1, const Vec3& n2) {
  mesh::SurfaceMesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  m.triangles = {{0, 1, 2}};
  mesh::finalize(m);
  m.normals = {n0, n1, n2};
  return m;
}

void expect_vec_near(const Vec3& got, const Vec3& want, double tol, const char* what) {
  EXPECT_LE((got - want).norm(), tol) << what << ": got " << got.transpose() << ", want " << want.transpose();
}

TEST(Contact, FlatTriangleIsOrthogonalProjection) {
  // Constant normal +z: the point is the probe's foot, offset its height.
  const auto m = one_triangle(Vec3::UnitZ(), Vec3::UnitZ(), Vec3::UnitZ());
  for (double z : {0.5, -0.25}) {
    const SurfacePoint sp = locate_surface_point(m, Vec3(0.2, 0.3, z), 0);
    EXPECT_EQ(sp.triangle, 0u);
    EXPECT_TRUE(sp.inside);
    expect_vec_near(sp.barycentric, Vec3(0.5, 0.2, 0.3), 1e-12, "barycentric");
    expect_vec_near(sp.point, Vec3(0.2, 0.3, 0), 1e-12, "point");
    expect_vec_near(sp.normal, Vec3::UnitZ(), 1e-12, "normal");
    EXPECT_NEAR(sp.offset, z, 1e-12);
  }
}

TEST(Contact, EqualTiltedNormalsGiveObliqueProjection) {
  // All normals (1,0,1)/sqrt2: the probe (0.5,0.2,0.1) runs back along that
  // direction to the plane z = 0 at (0.4, 0.2, 0): weights (0.4, 0.4, 0.2),
  // offset |(0.1, 0, 0.1)| = 0.1 sqrt2.
  const Vec3 n = Vec3(1, 0, 1).normalized();
  const auto m = one_triangle(n, n, n);
  const SurfacePoint sp = locate_surface_point(m, Vec3(0.5, 0.2, 0.1), 1);
  EXPECT_TRUE(sp.inside);
  expect_vec_near(sp.barycentric, Vec3(0.4, 0.4, 0.2), 1e-12, "barycentric");
  expect_vec_near(sp.point, Vec3(0.4, 0.2, 0), 1e-12, "point");
  expect_vec_near(sp.normal, n, 1e-12, "normal");
  EXPECT_NEAR(sp.offset, 0.1 * std::sqrt(2.0), 1e-12);
}

TEST(Contact, VaryingNormalsSolvedExactly) {
  // n0 = n2 = +z, n1 = (0.6, 0, 0.8). At weights (0.3, 0.4, 0.3) the point is
  // (0.4, 0.3, 0) and the blended normal 0.6 (0,0,1) + 0.4 (0.6,0,0.8) =
  // (0.24, 0, 0.92), |.| = sqrt(0.904). A probe 0.1 along it:
  // (0.424, 0.3, 0.092); offset 0.1 sqrt(0.904). The orthogonal projection
  // (0.424, 0.3, 0) would be wrong.
  const auto m = one_triangle(Vec3::UnitZ(), Vec3(0.6, 0, 0.8), Vec3::UnitZ());
  for (Index nearest : {0u, 1u, 2u}) {
    const SurfacePoint sp = locate_surface_point(m, Vec3(0.424, 0.3, 0.092), nearest);
    EXPECT_TRUE(sp.inside);
    expect_vec_near(sp.barycentric, Vec3(0.3, 0.4, 0.3), 1e-12, "barycentric");
    expect_vec_near(sp.point, Vec3(0.4, 0.3, 0), 1e-12, "point");
    expect_vec_near(sp.normal, Vec3(0.24, 0, 0.92) / std::sqrt(0.904), 1e-12, "normal");
    EXPECT_NEAR(sp.offset, 0.1 * std::sqrt(0.904), 1e-12);
  }
  // The same point below the surface: probe = point - 0.05 N(b).
  const SurfacePoint below = locate_surface_point(m, Vec3(0.4 - 0.012, 0.3, -0.046), 0);
  expect_vec_near(below.barycentric, Vec3(0.3, 0.4, 0.3), 1e-12, "barycentric below");
  EXPECT_NEAR(below.offset, -0.05 * std::sqrt(0.904), 1e-12);
}

TEST(Contact, ProbeAtAVertex) {
  // On a plane grid the probe exactly at a vertex: all weight on it, offset 0.
  const auto m = mesh::make_plane(5, 5, 0.01);
  for (Index v : {0u, 7u, 12u, 24u}) {
    const SurfacePoint sp = locate_surface_point(m, m.positions[v], v);
    ASSERT_NE(sp.triangle, kNoIndex);
    EXPECT_TRUE(sp.inside);
    const auto& tri = m.triangles[sp.triangle];
    int k = tri[0] == v ? 0 : tri[1] == v ? 1 : 2;
    ASSERT_EQ(tri[k], v);
    EXPECT_EQ(sp.barycentric[k], 1.0);
    EXPECT_EQ(sp.point, m.positions[v]);
    EXPECT_EQ(sp.offset, 0.0);
    expect_vec_near(sp.normal, Vec3::UnitZ(), 1e-15, "normal");
  }
}

TEST(Contact, ProbeOutsideTheOneRingGoesToTheNeighbour) {
  // A(-1,0) B(1,0) C(0,1) form T0; D(0,-0.1) below AB forms T1 = (B, A, D).
  // Above (0, 0.05) the nearest vertex is D (0.15 away, A and B ~1), but the
  // point lies in T0, which does not touch D: the search widens to the
  // triangles of D's neighbours A and B.
  mesh::SurfaceMesh m;
  m.positions = {Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -0.1, 0)};
  m.triangles = {{0, 1, 2}, {1, 0, 3}};
  mesh::finalize(m);
  const Vec3 probe(0, 0.05, -0.02);
  const SurfacePoint sp = locate_surface_point(m, probe, 3);
  EXPECT_EQ(sp.triangle, 0u);
  EXPECT_TRUE(sp.inside);
  expect_vec_near(sp.point, Vec3(0, 0.05, 0), 1e-12, "point");
  EXPECT_NEAR(sp.offset, -0.02, 1e-12);
}

TEST(Contact, ProbeBeyondTheBorderIsClamped) {
  // Past the edge x = 0.02 of a flat grid: no triangle holds the foot of the
  // normal, so the closest point on the border is taken (not inside).
  const auto m = mesh::make_plane(5, 5, 0.01);  // x, y in [-0.02, 0.02]
  Index corner = 0;
  for (Index v = 0; v < m.vertex_count(); ++v)
    if (m.positions[v].x() > 0.019 && std::abs(m.positions[v].y()) < 1e-9) corner = v;
  const Vec3 probe(0.025, 0.0, 0.003);
  const SurfacePoint sp = locate_surface_point(m, probe, corner);
  ASSERT_NE(sp.triangle, kNoIndex);
  EXPECT_FALSE(sp.inside);
  expect_vec_near(sp.point, Vec3(0.02, 0.0, 0), 1e-12, "point");
  EXPECT_NEAR(sp.offset, 0.003, 1e-12);
  EXPECT_NEAR(sp.barycentric.sum(), 1.0, 1e-12);
  EXPECT_GE(sp.barycentric.minCoeff(), 0.0);
}

TEST(Contact, SphereContactPointIsRadial) {
  // On a sphere with radial vertex normals the virtual vertex lies close to
  // R P/|P| and the offset close to |P| - R; the error is bounded by the
  // sagitta of an edge (h^2 / 8R) and the spread of the normals over it.
  const double radius = 0.05;
  const auto m = mesh::make_sphere(10000, radius);
  double h = 0;  // longest edge
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) h = std::max(h, (m.positions[t[k]] - m.positions[t[(k + 1) % 3]]).norm());
  const double tol = h * h / radius;
  const VertexTree tree(m.positions);
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.9, 1.1);
  for (int i = 0; i < 500; ++i) {
    const Vec3 dir = Vec3(g(rng), g(rng), g(rng)).normalized();
    const Vec3 probe = dir * radius * u(rng);
    const SurfacePoint sp = locate_surface_point(m, probe, tree.nearest(probe).vertex);
    ASSERT_NE(sp.triangle, kNoIndex);
    EXPECT_TRUE(sp.inside) << "probe " << probe.transpose();
    EXPECT_LE((sp.point - radius * dir).norm(), tol) << "probe " << probe.transpose();
    EXPECT_NEAR(sp.offset, probe.norm() - radius, tol) << "probe " << probe.transpose();
    EXPECT_LE((sp.normal - dir).norm(), h / radius) << "probe " << probe.transpose();
    EXPECT_NEAR(sp.normal.norm(), 1.0, 1e-12);
    // The point lies on its triangle and the probe on the normal line through it.
    EXPECT_LE((probe - sp.point - sp.offset * sp.normal).norm(), 1e-12);
  }
}

TEST(Contact, SphereWithRadialNormalsIsExactlyRadial) {
  // With exactly radial vertex normals n_i = p_i / R, the blended normal
  // sum b_i n_i = C(b) / R is parallel to the blended point C(b), so the
  // solution of P = C + t N lies on the ray through P: the point is
  // |C| P/|P| with R - |C| at most the sagitta h^2 / 8R, the normal P/|P|.
  const double radius = 0.05;
  auto m = mesh::make_sphere(10000, radius);
  for (std::size_t i = 0; i < m.vertex_count(); ++i) m.normals[i] = m.positions[i].normalized();
  double h = 0;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) h = std::max(h, (m.positions[t[k]] - m.positions[t[(k + 1) % 3]]).norm());
  const VertexTree tree(m.positions);
  std::mt19937 rng(6);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.9, 1.1);
  for (int i = 0; i < 500; ++i) {
    const Vec3 dir = Vec3(g(rng), g(rng), g(rng)).normalized();
    const Vec3 probe = dir * radius * u(rng);
    const SurfacePoint sp = locate_surface_point(m, probe, tree.nearest(probe).vertex);
    EXPECT_TRUE(sp.inside);
    expect_vec_near(sp.normal, dir, 1e-12, "normal");
    const double r = sp.point.norm();
    expect_vec_near(sp.point, r * dir, 1e-12, "point on the ray");
    EXPECT_LE(r, radius * (1 + 1e-12));
    EXPECT_GE(r, radius - h * h / (8 * radius));
    EXPECT_NEAR(sp.offset, probe.norm() - r, 1e-12);
  }
}

TEST(Contact, BadInputGivesNoTriangle) {
  const auto m = mesh::make_plane(3, 3, 0.01);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(locate_surface_point(m, Vec3(nan, 0, 0), 0).triangle, kNoIndex);
  EXPECT_EQ(locate_surface_point(m, Vec3(0, std::numeric_limits<double>::infinity(), 0), 0).triangle, kNoIndex);
  EXPECT_EQ(locate_surface_point(m, Vec3::Zero(), 9).triangle, kNoIndex);
  EXPECT_EQ(locate_surface_point(m, Vec3::Zero(), kNoIndex).triangle, kNoIndex);
}

SurfacePoint at(double offset, const Vec3& b = Vec3(1, 0, 0)) {
  SurfacePoint sp;
  sp.triangle = 0;
  sp.barycentric = b;
  sp.offset = offset;
  return sp;
}

TEST(HeightCheck, Cases) {
  // Below an undeformed surface: contact, depth = -offset.
  HeightCheck hc = height_check(at(-0.002), Vec3::Zero());
  EXPECT_TRUE(hc.in_contact);
  EXPECT_DOUBLE_EQ(hc.depth, 0.002);
  EXPECT_EQ(hc.surface_height, 0.0);
  // Above the surface: none.
  hc = height_check(at(0.001), Vec3::Zero());
  EXPECT_FALSE(hc.in_contact);
  EXPECT_DOUBLE_EQ(hc.depth, -0.001);
  // Exactly on the undeformed surface: offset < 0 fails, none.
  EXPECT_FALSE(height_check(at(0.0), Vec3::Zero()).in_contact);
  // The surface already pushed in deeper than the probe (h = -3 mm): none.
  hc = height_check(at(-0.002), Vec3::Constant(-0.003));
  EXPECT_FALSE(hc.in_contact);
  EXPECT_DOUBLE_EQ(hc.surface_height, -0.003);
  // Interpolated height: weights (0.5, 0.5, 0) of (-1 mm, -3 mm, +5 mm) = -2 mm,
  // the probe exactly there: contact (offset <= h).
  hc = height_check(at(-0.002, Vec3(0.5, 0.5, 0)), Vec3(-0.001, -0.003, 0.005));
  EXPECT_DOUBLE_EQ(hc.surface_height, -0.002);
  EXPECT_TRUE(hc.in_contact);
  // 1 um above the interpolated height: none.
  EXPECT_FALSE(height_check(at(-0.002 + 1e-6, Vec3(0.5, 0.5, 0)), Vec3(-0.001, -0.003, 0.005)).in_contact);
  // A raised surface (h > 0) does not make a probe above the rest surface touch.
  EXPECT_FALSE(height_check(at(0.001), Vec3::Constant(0.002)).in_contact);
}

}  // namespace
}  // namespace palpa::collision
