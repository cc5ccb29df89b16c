// Normals, adjacency and analyse() on hand-built meshes with known answers.

#include "common/test_support.h"
#include "mesh/generate.h"
#include "mesh/surface_mesh.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <set>

namespace palpa::mesh {
namespace {

using test::kRoundoff;

// The corner tetrahedron (0,0,0), (1,0,0), (0,1,0), (0,0,1), outward.
SurfaceMesh corner_tetrahedron() {
  SurfaceMesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  finalize(m);
  return m;
}

// A torus of n x m quads (R = 2, r = 1), outward.
SurfaceMesh torus(int n, int m) {
  SurfaceMesh t;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      const double u = 2 * M_PI * i / n, v = 2 * M_PI * j / m;
      t.positions.emplace_back((2 + std::cos(v)) * std::cos(u), (2 + std::cos(v)) * std::sin(u), std::sin(v));
    }
  auto id = [&](int i, int j) { return Index(((i + n) % n) * m + (j + m) % m); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      t.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      t.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  finalize(t);
  return t;
}

// Area weighting: at the right-angle corner the three unit faces (area 1/2
// each) give (-1,-1,-1)/sqrt(3); at (1,0,0) the two axis faces and the slanted
// face (area sqrt(3)/2, normal (1,1,1)/sqrt(3)) sum to (1,0,0).
TEST(Normals, AreaWeightedOnCornerTetrahedron) {
  const SurfaceMesh m = corner_tetrahedron();
  const Vec3 expected[4] = {Vec3(-1, -1, -1).normalized(), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  for (int v = 0; v < 4; ++v) EXPECT_LT((m.normals[v] - expected[v]).norm(), kRoundoff) << "vertex " << v;
}

TEST(Normals, VertexWithoutTrianglesGetsPlusZ) {
  SurfaceMesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(5, 5, 5)};
  m.triangles = {{0, 1, 2}};
  compute_normals(m);
  EXPECT_EQ(m.normals[3], Vec3(0, 0, 1));
  EXPECT_EQ(m.normals[0], Vec3(0, 0, 1));  // the triangle faces +z too
}

TEST(Adjacency, CornerTetrahedron) {
  const SurfaceMesh m = corner_tetrahedron();
  ASSERT_EQ(m.vertex_neighbors.rows(), 4u);
  for (Index v = 0; v < 4; ++v) {
    std::vector<Index> others;
    for (Index u = 0; u < 4; ++u)
      if (u != v) others.push_back(u);
    const auto row = m.vertex_neighbors.row(v);
    EXPECT_EQ(std::vector<Index>(row.begin(), row.end()), others);
  }
  const auto t0 = m.vertex_triangles.row(0);
  EXPECT_EQ(std::vector<Index>(t0.begin(), t0.end()), (std::vector<Index>{0, 1, 2}));
  const auto t3 = m.vertex_triangles.row(3);
  EXPECT_EQ(std::vector<Index>(t3.begin(), t3.end()), (std::vector<Index>{1, 2, 3}));
}

// Against a brute-force set construction on a larger mesh.
TEST(Adjacency, MatchesBruteForceOnSphere) {
  const SurfaceMesh m = make_sphere(600, 1.0);
  std::vector<std::set<Index>> nb(m.vertex_count()), tris(m.vertex_count());
  for (Index t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      tris[m.triangles[t][k]].insert(t);
      for (int j = 0; j < 3; ++j)
        if (j != k) nb[m.triangles[t][k]].insert(m.triangles[t][j]);
    }
  for (Index v = 0; v < m.vertex_count(); ++v) {
    const auto r = m.vertex_neighbors.row(v);
    const auto t = m.vertex_triangles.row(v);
    EXPECT_EQ(std::vector<Index>(r.begin(), r.end()), std::vector<Index>(nb[v].begin(), nb[v].end()));
    EXPECT_EQ(std::vector<Index>(t.begin(), t.end()), std::vector<Index>(tris[v].begin(), tris[v].end()));
  }
  // Triangle neighbours: across each edge, the other triangle holding both ends.
  ASSERT_EQ(m.triangle_neighbors.size(), m.triangle_count());
  for (Index t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Index a = m.triangles[t][(k + 1) % 3], b = m.triangles[t][(k + 2) % 3];
      std::vector<Index> across;
      for (Index s = 0; s < m.triangle_count(); ++s)
        if (s != t && tris[a].count(s) && tris[b].count(s)) across.push_back(s);
      ASSERT_EQ(across.size(), 1u);  // closed manifold
      EXPECT_EQ(m.triangle_neighbors[t][k], across[0]);
    }
}

TEST(Adjacency, TriangleNeighborsOnBordersAndNonManifoldEdges) {
  // Three triangles on the edge (0, 1) (non-manifold) and a border elsewhere.
  SurfaceMesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1), Vec3(1, 1, 0)};
  m.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}, {1, 5, 2}};
  build_adjacency(m);
  ASSERT_EQ(m.triangle_neighbors.size(), 4u);
  // Triangle 0: edge (1, 2) opposite corner 0 borders triangle 3; edge (2, 0)
  // is a border; edge (0, 1) has three triangles.
  EXPECT_EQ(m.triangle_neighbors[0], (Triangle{3, kNoIndex, kNoIndex}));
  EXPECT_EQ(m.triangle_neighbors[1], (Triangle{kNoIndex, kNoIndex, kNoIndex}));
  EXPECT_EQ(m.triangle_neighbors[3], (Triangle{kNoIndex, 0, kNoIndex}));
}

TEST(Analyse, CornerTetrahedron) {
  const MeshFacts f = analyse(corner_tetrahedron());
  EXPECT_EQ(f.vertices, 4u);
  EXPECT_EQ(f.triangles, 4u);
  EXPECT_EQ(f.boundary_edges, 0u);
  EXPECT_EQ(f.nonmanifold_edges, 0u);
  EXPECT_EQ(f.components, 1u);
  EXPECT_EQ(f.euler_characteristic, 2);  // 4 - 6 + 4
  EXPECT_TRUE(f.closed());
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_NEAR(f.area, 1.5 + std::sqrt(3.0) / 2, kRoundoff);
  EXPECT_NEAR(f.signed_volume, 1.0 / 6.0, kRoundoff);
  EXPECT_EQ(f.bbox_min, Vec3(0, 0, 0));
  EXPECT_EQ(f.bbox_max, Vec3(1, 1, 1));
}

TEST(Analyse, InsideOutHasNegativeVolume) {
  SurfaceMesh m = corner_tetrahedron();
  for (Triangle& t : m.triangles) std::swap(t[1], t[2]);
  const MeshFacts f = analyse(m);
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_NEAR(f.signed_volume, -1.0 / 6.0, kRoundoff);
}

TEST(Analyse, OneFlippedTriangleIsInconsistent) {
  SurfaceMesh m = corner_tetrahedron();
  std::swap(m.triangles[3][1], m.triangles[3][2]);
  const MeshFacts f = analyse(m);
  EXPECT_TRUE(f.closed());
  EXPECT_FALSE(f.consistently_oriented);
}

TEST(Analyse, OpenAndNonManifoldEdges) {
  SurfaceMesh fan;
  // Three triangles on the edge 0-1: one non-manifold edge, six boundary edges.
  fan.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1)};
  fan.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  const MeshFacts f = analyse(fan);
  EXPECT_EQ(f.nonmanifold_edges, 1u);
  EXPECT_EQ(f.boundary_edges, 6u);
  EXPECT_FALSE(f.closed());
  EXPECT_FALSE(f.manifold());
  EXPECT_FALSE(f.consistently_oriented);  // three uses of one edge: a direction repeats
  EXPECT_EQ(f.euler_characteristic, 5 - 7 + 3);
}

TEST(Analyse, ComponentsAndTorusGenus) {
  SurfaceMesh two = corner_tetrahedron();
  for (int k = 0; k < 4; ++k) two.positions.push_back(two.positions[k] + Vec3(3, 0, 0));
  for (int k = 0; k < 4; ++k) {
    Triangle t = two.triangles[k];
    for (Index& v : t) v += 4;
    two.triangles.push_back(t);
  }
  const MeshFacts f2 = analyse(two);
  EXPECT_EQ(f2.components, 2u);
  EXPECT_EQ(f2.euler_characteristic, 4);
  EXPECT_NEAR(f2.signed_volume, 2.0 / 6.0, kRoundoff);

  const MeshFacts ft = analyse(torus(24, 12));
  EXPECT_TRUE(ft.closed());
  EXPECT_TRUE(ft.consistently_oriented);
  EXPECT_EQ(ft.euler_characteristic, 0);  // genus 1
  // Volume of the inscribed polyhedral torus is below 2 pi^2 R r^2 and converges to it.
  const double exact = 2 * M_PI * M_PI * 2 * 1;
  EXPECT_LT(ft.signed_volume, exact);
  EXPECT_GT(ft.signed_volume, 0.9 * exact);
}

}  // namespace
}  // namespace palpa::mesh
