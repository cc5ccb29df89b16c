// The vertex tree against brute force: full and local queries must find a
// vertex at exactly the brute-force distance, on generated spheres and on
// every shared organ.

#include "collision/vertex_tree.h"
#include "common/test_support.h"
#include "mesh/generate.h"
#include "mesh/io.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace palpa::collision {
namespace {

// Squared distance written out the same way for every candidate, so the
// minimum is a well-defined number to compare against.
double d2(const Vec3& a, const Vec3& b) {
  const double dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

// The test's own reference: minimum squared distance over all vertices.
double reference_min(const std::vector<Vec3>& pts, const Vec3& q) {
  double best = std::numeric_limits<double>::infinity();
  for (const Vec3& p : pts) best = std::min(best, d2(p, q));
  return best;
}

// Checks one answer: a real vertex, its distance reported correctly, and
// that distance the minimum.
void expect_nearest(const std::vector<Vec3>& pts, const Vec3& q, const NearestVertex& got, const std::string& what) {
  ASSERT_LT(got.vertex, pts.size()) << what;
  const double ref = reference_min(pts, q);
  EXPECT_EQ(d2(pts[got.vertex], q), ref) << what << " query " << q.transpose();
  EXPECT_EQ(got.distance_sq, ref) << what << " query " << q.transpose();
}

Vec3 random_direction(std::mt19937& rng) {
  std::normal_distribution<double> g;
  Vec3 v;
  do v = Vec3(g(rng), g(rng), g(rng));
  while (v.norm() < 1e-6);
  return v.normalized();
}

// Random queries of three kinds around a mesh of size `scale` centred at c:
// near the surface (close to a vertex), far away, and inside the bounding box.
std::vector<Vec3> random_queries(const std::vector<Vec3>& pts, int count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  Vec3 lo = pts[0], hi = pts[0];
  for (const Vec3& p : pts) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec3 c = (lo + hi) / 2;
  const double scale = (hi - lo).norm();
  std::uniform_real_distribution<double> u(0, 1);
  std::uniform_int_distribution<std::size_t> pick(0, pts.size() - 1);
  std::vector<Vec3> out;
  for (int i = 0; i < count; ++i) {
    switch (i % 3) {
      case 0:  // near the surface: a vertex plus up to 1% of the size
        out.push_back(pts[pick(rng)] + random_direction(rng) * scale * 0.01 * u(rng));
        break;
      case 1:  // far away: 2 to 20 sizes from the centre
        out.push_back(c + random_direction(rng) * scale * (2 + 18 * u(rng)));
        break;
      default:  // anywhere in the bounding box (inside the organ mostly)
        out.push_back(lo + (hi - lo).cwiseProduct(Vec3(u(rng), u(rng), u(rng))));
    }
  }
  return out;
}

// Full and local queries (cursor carried across unrelated queries: jumps).
void check_random_queries(const std::vector<Vec3>& pts, int count, const std::string& what) {
  const VertexTree tree(pts);
  ASSERT_TRUE(tree.check_invariants()) << what;
  ASSERT_EQ(tree.vertex_count(), pts.size());
  SearchCursor cursor;
  int n = 0;
  for (const Vec3& q : random_queries(pts, count, 1234)) {
    expect_nearest(pts, q, tree.nearest(q), what + " full #" + std::to_string(n));
    expect_nearest(pts, q, tree.nearest_local(q, cursor), what + " local #" + std::to_string(n));
    ++n;
    if (::testing::Test::HasFailure()) return;
  }
}

// A probe sliding over the surface: small steps around a great circle of a
// sphere at a few offsets, with one jump to the far side half way.
void check_sliding(const std::vector<Vec3>& pts, double radius, const std::string& what) {
  const VertexTree tree(pts);
  for (double offset : {0.0, -0.003 * radius / 0.05, 0.002 * radius / 0.05}) {
    SearchCursor cursor;
    const Vec3 a = Vec3(1, 0.2, -0.3).normalized();
    const Vec3 b = a.cross(Vec3(0, 0, 1)).normalized();
    const int steps = 1500;
    for (int i = 0; i < steps; ++i) {
      // Step of 0.1 mm (at R = 5 cm); at i == steps/2 jump by pi.
      double th = i * 2e-3;
      if (i >= steps / 2) th += std::numbers::pi;
      const Vec3 q = (radius + offset) * (std::cos(th) * a + std::sin(th) * b);
      const NearestVertex local = tree.nearest_local(q, cursor);
      const NearestVertex full = tree.nearest(q);
      ASSERT_EQ(local.distance_sq, full.distance_sq) << what << " step " << i;
      if (i % 50 == 0) expect_nearest(pts, q, local, what + " sliding step " + std::to_string(i));
    }
  }
}

TEST(VertexTree, EmptyTreeFindsNothing) {
  const std::vector<Vec3> none;
  const VertexTree tree(none);
  EXPECT_TRUE(tree.check_invariants());
  EXPECT_EQ(tree.nearest(Vec3::Zero()).vertex, kNoIndex);
  SearchCursor cursor;
  EXPECT_EQ(tree.nearest_local(Vec3::Zero(), cursor).vertex, kNoIndex);
  EXPECT_EQ(nearest_brute_force(none, Vec3::Zero()).vertex, kNoIndex);
}

TEST(VertexTree, HandPlacedPoints) {
  // Unit cube corners: the query (0.9, 0.1, 0.2) is nearest (1, 0, 0), index 1,
  // at squared distance 0.01 + 0.01 + 0.04.
  const std::vector<Vec3> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0},
                                 {0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};
  const VertexTree tree(pts, 1);
  EXPECT_TRUE(tree.check_invariants());
  EXPECT_EQ(tree.depth(), 3);  // 8 points, one per leaf: a complete binary tree
  const Vec3 q(0.9, 0.1, 0.2);
  const NearestVertex nv = tree.nearest(q);
  EXPECT_EQ(nv.vertex, 1u);
  EXPECT_DOUBLE_EQ(nv.distance_sq, 0.06);
  SearchCursor cursor;
  EXPECT_EQ(tree.nearest_local(q, cursor).vertex, 1u);
  // From there, moving to (0.1, 0.95, 0.9) needs a climb to the root.
  EXPECT_EQ(tree.nearest_local(Vec3(0.1, 0.95, 0.9), cursor).vertex, 6u);
  EXPECT_EQ(nearest_brute_force(pts, q).vertex, 1u);
}

TEST(VertexTree, DegenerateInputs) {
  // All points equal, or all on a line: still a valid tree and exact answers.
  std::vector<Vec3> same(100, Vec3(0.1, 0.2, 0.3));
  std::vector<Vec3> line;
  for (int i = 0; i < 1000; ++i) line.emplace_back(1e-3 * i, 0, 0);
  for (const auto* pts : {&same, &line}) {
    const VertexTree tree(*pts, 4);
    EXPECT_TRUE(tree.check_invariants());
    SearchCursor cursor;
    for (const Vec3& q : random_queries(*pts, 60, 7)) {
      expect_nearest(*pts, q, tree.nearest(q), "degenerate full");
      expect_nearest(*pts, q, tree.nearest_local(q, cursor), "degenerate local");
    }
  }
}

TEST(VertexTree, NonFinitePositionsAreNeverReturned) {
  // Bad input points (NaN, infinite) must not break the build or the answers
  // for the finite ones.
  auto pts = mesh::make_sphere(2000, 0.05).positions;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 0; i < pts.size(); i += 97) pts[i].x() = nan;
  pts[5].y() = std::numeric_limits<double>::infinity();
  const VertexTree tree(pts);
  SearchCursor cursor;
  for (const Vec3& q : {Vec3(0.01, 0.02, 0.045), Vec3(-0.05, 0, 0), Vec3(0, 0, 0), Vec3(1, 1, 1)}) {
    const NearestVertex nv = tree.nearest(q);
    ASSERT_LT(nv.vertex, pts.size());
    EXPECT_TRUE(pts[nv.vertex].allFinite());
    EXPECT_EQ(nv.distance_sq, reference_min(pts, q));
    EXPECT_EQ(tree.nearest_local(q, cursor).distance_sq, reference_min(pts, q));
  }
}

TEST(VertexTree, BadCursorFallsBackToFullSearch) {
  const auto sphere = mesh::make_sphere(2000, 0.05);
  const VertexTree tree(sphere.positions);
  const Vec3 q(0.01, 0.02, 0.045);
  for (Index leaf : {Index{0}, Index{1}, static_cast<Index>(tree.node_count()), kNoIndex}) {
    SearchCursor cursor{leaf};  // the root, an inner node, past the end, none
    expect_nearest(sphere.positions, q, tree.nearest_local(q, cursor), "cursor " + std::to_string(leaf));
    EXPECT_LT(cursor.leaf, tree.node_count());
  }
}

TEST(VertexTree, NonFiniteQueryFindsNothing) {
  const auto sphere = mesh::make_sphere(500, 0.05);
  const VertexTree tree(sphere.positions);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  SearchCursor cursor;
  EXPECT_EQ(tree.nearest(Vec3(nan, 0, 0)).vertex, kNoIndex);
  EXPECT_EQ(tree.nearest_local(Vec3(0, nan, 0), cursor).vertex, kNoIndex);
  EXPECT_EQ(cursor.leaf, kNoIndex);
}

TEST(VertexTree, LeafSizesKeepInvariants) {
  const auto sphere = mesh::make_sphere(3000, 0.05);
  for (int leaf : {1, 2, 3, 8, 32, 10000}) {
    const VertexTree tree(sphere.positions, leaf);
    EXPECT_TRUE(tree.check_invariants()) << "leaf size " << leaf;
    const Vec3 q(0.03, -0.02, 0.01);
    EXPECT_EQ(tree.nearest(q).distance_sq, reference_min(sphere.positions, q)) << "leaf size " << leaf;
  }
}

TEST(VertexTree, SphereTenThousandMatchesBruteForce) {
  const auto sphere = mesh::make_sphere(10000, 0.05);
  check_random_queries(sphere.positions, 3000, "sphere 10k");
  check_sliding(sphere.positions, 0.05, "sphere 10k");
}

TEST(VertexTree, SphereHundredThousandMatchesBruteForce) {
  const auto sphere = mesh::make_sphere(100000, 0.08, Vec3(0.3, -0.1, 1.2));
  const VertexTree tree(sphere.positions);
  EXPECT_TRUE(tree.check_invariants());
  // Median splits: depth about log2(n / leaf size).
  EXPECT_LE(tree.depth(), static_cast<int>(std::ceil(std::log2(sphere.vertex_count() / 4.0))));
  check_random_queries(sphere.positions, 1500, "sphere 100k");
  // Sliding around the off-centre sphere: shift the points to the origin.
  std::vector<Vec3> centred = sphere.positions;
  for (Vec3& p : centred) p -= Vec3(0.3, -0.1, 1.2);
  check_sliding(centred, 0.08, "sphere 100k");
}

TEST(VertexTree, EverySharedOrganMatchesBruteForce) {
  PALPA_REQUIRE_SHARED_ORGANS();
  int loaded = 0;
  for (const auto& entry : std::filesystem::directory_iterator(test::shared_organs_dir())) {
    const std::string ext = entry.path().extension().string();
    if (ext != ".obj" && ext != ".vtk" && ext != ".off" && ext != ".ply" && ext != ".stl" && ext != ".vtp")
      continue;
    const mesh::SurfaceMesh organ = mesh::load_mesh(entry.path());
    ASSERT_GT(organ.vertex_count(), 100u) << entry.path();
    check_random_queries(organ.positions, 900, entry.path().filename().string());
    // Sliding from vertex to vertex along a chain of neighbours (surface path),
    // slightly above and below the surface.
    const VertexTree tree(organ.positions);
    SearchCursor cursor;
    Index v = 0;
    for (int i = 0; i < 400; ++i) {
      const auto ring = organ.vertex_neighbors.row(v);
      const Index w = ring[static_cast<std::size_t>(i * 7) % ring.size()];
      for (double s : {0.0, 0.25, 0.5, 0.75}) {
        const Vec3 q = (1 - s) * organ.positions[v] + s * organ.positions[w] +
                       0.3 * (organ.positions[w] - organ.positions[v]).norm() * ((i % 2) ? 1.0 : -1.0) *
                           organ.normals[v];
        expect_nearest(organ.positions, q, tree.nearest_local(q, cursor), entry.path().filename().string());
      }
      v = w;
    }
    ++loaded;
  }
  EXPECT_GE(loaded, 5);
}

// ---------------------------------------------------------------------------
// triangle_reach: the farthest a point of a triangle lies from its nearest
// corner. Closed forms, then dense sampling. clearance: against brute force.

TEST(TriangleReach, ClosedForms) {
  constexpr double kTol = 1e-12;
  // Equilateral, side 2: the circumradius 2 / sqrt(3).
  EXPECT_NEAR(triangle_reach(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(1, std::sqrt(3.0), 0)), 2 / std::sqrt(3.0), kTol);
  // Right, legs 3 and 4: half the hypotenuse (the circumcentre is its midpoint).
  EXPECT_NEAR(triangle_reach(Vec3(0, 0, 0), Vec3(3, 0, 0), Vec3(0, 4, 0)), 2.5, kTol);
  // Obtuse at (1, 0.5): the circumcentre (2, -2.75) lies outside. The
  // perpendicular bisector of the edge from (1, 0.5) to (4, 0) meets the
  // long edge 37/24 from (4, 0), and as far from (1, 0.5); the other
  // bisector meets it 5/8 from (0, 0).
  for (int turn = 0; turn < 3; ++turn) {  // each corner order
    Vec3 c[3] = {Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(1, 0.5, 0)};
    std::rotate(c, c + turn, c + 3);
    EXPECT_NEAR(triangle_reach(c[0], c[1], c[2]), 37.0 / 24, kTol) << "turn " << turn;
  }
  // Degenerate: three points on a line, half the longer piece; two corners
  // at one point, half the edge; all three at one point, 0.
  EXPECT_NEAR(triangle_reach(Vec3(0, 0, 0), Vec3(6, 0, 0), Vec3(2, 0, 0)), 2.0, kTol);
  EXPECT_NEAR(triangle_reach(Vec3(0, 0, 0), Vec3(6, 0, 0), Vec3(0, 0, 0)), 3.0, kTol);
  EXPECT_EQ(triangle_reach(Vec3(1, 1, 1), Vec3(1, 1, 1), Vec3(1, 1, 1)), 0.0);
  EXPECT_TRUE(std::isnan(triangle_reach(Vec3(0, 0, 0), Vec3(std::nan(""), 0, 0), Vec3(0, 1, 0))));
}

TEST(TriangleReach, NoSampledPointLiesFartherAndTheFarthestComesClose) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr int n = 80;  // grid steps a side
  for (int k = 0; k < 300; ++k) {
    // Random triangles, a third of them slivers.
    Vec3 c[3] = {Vec3(u(rng), u(rng), u(rng)), Vec3(u(rng), u(rng), u(rng)), Vec3(u(rng), u(rng), u(rng))};
    if (k % 3 == 0) c[2] = 0.5 * (c[0] + c[1]) + 0.02 * Vec3(u(rng), u(rng), u(rng));
    const double reach = triangle_reach(c[0], c[1], c[2]);
    double far = 0;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const double a = double(i) / n, b = double(j) / n;
        const Vec3 x = (1 - a - b) * c[0] + a * c[1] + b * c[2];
        far = std::max(far, std::min({(x - c[0]).norm(), (x - c[1]).norm(), (x - c[2]).norm()}));
      }
    EXPECT_LE(far, reach * (1 + 1e-12)) << "triangle " << k;
    EXPECT_GE(far, 0.97 * reach) << "triangle " << k;
  }
}

// min(cap, least over the vertices of distance less reach), each vertex's
// reach the largest of its triangles'.
double brute_clearance(const mesh::SurfaceMesh& m, const Vec3& q, double cap) {
  std::vector<double> reach(m.vertex_count(), 0.0);
  for (const auto& t : m.triangles) {
    const double r = triangle_reach(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]);
    for (Index v : t) reach[v] = std::max(reach[v], r);
  }
  double best = cap;
  for (std::size_t v = 0; v < m.vertex_count(); ++v) best = std::min(best, (q - m.positions[v]).norm() - reach[v]);
  return std::max(best, 0.0);
}

TEST(VertexTree, ClearanceIsTheBruteForceBoundCapped) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.12, 0.12);
  for (const mesh::SurfaceMesh& m : {mesh::make_sphere(3000, 0.05), mesh::make_organ(3000)}) {
    const VertexTree tree(m);
    for (int i = 0; i < 300; ++i) {
      const Vec3 q(u(rng), u(rng), u(rng));
      for (double cap : {0.002, 0.01, 1.0}) {
        const double want = brute_clearance(m, q, cap);
        const double got = tree.clearance(q, cap);
        // The reaches are kept as floats rounded up (within 6e-8 of
        // themselves, up to 15 mm here): a little lower, never higher.
        EXPECT_LE(got, want + 1e-15) << "query " << q.transpose() << ", cap " << cap;
        EXPECT_GE(got, want - 1e-8) << "query " << q.transpose() << ", cap " << cap << ", short by " << want - got;
      }
    }
  }
}

TEST(VertexTree, ClearanceBoundsNothingWithoutASurface) {
  const auto m = mesh::make_sphere(500, 0.05);
  const Vec3 far(1, 0, 0);
  EXPECT_GT(VertexTree(m).clearance(far, 1.0), 0.9);
  // Positions alone, a non-finite query, a cap of 0, a non-finite position.
  EXPECT_EQ(VertexTree(std::span<const Vec3>(m.positions)).clearance(far, 1.0), 0.0);
  EXPECT_EQ(VertexTree(m).clearance(Vec3(std::nan(""), 0, 0), 1.0), 0.0);
  EXPECT_EQ(VertexTree(m).clearance(far, 0.0), 0.0);
  auto bad = m;
  bad.positions[7].y() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(VertexTree(bad).clearance(far, 1.0), 0.0);
  // A triangle naming a vertex that does not exist: no bound either.
  auto broken = m;
  broken.triangles[0][1] = static_cast<Index>(m.vertex_count());
  EXPECT_EQ(VertexTree(broken).clearance(far, 1.0), 0.0);
  // A vertex used by no triangle counts with reach 0: it bounds the query
  // next to it.
  auto stray = m;
  stray.positions.push_back(Vec3(0.2, 0, 0));
  EXPECT_NEAR(VertexTree(stray).clearance(Vec3(0.201, 0, 0), 1.0), 0.001, 1e-12);
}

}  // namespace
}  // namespace palpa::collision
