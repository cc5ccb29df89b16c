// Contact point interpolation and the height check on hand-worked cases.

#include "collision/contact.h"
#include "common/test_support.h"
#include "mesh/generate.h"
#include "radial_sphere.h"
#include "mesh/io.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

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

// Every weight pattern on a grid of thirds, ties included: the corner
// returned has a weight no other corner exceeds, and no corner before it
// has as much (the first of equal ones).
TEST(Contact, TheHeaviestCornerHasTheLargestWeightAndIsTheFirstOfEqualOnes) {
  const std::array<double, 5> w = {-1.0 / 3, 0.0, 1.0 / 3, 2.0 / 3, 1.0};
  int checked = 0;
  for (double a : w)
    for (double b : w)
      for (double c : w) {
        const Vec3 bary(a, b, c);
        const int k = heaviest_corner(bary);
        ASSERT_GE(k, 0);
        ASSERT_LE(k, 2);
        for (int j = 0; j < 3; ++j) {
          EXPECT_GE(bary[k], bary[j]) << a << ' ' << b << ' ' << c;
          if (j < k) {
            EXPECT_LT(bary[j], bary[k]) << a << ' ' << b << ' ' << c;
          }
        }
        ++checked;
      }
  EXPECT_EQ(checked, 125);
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

TEST(Contact, OnAFlatTriangleTheAnswerIsItsClosestPoint) {
  // One triangle whose vertex normals are its face normal: the foot of the
  // normal is the orthogonal projection, so inside or out the answer is the
  // triangle's closest point to the probe (outside: the search's fallback,
  // the closest point of the triangles it saw). Against the closed form,
  // the nearest of the projection (when inside) and the three edges'
  // closest points, on random triangles (some needle-thin, some with
  // nearly equal corners) and probes all round them.
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto segment_closest = [](const Vec3& p, const Vec3& a, const Vec3& b) {
    const Vec3 ab = b - a;
    const double len2 = ab.squaredNorm();
    const double s = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    return Vec3(a + s * ab);
  };
  std::size_t inside = 0, outside = 0;
  for (int i = 0; i < 3000; ++i) {
    mesh::SurfaceMesh m;
    const Vec3 a(u(rng), u(rng), u(rng));
    Vec3 b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
    if (i % 5 == 1) c = a + 1e-3 * (b - a) + 1e-4 * Vec3(u(rng), u(rng), u(rng));  // a needle
    if (i % 5 == 2) b = a + 1e-6 * Vec3(u(rng), u(rng), u(rng));                   // two corners 1 um apart
    m.positions = {a, b, c};
    m.triangles = {{0, 1, 2}};
    mesh::finalize(m);
    const Vec3 n = (b - a).cross(c - a).normalized();
    m.normals = {n, n, n};
    // A third of the probes above or below a point of the triangle, the rest anywhere around.
    Vec3 probe = 2.0 * Vec3(u(rng), u(rng), u(rng));
    if (i % 3 == 0) {
      const double w1 = 0.5 + 0.5 * u(rng), w2 = (1 - w1) * (0.5 + 0.5 * u(rng));
      probe = (1 - w1 - w2) * a + w1 * b + w2 * c + u(rng) * n;
    }
    // The closed form.
    double want = std::min({(probe - segment_closest(probe, a, b)).norm(), (probe - segment_closest(probe, b, c)).norm(),
                            (probe - segment_closest(probe, c, a)).norm()});
    const Vec3 e1 = b - a, e2 = c - a, d = probe - a;
    const double a11 = e1.dot(e1), a12 = e1.dot(e2), a22 = e2.dot(e2), det = a11 * a22 - a12 * a12;
    const double s = (a22 * d.dot(e1) - a12 * d.dot(e2)) / det, t = (a11 * d.dot(e2) - a12 * d.dot(e1)) / det;
    const bool projects_inside = s >= 0 && t >= 0 && s + t <= 1;
    if (projects_inside) want = std::min(want, std::abs(d.dot(n)));
    const SurfacePoint sp = locate_surface_point(m, probe, 0);
    ASSERT_EQ(sp.triangle, 0u) << "triangle " << i;
    EXPECT_GE(sp.barycentric.minCoeff(), 0.0) << "triangle " << i;
    EXPECT_NEAR(sp.barycentric.sum(), 1.0, 1e-12) << "triangle " << i;
    EXPECT_LE((sp.barycentric[0] * a + sp.barycentric[1] * b + sp.barycentric[2] * c - sp.point).norm(), 1e-12)
        << "triangle " << i;
    EXPECT_NEAR((sp.point - probe).norm(), want, 1e-9) << "triangle " << i << ", probe " << probe.transpose();
    (projects_inside ? inside : outside) += 1;
  }
  // Both kinds are exercised.
  EXPECT_GT(inside, 500u);
  EXPECT_GT(outside, 1000u);
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

// A probe leaving contact (track_contact) asks the tree from its root,
// whatever leaf its cursor holds: the nearest vertex is the brute-force one,
// as query_contact's from that leaf, and the cursor ends on the leaf of the
// answer (a local search from it at the same point starts there).
TEST(Contact, TheQueryFromTheRootFindsTheNearestVertexFromAFarLeaf) {
  const double radius = 0.05;
  const auto m = mesh::make_sphere(10000, radius);
  const VertexTree tree(m);
  std::mt19937 rng(11);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.95, 1.05);
  for (int i = 0; i < 200; ++i) {
    const Vec3 dir = Vec3(g(rng), g(rng), g(rng)).normalized();
    const Vec3 probe = dir * radius * u(rng);
    // A cursor whose leaf is on the far side of the sphere.
    ContactCursor far;
    (void)query_contact(m, tree, -probe, far, false);
    ContactCursor from_leaf = far, from_root = far;
    const ContactAnswer a = query_contact(m, tree, probe, from_leaf, false);
    const ContactAnswer b = query_contact_from_root(m, tree, probe, from_root);
    Index brute = kNoIndex;
    double best = std::numeric_limits<double>::infinity();
    for (Index v = 0; v < m.vertex_count(); ++v)
      if (const double d = (m.positions[v] - probe).squaredNorm(); d < best) {
        best = d;
        brute = v;
      }
    EXPECT_EQ(b.nearest_vertex, brute) << "probe " << probe.transpose();
    EXPECT_EQ(b.nearest_vertex, a.nearest_vertex) << "probe " << probe.transpose();
    EXPECT_EQ(b.path, ContactPath::Tree);
    EXPECT_EQ(b.surface.triangle, a.surface.triangle);
    EXPECT_EQ(from_root.tree.leaf, from_leaf.tree.leaf);
  }
}

TEST(Contact, SphereWithRadialNormalsIsExactlyRadial) {
  // With exactly radial vertex normals n_i = p_i / R, the blended normal
  // sum b_i n_i = C(b) / R is parallel to the blended point C(b), so the
  // solution of P = C + t N lies on the ray through P: the point is
  // |C| P/|P| with R - |C| at most the sagitta h^2 / 8R, the normal P/|P|.
  const double radius = 0.05;
  auto m = test::radial_sphere(10000, radius);
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

// ---------------------------------------------------------------------------
// The shared organs these tests load, with their files' units (SOURCES.md:
// the smooth liver in cm, the others in mm) and what the walk is expected to
// do on each (ContactWalk.MatchesTheFullQueryAlongSlidingPathsOnOrgans).
struct SharedOrgan {
  const char* file;
  double unit_m;
  double min_walked;  // fraction of queries the walk answers, at least
  double max_differ;  // fraction of walked answers that may differ from the full query, at most
};
constexpr SharedOrgan kSharedOrgans[] = {{"sofa_liver-smooth.obj", 1e-2, 0.95, 0.01},
                                         {"sofa_liver.vtk", 1e-3, 0.95, 0.0},
                                         {"sofa_coeur1.off", 1e-3, 0.95, 0.0},
                                         {"bp3d_FMA72717_right_cingulate_gyrus.obj", 1e-3, 0.80, 0.06},
                                         {"gca_EdinGCA_3D_00090_large_intestine_20k.vtk", 1e-3, 0.95, 0.0}};

// One of them in metres, its largest component only (sofa_liver.vtk carries
// three tiny specks).
mesh::SurfaceMesh load_shared_organ(const SharedOrgan& o) {
  mesh::LoadOptions lo;
  lo.unit_m = o.unit_m;
  lo.keep_largest_component = true;
  return mesh::load_mesh(test::shared_organs_dir() / o.file, lo);
}

// ---------------------------------------------------------------------------
// locate_surface_point against a brute-force search of the nearest vertex's
// triangles. Each triangle's own answer comes from walk_surface_point
// started on it: where that triangle holds the foot of the interpolated
// normal (with the probe below the surface and within half its focal
// distance) the walk answers at once on it, with the bits locate's solve
// gives. The search must then answer inside and no farther than the
// nearest of those feet. This is what the search's cheap test before each
// solve must not break: it skips only triangles that cannot hold the foot.
// The probes are built below random points of random triangles,
// P = C(b) + s N(b), s < 0, so that most have a foot around their nearest
// vertex.

struct FootCheck {
  std::size_t probes = 0;  // probes with a foot on a triangle around the nearest vertex
  std::size_t feet = 0;    // such feet, all probes
  std::size_t wrong = 0;   // probes whose search answered outside or farther
};

// `count` probes, each at most `reach` (< 1) times half its triangle's focal
// distance below the surface (kappa the largest |n_a - n_b| / |p_a - p_b|
// over its edges, as the walk's test).
FootCheck check_feet_around_nearest(const mesh::SurfaceMesh& m, std::mt19937& rng, int count, double reach,
                                    const std::string& what) {
  const VertexTree tree(m.positions);
  std::uniform_int_distribution<Index> pick(0, static_cast<Index>(m.triangle_count() - 1));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  FootCheck fc;
  for (int i = 0; i < count; ++i) {
    const auto& tri = m.triangles[pick(rng)];
    double u = unit(rng), v = unit(rng);
    if (u + v > 1) {
      u = 1 - u;
      v = 1 - v;
    }
    const Vec3 b(1 - u - v, u, v);
    Vec3 point = Vec3::Zero(), normal = Vec3::Zero();
    double edge = 0, kappa = 0;
    for (int k = 0; k < 3; ++k) {
      point += b[k] * m.positions[tri[k]];
      normal += b[k] * m.normals[tri[k]];
      const Index j = tri[(k + 1) % 3];
      const double len = (m.positions[tri[k]] - m.positions[j]).norm();
      edge = std::max(edge, len);
      kappa = std::max(kappa, (m.normals[tri[k]] - m.normals[j]).norm() / len);
    }
    const double depth = reach * std::min(kappa > 0 ? 0.5 / kappa : edge, edge) * unit(rng);
    const Vec3 probe = point - depth * normal / normal.norm();
    const Index nearest = tree.nearest(probe).vertex;
    double best = std::numeric_limits<double>::infinity();
    for (Index t : m.vertex_triangles.row(nearest)) {
      const SurfacePoint own = walk_surface_point(m, probe, t);
      if (own.triangle != t) continue;
      ++fc.feet;
      best = std::min(best, (own.point - probe).norm());
    }
    if (!std::isfinite(best)) continue;
    ++fc.probes;
    const SurfacePoint sp = locate_surface_point(m, probe, nearest);
    const double got = (sp.point - probe).norm();
    if (!sp.inside || !(got <= best * (1 + 1e-12))) {
      ++fc.wrong;
      ADD_FAILURE() << what << ": probe " << probe.transpose() << " (nearest vertex " << nearest
                    << ") has a foot on a triangle around its nearest vertex " << best
                    << " m away; the search answered triangle " << sp.triangle
                    << (sp.inside ? " inside, " : " not inside, ") << got << " m away";
      if (fc.wrong > 5) break;
    }
  }
  return fc;
}

// A bumpy grid whose vertex normals are tilted at random, some past 90
// degrees from their triangles' planes (where no cheap test applies).
mesh::SurfaceMesh tilted_grid(std::mt19937& rng, double max_tilt) {
  auto m = mesh::make_plane(31, 31, 0.002);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (auto& p : m.positions) p.z() += 0.0004 * g(rng);
  for (auto& n : m.normals) {
    const Vec3 side = Vec3(g(rng), g(rng), 0).normalized();
    const double a = max_tilt * unit(rng);
    n = std::cos(a) * Vec3::UnitZ() + std::sin(a) * side;
  }
  return m;
}

TEST(Contact, LocateFindsTheNearestFootAroundTheNearestVertex) {
  std::mt19937 rng(31);
  // A sphere (normals from the mesh), the synthetic organ, and grids with
  // tilted normals: up to 30 degrees, and up to 100 (corner normals behind
  // their triangles' planes).
  std::vector<std::pair<std::string, mesh::SurfaceMesh>> meshes;
  meshes.emplace_back("sphere 2k", mesh::make_sphere(2000, 0.05));
  meshes.emplace_back("organ 5k", mesh::make_organ(5000));
  meshes.emplace_back("grid, normals within 30 degrees", tilted_grid(rng, 30 * std::numbers::pi / 180));
  meshes.emplace_back("grid, normals within 100 degrees", tilted_grid(rng, 100 * std::numbers::pi / 180));
  for (const auto& [what, m] : meshes) {
    for (double reach : {0.3, 0.95}) {
      const FootCheck fc = check_feet_around_nearest(m, rng, 3000, reach, what);
      EXPECT_EQ(fc.wrong, 0u) << what << ", reach " << reach;
      // Enough probes with a foot around their nearest vertex, most with more than one triangle to choose from.
      EXPECT_GE(fc.probes, 1500u) << what << ", reach " << reach;
      std::printf("%s, reach %.2f: %zu probes with a foot around their nearest vertex, %zu such feet\n",
                  what.c_str(), reach, fc.probes, fc.feet);
    }
  }
}

TEST(Contact, LocateFindsTheNearestFootAroundTheNearestVertexOnOrgans) {
  PALPA_REQUIRE_SHARED_ORGANS();
  std::mt19937 rng(32);
  for (const SharedOrgan& o : kSharedOrgans) {
    const auto m = load_shared_organ(o);
    const char* file = o.file;
    for (double reach : {0.3, 0.95}) {
      const FootCheck fc = check_feet_around_nearest(m, rng, 3000, reach, file);
      EXPECT_EQ(fc.wrong, 0u) << file << ", reach " << reach;
      EXPECT_GE(fc.probes, 1500u) << file << ", reach " << reach;
      std::printf("%s, reach %.2f: %zu probes with a foot around their nearest vertex, %zu such feet\n", file,
                  reach, fc.probes, fc.feet);
    }
  }
}

// ---------------------------------------------------------------------------
// The in-contact walk against the full query (nearest vertex by brute force,
// then locate_surface_point), along sliding trajectories.

// The reference answer: brute-force nearest vertex, surface point around it.
SurfacePoint full_query(const mesh::SurfaceMesh& m, const Vec3& q) {
  return locate_surface_point(m, q, nearest_brute_force(m.positions, q).vertex);
}

double longest_edge(const mesh::SurfaceMesh& m) {
  double h = 0;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) h = std::max(h, (m.positions[t[k]] - m.positions[t[(k + 1) % 3]]).norm());
  return h;
}

// A probe sliding `depth` (m) below the surface: every step moves the surface
// point `step` (m) along a heading that turns by up to 0.1 rad, then finds
// the surface point of that position by the full query. Starts at a seeded vertex.
std::vector<Vec3> sliding_path(const mesh::SurfaceMesh& m, std::mt19937& rng, int steps, double step,
                               double depth) {
  std::uniform_int_distribution<Index> vertex(0, static_cast<Index>(m.vertex_count() - 1));
  std::uniform_real_distribution<double> turn(-0.1, 0.1);
  std::normal_distribution<double> g;
  const Index v0 = vertex(rng);
  Vec3 point = m.positions[v0], normal = m.normals[v0];
  auto tangent = [](const Vec3& d, const Vec3& n) {
    const Vec3 t = d - d.dot(n) * n;
    return t.norm() > 1e-9 ? Vec3(t.normalized()) : Vec3(n.unitOrthogonal());
  };
  Vec3 heading = tangent(Vec3(g(rng), g(rng), g(rng)), normal);
  std::vector<Vec3> path;
  for (int k = 0; k < steps; ++k) {
    path.push_back(point - depth * normal);
    const double a = turn(rng);
    heading = std::cos(a) * heading + std::sin(a) * normal.cross(heading);
    const SurfacePoint sp = full_query(m, point + step * heading);
    if (sp.triangle == kNoIndex) break;
    point = sp.point;
    normal = sp.normal;
    heading = tangent(heading, normal);
  }
  return path;
}

// Counts of a comparison of query_contact with the full query.
struct WalkStats {
  std::size_t queries = 0, walked = 0, same_triangle = 0, differ = 0;
  WalkStats& operator+=(const WalkStats& o) {
    queries += o.queries;
    walked += o.walked;
    same_triangle += o.same_triangle;
    differ += o.differ;
    return *this;
  }
};

// Along the path, runs query_contact as the haptic tick does (in contact
// while the probe is below the undeformed surface) and compares each answer
// with the full query. Tree answers must be the full query itself (exact
// nearest vertex). Walked answers must be a true solution (inside a
// triangle, below the surface, the probe on the interpolated normal line
// through the point) and are counted as differing unless they give the full
// query's virtual vertex within tol (m); on the same triangle they must be
// bit-identical to it.
WalkStats compare_walk_with_full(const mesh::SurfaceMesh& m, const VertexTree& tree, const std::vector<Vec3>& path,
                                 double tol, const std::string& what) {
  WalkStats st;
  ContactCursor cursor;
  bool in_contact = false;
  for (std::size_t k = 0; k < path.size(); ++k) {
    const Vec3& q = path[k];
    const SurfacePoint full = full_query(m, q);
    ++st.queries;
    const ContactAnswer ans = query_contact(m, tree, q, cursor, in_contact);
    const SurfacePoint& got = ans.surface;
    in_contact = got.triangle != kNoIndex && got.offset < 0;
    EXPECT_EQ(cursor.triangle, got.triangle);
    if (ans.path == ContactPath::Tree) {
      EXPECT_EQ(ans.nearest_vertex, nearest_brute_force(m.positions, q).vertex) << what << " step " << k;
      EXPECT_EQ(got.triangle, full.triangle) << what << " step " << k;
      EXPECT_EQ(got.point, full.point) << what << " step " << k;
      continue;
    }
    EXPECT_EQ(ans.path, ContactPath::Walk);
    ++st.walked;
    // A true solution: inside, below, probe = point + offset * normal.
    const auto& tri = m.triangles[got.triangle];
    EXPECT_TRUE(got.inside) << what << " step " << k;
    EXPECT_LT(got.offset, 0.0) << what << " step " << k;
    EXPECT_GE(got.barycentric.minCoeff(), 0.0) << what << " step " << k;
    EXPECT_NEAR(got.barycentric.sum(), 1.0, 1e-15) << what << " step " << k;
    EXPECT_LE((q - got.point - got.offset * got.normal).norm(), 1e-12 * (1 + q.norm())) << what << " step " << k;
    EXPECT_TRUE(ans.nearest_vertex == tri[0] || ans.nearest_vertex == tri[1] || ans.nearest_vertex == tri[2]);
    for (Index v : tri)
      EXPECT_LE((m.positions[ans.nearest_vertex] - q).squaredNorm(), (m.positions[v] - q).squaredNorm());
    // The full query's virtual vertex.
    const bool same = full.inside && (got.point - full.point).norm() <= tol &&
                      (got.normal - full.normal).norm() <= 1e-9 && std::abs(got.offset - full.offset) <= tol;
    st.differ += !same;
    if (got.triangle == full.triangle) {
      ++st.same_triangle;
      EXPECT_EQ(got.barycentric, full.barycentric) << what << " step " << k;
      EXPECT_EQ(got.point, full.point) << what << " step " << k;
      EXPECT_EQ(got.normal, full.normal) << what << " step " << k;
      EXPECT_EQ(got.offset, full.offset) << what << " step " << k;
    }
  }
  return st;
}

TEST(ContactWalk, MatchesTheFullQueryAlongSlidingPathsOnSpheres) {
  // Area-weighted normals of the cube-sphere (not exactly radial); probes 0.2
  // to 3 mm deep sliding 1/10 to 1 longest edge per step.
  for (std::size_t n : {2000u, 20000u}) {
    const double radius = 0.05;
    const auto m = mesh::make_sphere(n, radius);
    const double h = longest_edge(m);
    const VertexTree tree(m.positions);
    std::mt19937 rng(40 + static_cast<unsigned>(n));
    WalkStats total;
    for (double depth : {0.0002, 0.001, 0.003}) {
      for (double step : {0.1 * h, 0.4 * h, h}) {
        const std::string what = "sphere " + std::to_string(n) + " depth " + std::to_string(depth) + " step " +
                                 std::to_string(step);
        const auto path = sliding_path(m, rng, 300, step, depth);
        ASSERT_EQ(path.size(), 300u);
        const WalkStats st = compare_walk_with_full(m, tree, path, 1e-12, what);
        // Short steps: every query after the first is walked (long ones may
        // exceed the jump limit of the last triangle and go to the tree).
        if (step < 0.5 * h) {
          EXPECT_EQ(st.walked, st.queries - 1) << what;
        }
        total += st;
      }
    }
    // On a sphere the walk always lands on the full query's virtual vertex,
    // almost always on the very same triangle (else on a shared edge).
    EXPECT_EQ(total.differ, 0u) << "sphere " << n;
    EXPECT_GE(total.same_triangle, total.walked * 99 / 100) << "sphere " << n;
    EXPECT_GE(total.walked, total.queries * 2 / 3) << "sphere " << n;
  }
}

TEST(ContactWalk, MatchesTheFullQueryAlongSlidingPathsOnOrgans) {
  // Probes 0.2 and 1 mm deep sliding over the shared organs. Where a fold is
  // about as thin as the probe is deep the full query may change sheets (its
  // nearest vertex moves to the other side) while the walk keeps the one the
  // contact slid on, so a few answers may differ there (each still a true
  // solution, checked in compare_walk_with_full).
  PALPA_REQUIRE_SHARED_ORGANS();
  for (const SharedOrgan& o : kSharedOrgans) {
    const auto m = load_shared_organ(o);
    const double h = longest_edge(m);
    const VertexTree tree(m.positions);
    std::mt19937 rng(77);
    WalkStats total;
    for (double depth : {0.0002, 0.001}) {
      for (int path_no = 0; path_no < 4; ++path_no) {
        const auto path = sliding_path(m, rng, 250, 0.03 * h * (1 + path_no), depth);
        total += compare_walk_with_full(m, tree, path, 1e-12, std::string(o.file));
      }
    }
    std::printf("%s: %zu queries, %zu walked, %zu on the full query's triangle, %zu differ from it\n", o.file,
                total.queries, total.walked, total.same_triangle, total.differ);
    EXPECT_GE(static_cast<double>(total.walked), o.min_walked * static_cast<double>(total.queries)) << o.file;
    EXPECT_LE(static_cast<double>(total.differ), o.max_differ * static_cast<double>(total.walked)) << o.file;
  }
}

TEST(ContactWalk, CrossesEdgesToTheTriangleUnderTheProbe) {
  // Flat grid with normals +z: the walk from a triangle a few edges away
  // reaches the triangle holding the probe's foot, with locate's bits; from
  // farther than kMaxWalkSteps triangles it declines.
  const auto m = mesh::make_plane(21, 21, 0.005);
  const Vec3 probe(0.0112, -0.0031, -0.001);
  const SurfacePoint want = full_query(m, probe);
  ASSERT_TRUE(want.inside);
  std::size_t answered = 0, declined = 0;
  for (Index t = 0; t < m.triangle_count(); ++t) {
    const SurfacePoint got = walk_surface_point(m, probe, t);
    Vec3 c = Vec3::Zero();
    for (Index v : m.triangles[t]) c += m.positions[v] / 3;
    const double dist = (c - want.point).norm();
    if (got.triangle == kNoIndex) {
      ++declined;
      // Triangles within two edges of the foot are always close enough.
      EXPECT_GT(dist, 2 * 0.005) << "triangle " << t;
      continue;
    }
    ++answered;
    EXPECT_LE((got.point - want.point).norm(), 1e-15) << "triangle " << t;
    EXPECT_NEAR(got.offset, -0.001, 1e-15);
    // Each step crosses one edge, so the walk cannot answer from far away.
    EXPECT_LT(dist, kMaxWalkSteps * 0.005 * 1.5) << "triangle " << t;
    if (got.triangle == want.triangle) {
      EXPECT_EQ(got.barycentric, want.barycentric);
    }
  }
  EXPECT_GT(answered, 10u);
  EXPECT_GT(declined, 100u);
}

// Why a traced walk from `start` stopped; an answer, and only an answer,
// says WalkEnd::Answer.
WalkEnd why(const mesh::SurfaceMesh& m, const Vec3& probe, Index start) {
  WalkTrace trace;
  const SurfacePoint sp = walk_surface_point(m, probe, start, trace);
  EXPECT_EQ(sp.triangle != kNoIndex, trace.end == WalkEnd::Answer);
  return trace.end;
}

TEST(ContactWalk, DeclinesAboveTheSurfaceBeyondTheBorderAndPastHalfTheFocalDistance) {
  // Above the flat grid: the tree decides a probe that left the surface.
  const auto plane = mesh::make_plane(5, 5, 0.01);
  const SurfacePoint under = full_query(plane, Vec3(0.001, 0.002, -0.001));
  ASSERT_NE(walk_surface_point(plane, Vec3(0.001, 0.002, -0.001), under.triangle).triangle, kNoIndex);
  EXPECT_EQ(walk_surface_point(plane, Vec3(0.001, 0.002, 0.001), under.triangle).triangle, kNoIndex);
  // Past the border x = 0.02: no triangle to step into.
  EXPECT_EQ(walk_surface_point(plane, Vec3(0.025, 0.0, -0.001), under.triangle).triangle, kNoIndex);
  EXPECT_EQ(walk_surface_point(plane, Vec3(0.001, 0.002, -0.001), kNoIndex).triangle, kNoIndex);

  // A sphere with radial normals: |n_a - n_b| = |p_a - p_b| / R on every
  // edge, so the focal distance is R and the walk answers down to R / 2 deep.
  const double radius = 0.05;
  auto m = test::radial_sphere(5000, radius);
  std::mt19937 rng(9);
  std::normal_distribution<double> g;
  for (int i = 0; i < 100; ++i) {
    const Vec3 dir = Vec3(g(rng), g(rng), g(rng)).normalized();
    const SurfacePoint start = full_query(m, dir * radius * 0.99);
    ASSERT_TRUE(start.inside);
    // The surface point is at |C| <= R along dir (sagitta aside): depth = |C| - |probe|.
    const double c = start.point.norm();
    // Its trace says so (ContactWalk.ItsTraceSaysWhyItStopped).
    EXPECT_EQ(why(m, dir * (c - 0.49 * radius), start.triangle), WalkEnd::Answer) << i;
    EXPECT_EQ(why(m, dir * (c - 0.51 * radius), start.triangle), WalkEnd::TooDeep) << i;
  }
}

// Each way a walk stops is reported in its trace (WalkTrace::end), in
// situations whose outcome follows from the geometry alone.
TEST(ContactWalk, ItsTraceSaysWhyItStopped) {
  // A flat grid of 1 mm squares, 40 mm across (x and y from -0.02 to 0.02).
  const auto plane = mesh::make_plane(41, 41, 0.001);
  const Vec3 below(-0.0095, 0.0002, -0.001);
  const Index under = full_query(plane, below).triangle;
  ASSERT_NE(under, kNoIndex);
  EXPECT_EQ(why(plane, below, under), WalkEnd::Answer);
  EXPECT_EQ(why(plane, Vec3(-0.0095, 0.0002, 0.001), under), WalkEnd::Above);
  EXPECT_EQ(why(plane, below, kNoIndex), WalkEnd::BadInput);
  EXPECT_EQ(why(plane, Vec3(-0.0095, 0.0002, std::nan("")), under), WalkEnd::BadInput);
  // Past the border x = 0.02, next to the triangle under the probe's foot
  // on the border: the step out of the grid finds no triangle.
  const Index edge = full_query(plane, Vec3(0.0195, 0.0002, -0.001)).triangle;
  ASSERT_NE(edge, kNoIndex);
  EXPECT_EQ(why(plane, Vec3(0.0215, 0.0002, -0.001), edge), WalkEnd::Border);
  // 20 mm away, twenty squares: far more triangles than kMaxWalkSteps.
  EXPECT_EQ(why(plane, Vec3(0.0105, 0.0002, -0.001), under), WalkEnd::OutOfSteps);
  // TooDeep: on the radial sphere of the test above.
}

// ---------------------------------------------------------------------------
// The walk's trace: a walk started afresh on a later triangle of the trace,
// with the same probe, must give the same bits (or no answer) wherever the
// trace says it repeats; track_contact skips such a walk on that promise.

struct TraceCheck {
  std::size_t walks = 0;     // walks traced
  std::size_t restarts = 0;  // restarts the trace says repeat, all checked
  std::size_t wrong = 0;     // of those, restarts with another answer
  // Restarts from triangles the trace leaves out (all of a walk that is not
  // repeatable) that gave another answer: the trace is right to leave them
  // out.
  std::size_t excluded_differ = 0;
};

bool same_answer(const SurfacePoint& a, const SurfacePoint& b) {
  if (a.triangle != b.triangle) return false;
  if (a.triangle == kNoIndex) return true;
  return a.point == b.point && a.offset == b.offset && a.barycentric == b.barycentric && a.normal == b.normal;
}

// `n` probes under random points of random triangles, between `depth_lo`
// and `depth_hi` (m) below them along the interpolated normal, each walked
// from a triangle up to eight random steps across edges from the one above
// it; every later triangle of the trace is restarted.
TraceCheck check_walk_traces(const mesh::SurfaceMesh& m, std::mt19937& rng, int n, double depth_lo,
                             double depth_hi, const std::string& what) {
  TraceCheck c;
  std::uniform_int_distribution<Index> tri(0, static_cast<Index>(m.triangle_count() - 1));
  std::uniform_real_distribution<double> u(0, 1), dd(depth_lo, depth_hi);
  std::uniform_int_distribution<int> hops(0, 8), side(0, 2);
  for (int i = 0; i < n; ++i) {
    const Index t = tri(rng);
    double a = u(rng), b = u(rng);
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    const mesh::Triangle& tv = m.triangles[t];
    const Vec3 w(1 - a - b, a, b);
    const Vec3 point = w[0] * m.positions[tv[0]] + w[1] * m.positions[tv[1]] + w[2] * m.positions[tv[2]];
    const Vec3 normal = (w[0] * m.normals[tv[0]] + w[1] * m.normals[tv[1]] + w[2] * m.normals[tv[2]]).normalized();
    const Vec3 probe = point - dd(rng) * normal;
    Index start = t;
    for (int h = hops(rng); h > 0; --h) {
      const Index next = m.triangle_neighbors[start][side(rng)];
      if (next != kNoIndex) start = next;
    }
    WalkTrace trace;
    const SurfacePoint walked = walk_surface_point(m, probe, start, trace);
    ++c.walks;
    // The trace is the walk's path: it starts on `start`, each next triangle
    // shares an edge with the one before, and it gives the untraced answer.
    EXPECT_TRUE(same_answer(walked, walk_surface_point(m, probe, start))) << what << ", probe " << i;
    if (trace.count < 1 || trace.count > WalkTrace::kCapacity) {
      ADD_FAILURE() << what << ", probe " << i << ": a trace of " << trace.count << " triangles";
      ++c.wrong;
      continue;
    }
    EXPECT_EQ(trace.triangles[0], start) << what;
    for (int k = 1; k < trace.count; ++k) {
      const auto& nb = m.triangle_neighbors[trace.triangles[k - 1]];
      EXPECT_TRUE(nb[0] == trace.triangles[k] || nb[1] == trace.triangles[k] || nb[2] == trace.triangles[k])
          << what << ", probe " << i << ": step " << k << " is not across an edge";
    }
    // repeats_from(t): t is among triangles[1 .. count - 1] of a repeatable
    // walk (the start is not, unless the walk came back to it: the caller's
    // first walk may have declined there for its jump test).
    for (int k = 0; k < trace.count; ++k) {
      bool listed = false;
      for (int j = 1; trace.repeatable && j < trace.count; ++j)
        listed = listed || trace.triangles[j] == trace.triangles[k];
      EXPECT_EQ(trace.repeats_from(trace.triangles[k]), listed) << what << ", probe " << i << ", step " << k;
    }
    for (int k = 1; k < trace.count; ++k) {
      const bool same = same_answer(walked, walk_surface_point(m, probe, trace.triangles[k]));
      if (trace.repeatable) {
        ++c.restarts;
        if (!same) {
          ++c.wrong;
          ADD_FAILURE() << what << ", probe " << i << ": the walk from step " << k << " of " << trace.count
                        << " ends otherwise";
        }
      } else if (!same) {
        ++c.excluded_differ;
      }
    }
  }
  return c;
}

TEST(ContactWalk, AWalkFromALaterTriangleOfItsTraceEndsAsTheTraceSays) {
  // A sphere with radial normals (focal distance R): probes from above the
  // surface to twice R deep, where walks step back and forth or run out of
  // steps; grids with normals tilted up to 30 and 100 degrees.
  const double radius = 0.05;
  std::mt19937 rng(41);
  struct Case {
    std::string name;
    mesh::SurfaceMesh mesh;
    double depth_lo, depth_hi;
  };
  std::vector<Case> cases;
  cases.push_back({"radial sphere", test::radial_sphere(3000, radius), -0.2 * radius, 2 * radius});
  for (double tilt : {30.0, 100.0}) {
    auto g = mesh::make_plane(12, 12, 0.01);
    std::uniform_real_distribution<double> ang(-tilt / 2, tilt / 2);
    for (auto& n : g.normals) {
      const double ax = ang(rng) * std::numbers::pi / 180, ay = ang(rng) * std::numbers::pi / 180;
      n = (Eigen::AngleAxisd(ax, Vec3::UnitX()) * Eigen::AngleAxisd(ay, Vec3::UnitY()) * Vec3::UnitZ()).normalized();
    }
    cases.push_back({"grid tilted " + std::to_string(static_cast<int>(tilt)) + " deg", g, -0.005, 0.03});
  }
  TraceCheck total;
  for (const Case& k : cases) {
    const TraceCheck c = check_walk_traces(k.mesh, rng, 3000, k.depth_lo, k.depth_hi, k.name);
    std::printf("%s: %zu walks, %zu restarts checked, %zu from left-out triangles that end otherwise\n",
                k.name.c_str(), c.walks, c.restarts, c.excluded_differ);
    EXPECT_EQ(c.wrong, 0u) << k.name;
    EXPECT_GE(c.restarts, 500u) << k.name;
    total.excluded_differ += c.excluded_differ;
  }
  // The left-out triangles are left out for a reason: some restarts from
  // them end otherwise (these walks have no jump test, so they are the
  // walks that ran out of steps).
  EXPECT_GT(total.excluded_differ, 0u);
}

TEST(ContactWalk, AWalkFromALaterTriangleOfItsTraceEndsAsTheTraceSaysOnOrgans) {
  PALPA_REQUIRE_SHARED_ORGANS();
  std::mt19937 rng(43);
  for (const SharedOrgan& o : kSharedOrgans) {
    const auto m = load_shared_organ(o);
    const TraceCheck c = check_walk_traces(m, rng, 3000, -0.001, 0.008, o.file);
    std::printf("%s: %zu walks, %zu restarts checked, %zu from left-out triangles that end otherwise\n", o.file,
                c.walks, c.restarts, c.excluded_differ);
    EXPECT_EQ(c.wrong, 0u) << o.file;
    EXPECT_GE(c.restarts, 500u) << o.file;
  }
}

// How the guess fared in check_guessed_crossings.
struct GuessCounts {
  std::size_t compared = 0;      // walk answers compared
  std::size_t right = 0;         // the answer on the guessed triangle
  std::size_t wrong = 0;         // the walk came back to the start
  std::size_t beyond_guess = 0;  // the answer on a neighbour of the guessed triangle
  std::size_t beyond_plain = 0;  // an answer where the walk without the guess declines
  std::size_t other_foot = 0;    // an answer on another triangle than that walk's
};

// The in-contact walk of query_contact first looks for a probe that may
// have crossed an edge across the edge it guesses from the last answer's
// weights (the cursor's barycentric), without solving the start triangle.
// Right or wrong, the guess must not change the answer: it must be the
// walk's from the same start without a guess (walk_surface_point), bit for
// bit, or no walk answer when that walk has none. The hints here are the
// true last weights and made-up ones (which make the guess wrong more
// often); the test works out the guess itself, as the walk documents it
// (when it is made, and which edge), and requires that right guesses,
// wrong ones and answers beyond the guessed triangle (the probe past a
// corner of the start, where the walk goes on from the guessed triangle)
// were all exercised.
//
// Here: `trials` random crossings of mesh m, each compared with the walk
// without the guess (failures are reported with `name`). With `unique_feet` (a
// convex mesh: one foot under each probe), the answers must be that walk's.
GuessCounts check_guessed_crossings(const mesh::SurfaceMesh& m, std::mt19937& rng, int trials, bool unique_feet,
                                    const std::string& name) {
  GuessCounts c;
  const VertexTree tree(m.positions);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<Index> pick(0, static_cast<Index>(m.triangle_count() - 1));
  for (int trial = 0; trial < trials; ++trial) {
    const Index s = pick(rng);
    const auto& tri = m.triangles[s];
    const Vec3 p[3] = {m.positions[tri[0]], m.positions[tri[1]], m.positions[tri[2]]};
    const Vec3 nrm[3] = {m.normals[tri[0]], m.normals[tri[1]], m.normals[tri[2]]};
    const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
    const double longest_sq = std::max({e1.squaredNorm(), e2.squaredNorm(), (e2 - e1).squaredNorm()});
    // The last answer: a point of s near an edge, 0.1 to 2 mm deep.
    Vec3 last(unit(rng), unit(rng), 0.02 * unit(rng));
    std::shuffle(last.data(), last.data() + 3, rng);
    last /= last.sum();
    const Vec3 at = last[0] * p[0] + last[1] * p[1] + last[2] * p[2];
    const Vec3 along = (last[0] * nrm[0] + last[1] * nrm[1] + last[2] * nrm[2]).normalized();
    const Vec3 before = at - (1e-4 + 1.9e-3 * unit(rng)) * along;
    // The probe now: moved up to 0.6 of the longest edge (no jump).
    const Vec3 dir = Vec3(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5).normalized();
    const Vec3 probe = before + 0.6 * std::sqrt(longest_sq) * unit(rng) * dir;
    // The true last weights, or made-up ones with a small least weight.
    Vec3 hint = last;
    if (trial % 2 == 1) {
      hint = Vec3(unit(rng), unit(rng), 0.03 * unit(rng));
      std::shuffle(hint.data(), hint.data() + 3, rng);
      hint /= hint.sum();
    }
    // The guess, worked out here: whether the foot can have left s (its
    // least weight times s's least height within twice the move), then
    // the probe carried onto s's plane along the normal at `hint`.
    const double det = e1.squaredNorm() * e2.squaredNorm() - std::pow(e1.dot(e2), 2);
    const double move_sq = (probe - before).squaredNorm();
    int k = -1;
    if (!(hint.minCoeff() * hint.minCoeff() * det > 4 * move_sq * longest_sq)) {
      const Vec3 nh = hint[0] * nrm[0] + hint[1] * nrm[1] + hint[2] * nrm[2];
      Eigen::Matrix3d a;
      a << e1, e2, nh;
      const Vec3 x = a.colPivHouseholderQr().solve(probe - p[0]);
      const Vec3 w(1 - x[0] - x[1], x[0], x[1]);
      if ((w.array() < 0).count() == 1 && e1.cross(e2).dot(nh) > 0) w.minCoeff(&k);
    }
    const SurfacePoint plain = walk_surface_point(m, probe, s);
    ContactCursor cursor;
    cursor.triangle = s;
    cursor.probe = before;
    cursor.barycentric = hint;
    cursor.at_foot = true;
    const ContactAnswer ans = query_contact(m, tree, probe, cursor, true);
    const std::string what = name + " trial " + std::to_string(trial);
    // Where the surface folds, the guessed triangle's side can hold a foot
    // where the walk from s declines (too deep there, or stepping back), or
    // another foot than the one it finds. Such an answer must be a foot of
    // its own triangle: a walk started there answers at once, with the
    // same bits.
    auto own_foot = [&] {
      const SurfacePoint there = walk_surface_point(m, probe, ans.surface.triangle);
      EXPECT_EQ(there.triangle, ans.surface.triangle) << what;
      EXPECT_EQ(there.barycentric, ans.surface.barycentric) << what;
      EXPECT_EQ(there.offset, ans.surface.offset) << what;
      EXPECT_LT(ans.surface.offset, 0) << what;
    };
    if (plain.triangle == kNoIndex) {
      if (ans.path == ContactPath::Walk) {
        EXPECT_FALSE(unique_feet) << what;
        ++c.beyond_plain;
        own_foot();
      }
      continue;
    }
    ++c.compared;
    EXPECT_EQ(ans.path, ContactPath::Walk) << what;
    if (ans.path != ContactPath::Walk) continue;
    if (!unique_feet && ans.surface.triangle != plain.triangle) {
      ++c.other_foot;
      own_foot();
      continue;
    }
    EXPECT_EQ(ans.surface.triangle, plain.triangle) << what;
    EXPECT_EQ(ans.surface.barycentric, plain.barycentric) << what;
    EXPECT_EQ(ans.surface.point, plain.point) << what;
    EXPECT_EQ(ans.surface.normal, plain.normal) << what;
    EXPECT_EQ(ans.surface.offset, plain.offset) << what;
    const Index guessed = k >= 0 ? m.triangle_neighbors[s][k] : kNoIndex;
    if (guessed == kNoIndex) continue;
    const auto& beyond = m.triangle_neighbors[guessed];
    if (plain.triangle == guessed) {
      ++c.right;
    } else if (plain.triangle != s && std::find(beyond.begin(), beyond.end(), plain.triangle) != beyond.end()) {
      // The foot left s past a corner into a neighbour of the guessed
      // triangle: the walk went on from the guessed triangle (or came back
      // to s and stepped there again); the bits are the same.
      ++c.beyond_guess;
    } else {
      ++c.wrong;  // the walk had to come back to s
    }
  }
  return c;
}

TEST(ContactWalk, AGuessedCrossingGivesTheAnswerOfTheWalkWithoutIt) {
  const double radius = 0.05;
  GuessCounts total;
  for (std::size_t n : {2000u, 20000u}) {
    const auto m = mesh::make_sphere(n, radius);
    std::mt19937 rng(77 + static_cast<unsigned>(n));
    const GuessCounts c = check_guessed_crossings(m, rng, 4000, true, "sphere n " + std::to_string(n));
    total.compared += c.compared;
    total.right += c.right;
    total.wrong += c.wrong;
    total.beyond_guess += c.beyond_guess;
  }
  std::printf("walk answers compared %zu; the guess right %zu, wrong %zu, the answer beyond it %zu\n",
              total.compared, total.right, total.wrong, total.beyond_guess);
  EXPECT_GE(total.compared, 4000u);
  EXPECT_GE(total.right, 500u);
  EXPECT_GE(total.wrong, 20u);
  EXPECT_GE(total.beyond_guess, 20u);
}

// The same on the shared organs, whose folds hold more than one foot under
// some probes: there the guess may answer where the walk from the start
// declines, or elsewhere, with a foot of its own triangle; it must never
// decline where that walk answers.
TEST(ContactWalk, AGuessedCrossingGivesTheAnswerOfTheWalkWithoutItOnOrgans) {
  PALPA_REQUIRE_SHARED_ORGANS();
  std::mt19937 rng(79);
  for (const SharedOrgan& o : kSharedOrgans) {
    const auto m = load_shared_organ(o);
    const GuessCounts c = check_guessed_crossings(m, rng, 20000, false, o.file);
    std::printf("%s: walk answers compared %zu; the guess right %zu, wrong %zu, the answer beyond it %zu; "
                "answers where the walk without the guess declines %zu, on another triangle %zu\n",
                o.file, c.compared, c.right, c.wrong, c.beyond_guess, c.beyond_plain, c.other_foot);
    EXPECT_GE(c.compared, 2000u) << o.file;
    EXPECT_GE(c.beyond_guess, 20u) << o.file;
  }
}

TEST(ContactWalk, QueryContactWalksOnlyInContactAndWithoutJumps) {
  const double radius = 0.05;
  const auto m = mesh::make_sphere(20000, radius);
  const VertexTree tree(m.positions);
  const Vec3 dir = Vec3(1, 2, 3).normalized();
  ContactCursor cursor;
  // First query: the tree, exact nearest vertex.
  ContactAnswer a = query_contact(m, tree, dir * (radius - 0.001), cursor, true);
  EXPECT_EQ(a.path, ContactPath::Tree);
  EXPECT_EQ(a.nearest_vertex, nearest_brute_force(m.positions, dir * (radius - 0.001)).vertex);
  EXPECT_EQ(cursor.triangle, a.surface.triangle);
  // In contact, a small move: the walk.
  const Vec3 moved = (dir + Vec3(0, 0.001, 0)).normalized() * (radius - 0.001);
  a = query_contact(m, tree, moved, cursor, true);
  EXPECT_EQ(a.path, ContactPath::Walk);
  EXPECT_LE((a.surface.point - full_query(m, moved).point).norm(), 1e-12);
  // Not in contact: the tree, even for a small move.
  a = query_contact(m, tree, moved, cursor, false);
  EXPECT_EQ(a.path, ContactPath::Tree);
  // In contact but jumped 1 cm (beyond the last triangle's longest edge): the tree.
  const Vec3 far = (dir + Vec3(0.2, 0, 0)).normalized() * (radius - 0.001);
  a = query_contact(m, tree, far, cursor, true);
  EXPECT_EQ(a.path, ContactPath::Tree);
  EXPECT_EQ(a.nearest_vertex, nearest_brute_force(m.positions, far).vertex);
  // A non-finite probe: no answer, cursor untouched.
  const ContactCursor before = cursor;
  a = query_contact(m, tree, Vec3(std::nan(""), 0, 0), cursor, true);
  EXPECT_EQ(a.path, ContactPath::None);
  EXPECT_EQ(a.surface.triangle, kNoIndex);
  EXPECT_EQ(cursor.triangle, before.triangle);
}

// ---------------------------------------------------------------------------
// The clearance of a tree answer above the surface (track_contact's path
// Clear) against the distance to the surface by brute force.

// The largest triangle_reach of the mesh's triangles, m.
double largest_triangle_reach(const mesh::SurfaceMesh& m) {
  double reach = 0;
  for (const auto& t : m.triangles)
    reach = std::max(reach, triangle_reach(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]));
  return reach;
}

// Distance (m) from q to the triangle abc: to its plane when the foot lies
// inside, else to the nearest of its edges.
double distance_to_triangle(const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  auto to_segment = [&](const Vec3& p0, const Vec3& p1) {
    const Vec3 e = p1 - p0;
    const double l2 = e.squaredNorm();
    const double t = l2 > 0 ? std::clamp((q - p0).dot(e) / l2, 0.0, 1.0) : 0.0;
    return (q - (p0 + t * e)).norm();
  };
  const Vec3 n = (b - a).cross(c - a);
  const double n2 = n.squaredNorm();
  if (n2 > 0) {
    const Vec3 foot = q - ((q - a).dot(n) / n2) * n;
    // Inside when the foot is on the inner side of all three edges.
    const bool inside = (b - a).cross(foot - a).dot(n) >= 0 && (c - b).cross(foot - b).dot(n) >= 0 &&
                        (a - c).cross(foot - c).dot(n) >= 0;
    if (inside) return (q - foot).norm();
  }
  return std::min({to_segment(a, b), to_segment(b, c), to_segment(c, a)});
}

double distance_to_surface(const mesh::SurfaceMesh& m, const Vec3& q) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : m.triangles)
    best = std::min(best, distance_to_triangle(q, m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]));
  return best;
}

// `count` probes 0 to 6 mm above random points of the surface (along the
// interpolated normal), each asked of track_contact afresh: where the tree's
// answer leaves a clearance, no point of the surface lies nearer. Returns
// how many answers left one.
int check_clearance(const mesh::SurfaceMesh& m, std::mt19937& rng, int count, const std::string& what) {
  const VertexTree tree(m);
  const double reach = largest_triangle_reach(m);
  std::uniform_int_distribution<Index> pick(0, static_cast<Index>(m.triangle_count() - 1));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int cleared = 0;
  for (int i = 0; i < count; ++i) {
    const auto& tri = m.triangles[pick(rng)];
    const double u = unit(rng), v = unit(rng) * (1 - u);
    const Vec3 b(1 - u - v, u, v);
    Vec3 point = Vec3::Zero(), normal = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      point += b[k] * m.positions[tri[k]];
      normal += b[k] * m.normals[tri[k]];
    }
    const Vec3 probe = point + 0.006 * unit(rng) * normal.normalized();
    ContactCursor cursor;
    const ContactAnswer a = track_contact(m, tree, probe, cursor, false);
    EXPECT_EQ(a.path, ContactPath::Tree) << what;
    if (cursor.clearance <= 0) continue;
    ++cleared;
    EXPECT_GT(a.surface.offset, 0.0) << what;  // only above the surface
    EXPECT_EQ(cursor.clear_from, probe) << what;
    const double d = distance_to_surface(m, probe);
    EXPECT_LE(cursor.clearance, d) << what << ": probe " << probe.transpose() << " is " << d
                                   << " m from the surface, its clearance " << cursor.clearance << " m";
    // And not far below it: every vertex is at least d away, and no reach is
    // larger than the largest triangle's.
    EXPECT_GE(cursor.clearance, std::min(d, kMaxClearance) - reach - 1e-9) << what;
  }
  return cleared;
}

TEST(TrackContact, TheClearanceAboveTheSurfaceIsNoMoreThanTheDistanceToItOnMeshesOfOurOwn) {
  std::mt19937 rng(5);
  EXPECT_GT(check_clearance(mesh::make_sphere(5000, 0.05), rng, 300, "sphere"), 150);
  EXPECT_GT(check_clearance(mesh::make_organ(5000), rng, 300, "organ"), 150);
  // A bumpy grid with tilted normals, open at its borders.
  EXPECT_GT(check_clearance(tilted_grid(rng, 0.6), rng, 300, "tilted grid"), 50);
}

TEST(TrackContact, TheClearanceAboveTheSurfaceIsNoMoreThanTheDistanceToItOnOrgans) {
  PALPA_REQUIRE_SHARED_ORGANS();
  for (const SharedOrgan& o : kSharedOrgans) {
    std::mt19937 rng(6);
    const auto m = load_shared_organ(o);
    const int cleared = check_clearance(m, rng, 100, o.file);
    std::printf("%s: %d of 100 probes up to 6 mm above with a clearance\n", o.file, cleared);
    // Their triangles' reaches are 1 to 8 mm: about half the probes lie beyond.
    EXPECT_GT(cleared, 30) << o.file;
  }
}

TEST(TrackContact, OutOfContactInsideTheClearanceTheLastAnswerHoldsWithoutASearch) {
  const double radius = 0.05;
  const auto m = mesh::make_sphere(20000, radius);
  const VertexTree tree(m);
  const double reach = largest_triangle_reach(m);
  const Vec3 dir = Vec3(1, 2, 3).normalized();
  ContactCursor cursor;
  const Vec3 above = dir * (radius + 0.004);
  const ContactAnswer first = track_contact(m, tree, above, cursor, false);
  ASSERT_EQ(first.path, ContactPath::Tree);
  const double clearance = cursor.clearance;
  // 4 mm above less the reach (and the sagitta, under 0.1 mm here).
  ASSERT_GT(clearance, 0.004 - reach - 1e-4);
  ASSERT_LT(clearance, 0.004);
  // A move just inside the ball: the same answer, offset measured again.
  const Vec3 side = dir.cross(Vec3::UnitZ()).normalized();
  const Vec3 inside = above + 0.999 * clearance * side;
  ContactAnswer a = track_contact(m, tree, inside, cursor, false);
  EXPECT_EQ(a.path, ContactPath::Clear);
  EXPECT_EQ(a.nearest_vertex, first.nearest_vertex);
  EXPECT_EQ(a.surface.triangle, first.surface.triangle);
  EXPECT_EQ(a.surface.point, first.surface.point);
  EXPECT_DOUBLE_EQ(a.surface.offset, (inside - first.surface.point).dot(first.surface.normal));
  EXPECT_EQ(cursor.clear_from, above);  // the ball does not move with it
  // Straight down by as much: also inside, and still above the surface.
  a = track_contact(m, tree, above - 0.999 * clearance * dir, cursor, false);
  EXPECT_EQ(a.path, ContactPath::Clear);
  EXPECT_GT(a.surface.offset, 0.0);
  // Just outside the ball: the tree again, exact, and a new ball there.
  const Vec3 outside = above + 1.001 * clearance * side;
  a = track_contact(m, tree, outside, cursor, false);
  EXPECT_EQ(a.path, ContactPath::Tree);
  EXPECT_EQ(a.nearest_vertex, nearest_brute_force(m.positions, outside).vertex);
  EXPECT_EQ(cursor.clear_from, outside);
  // In contact the clearance is not used (the contact is tracked).
  a = track_contact(m, tree, outside, cursor, true);
  EXPECT_NE(a.path, ContactPath::Clear);
  // query_contact, the exact query, never skips.
  EXPECT_EQ(query_contact(m, tree, outside, cursor, false).path, ContactPath::Tree);
  // Below the surface no clearance is left: a probe 1 mm in, then 0.01 mm on.
  ContactCursor below;
  track_contact(m, tree, dir * (radius - 0.001), below, false);
  EXPECT_EQ(below.clearance, 0.0);
  EXPECT_EQ(track_contact(m, tree, dir * (radius - 0.00101), below, false).path, ContactPath::Tree);
  // A tree built from the positions alone knows no surface: none.
  const VertexTree positions_only(m.positions);
  ContactCursor never;
  track_contact(m, positions_only, above, never, false);
  EXPECT_EQ(never.clearance, 0.0);
  EXPECT_EQ(track_contact(m, positions_only, above, never, false).path, ContactPath::Tree);
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

TEST(HeightCheck, AnExistingContactHoldsWhileBelowTheRestSurface) {
  // The surface overshot past the probe (h = -3 mm, probe at -2 mm): a new
  // contact is refused, an existing one holds.
  EXPECT_FALSE(height_check(at(-0.002), Vec3::Constant(-0.003), false).in_contact);
  const HeightCheck held = height_check(at(-0.002), Vec3::Constant(-0.003), true);
  EXPECT_TRUE(held.in_contact);
  EXPECT_DOUBLE_EQ(held.depth, 0.002);
  EXPECT_DOUBLE_EQ(held.surface_height, -0.003);
  // It still ends once the probe is at or above the undeformed surface.
  EXPECT_FALSE(height_check(at(0.0), Vec3::Constant(-0.003), true).in_contact);
  EXPECT_FALSE(height_check(at(0.0005), Vec3::Zero(), true).in_contact);
  // Below the deformed surface it is a contact either way.
  EXPECT_TRUE(height_check(at(-0.002), Vec3::Constant(-0.001), true).in_contact);
  EXPECT_TRUE(height_check(at(-0.002), Vec3::Constant(-0.001), false).in_contact);
}

}  // namespace
}  // namespace palpa::collision

namespace palpa::collision {
namespace {

// A flat grid (normals +z) whose triangles touching the disk of `radius`
// around the centre vertex are replaced by a fan of thin triangles meeting
// there (one per boundary edge of the hole: its valence).
mesh::SurfaceMesh fan_plane(int n, double spacing, double radius, Index& centre) {
  const mesh::SurfaceMesh g = mesh::make_plane(n, n, spacing);
  centre = nearest_brute_force(g.positions, Vec3::Zero()).vertex;
  std::vector<char> in(g.vertex_count(), 0);
  for (Index v = 0; v < g.vertex_count(); ++v) in[v] = (g.positions[v] - g.positions[centre]).norm() < radius;
  mesh::SurfaceMesh out;
  out.positions = g.positions;
  std::vector<std::array<Index, 2>> removed;
  for (const auto& t : g.triangles) {
    if (!in[t[0]] && !in[t[1]] && !in[t[2]]) {
      out.triangles.push_back(t);
      continue;
    }
    for (int k = 0; k < 3; ++k) removed.push_back({t[k], t[(k + 1) % 3]});
  }
  for (const auto& e : removed) {
    bool inner = false;
    for (const auto& o : removed) inner = inner || (o[0] == e[1] && o[1] == e[0]);
    if (!inner) out.triangles.push_back({e[0], e[1], centre});
  }
  // Drop the vertices the fan left unused.
  std::vector<Index> remap(out.positions.size(), kNoIndex);
  std::vector<Vec3> kept;
  for (auto& t : out.triangles)
    for (Index& v : t) {
      if (remap[v] == kNoIndex) {
        remap[v] = static_cast<Index>(kept.size());
        kept.push_back(out.positions[v]);
      }
      v = remap[v];
    }
  centre = remap[centre];
  out.positions = kept;
  mesh::finalize(out);
  return out;
}

// The probe 1 mm below the plane z = 0 at distance rho (m) and angle (rad)
// round vertex c.
Vec3 round_vertex(const mesh::SurfaceMesh& m, Index c, double rho, double angle) {
  return m.positions[c] + Vec3(rho * std::cos(angle), rho * std::sin(angle), -0.001);
}

// One tick of a probe sliding round a vertex: the walk from last's triangle
// to the probe must answer, with brute force's point and offset
// (full_query). Returns the walk's answer; its triangle is kNoIndex when the
// walk declined, which has failed the test.
SurfacePoint walk_like_brute_force(const mesh::SurfaceMesh& m, const Vec3& probe, const SurfacePoint& last,
                                   const std::string& where) {
  const SurfacePoint got = walk_surface_point(m, probe, last.triangle);
  if (got.triangle == kNoIndex) {
    ADD_FAILURE() << "the walk declined: " << where;
    return got;
  }
  const SurfacePoint want = full_query(m, probe);
  EXPECT_LE((got.point - want.point).norm(), 1e-12) << where;
  EXPECT_NEAR(got.offset, want.offset, 1e-12) << where;
  return got;
}

TEST(ContactWalk, GoesAroundAHighValenceVertexWithTheAnswerOfBruteForce) {
  Index centre = kNoIndex;
  const mesh::SurfaceMesh m = fan_plane(81, 0.001, 0.02, centre);
  const std::size_t valence = m.vertex_triangles.row(centre).size();
  ASSERT_GT(valence, 100u);
  // Probes 1 mm below the plane sliding around the centre at several radii:
  // each tick's walk starts from the last answer's triangle and crosses many
  // thin fan triangles; it must answer, with brute force's triangle and point.
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(0, 1);
  std::size_t walked = 0, queries = 0;
  for (int path = 0; path < 20; ++path) {
    const double rho = 0.0005 + 0.012 * u(rng);
    double angle = 2 * std::numbers::pi * u(rng);
    const double turn = (u(rng) < 0.5 ? -1 : 1) * (0.02 + 0.25 * u(rng));  // rad per tick: up to ~25 fan triangles
    SurfacePoint last = full_query(m, round_vertex(m, centre, rho, angle));
    ASSERT_TRUE(last.inside);
    for (int tick = 0; tick < 30; ++tick) {
      angle += turn;
      ++queries;
      last = walk_like_brute_force(m, round_vertex(m, centre, rho, angle), last,
                                   "path " + std::to_string(path) + " tick " + std::to_string(tick) + " radius " +
                                       std::to_string(rho));
      ASSERT_NE(last.triangle, kNoIndex);
      ++walked;
    }
  }
  EXPECT_EQ(walked, queries);
}

// A flat grid (normals +z) whose every triangle is split in three at a point
// 2% of the way from its first edge's midpoint to the opposite corner: a
// sliver along that edge and two wide triangles. The grid's interior
// vertices meet 12 triangles (two from each of their six), the new ones 3.
mesh::SurfaceMesh sliver_plane(int n, double spacing) {
  const mesh::SurfaceMesh g = mesh::make_plane(n, n, spacing);
  mesh::SurfaceMesh out;
  out.positions = g.positions;
  for (const auto& t : g.triangles) {
    const Vec3 mid = 0.5 * (g.positions[t[0]] + g.positions[t[1]]);
    const auto p = static_cast<Index>(out.positions.size());
    out.positions.push_back(mid + 0.02 * (g.positions[t[2]] - mid));
    out.triangles.push_back({t[0], t[1], p});
    out.triangles.push_back({t[1], t[2], p});
    out.triangles.push_back({t[2], t[0], p});
  }
  mesh::finalize(out);
  return out;
}

TEST(ContactWalk, GoesAroundAVertexOfSliversWithTheAnswerOfBruteForce) {
  // Around a vertex where 12 triangles meet, half of them slivers, a probe
  // that swings up to 170 degrees around it in one tick crosses up to six
  // triangles turning about that vertex: the walk must answer (it gave up
  // after kMaxWalkSteps of them before such turns had their own budget,
  // and the tick fell back to the proxy or the tree), with brute force's
  // point.
  const mesh::SurfaceMesh m = sliver_plane(21, 0.001);
  const Index centre = nearest_brute_force(m.positions, Vec3::Zero()).vertex;
  ASSERT_EQ(m.vertex_triangles.row(centre).size(), 12u);
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(0, 1);
  std::size_t queries = 0, wide_turns = 0;
  for (int path = 0; path < 40; ++path) {
    const double rho = 0.0001 + 0.0004 * u(rng);
    double angle = 2 * std::numbers::pi * u(rng);
    const double sign = u(rng) < 0.5 ? -1 : 1;
    SurfacePoint last = full_query(m, round_vertex(m, centre, rho, angle));
    ASSERT_TRUE(last.inside);
    for (int tick = 0; tick < 20; ++tick) {
      const double turn = sign * (0.3 + 2.67 * u(rng));  // rad: up to about 170 degrees
      wide_turns += std::abs(turn) > 2.5;
      angle += turn;
      ++queries;
      last = walk_like_brute_force(m, round_vertex(m, centre, rho, angle), last,
                                   "path " + std::to_string(path) + " tick " + std::to_string(tick) + " radius " +
                                       std::to_string(rho) + " turn " + std::to_string(turn));
      ASSERT_NE(last.triangle, kNoIndex);
    }
  }
  EXPECT_EQ(queries, 800u);
  EXPECT_GT(wide_turns, 50u);
}

TEST(ContactWalk, LocateAroundAHighValenceVertexFindsTheTriangleUnderTheProbe) {
  Index centre = kNoIndex;
  const mesh::SurfaceMesh m = fan_plane(81, 0.001, 0.02, centre);
  ASSERT_GT(m.vertex_triangles.row(centre).size(), 100u);
  // Every fan triangle's centroid, 1 mm below: located from the centre
  // vertex, the answer is that triangle (brute force over all triangles).
  for (Index t : m.vertex_triangles.row(centre)) {
    Vec3 c = Vec3::Zero();
    for (Index v : m.triangles[t]) c += m.positions[v] / 3;
    const SurfacePoint got = locate_surface_point(m, c - Vec3(0, 0, 0.001), centre);
    ASSERT_TRUE(got.inside) << "triangle " << t;
    EXPECT_EQ(got.triangle, t);
    EXPECT_LE((got.point - c).norm(), 1e-12);
  }
}

}  // namespace
}  // namespace palpa::collision
