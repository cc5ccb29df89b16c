// Spatial order (mesh/spatial_order.h): a renumbering that keeps the surface,
// follows a Hilbert curve, and packs a contact-sized patch into few cache lines.

#include "mesh/spatial_order.h"

#include "mesh/generate.h"
#include "mesh/organ.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <numeric>
#include <random>
#include <set>
#include <vector>

namespace palpa::mesh {
namespace {

// A copy of m with its vertices numbered in a random order (what a mesh
// file written by another tool often looks like).
SurfaceMesh shuffled(const SurfaceMesh& m, unsigned seed) {
  std::vector<Index> perm(m.vertex_count());
  std::iota(perm.begin(), perm.end(), Index{0});
  std::mt19937 rng(seed);
  std::shuffle(perm.begin(), perm.end(), rng);
  SurfaceMesh out;
  out.positions.resize(m.vertex_count());
  for (std::size_t i = 0; i < perm.size(); ++i) out.positions[perm[i]] = m.positions[i];
  out.triangles = m.triangles;
  for (Triangle& t : out.triangles)
    for (Index& v : t) v = perm[v];
  std::shuffle(out.triangles.begin(), out.triangles.end(), rng);
  finalize(out);
  return out;
}

// Cache lines of a 24-byte-per-vertex array (the surface state) that the
// vertices within `radius` of p occupy, and the fewest they could occupy.
std::pair<std::size_t, std::size_t> lines_near(const SurfaceMesh& m, const Vec3& p, double radius) {
  std::set<std::size_t> lines;
  std::size_t count = 0;
  for (std::size_t i = 0; i < m.vertex_count(); ++i) {
    if ((m.positions[i] - p).norm() >= radius) continue;
    ++count;
    lines.insert(i * 24 / 64);
    lines.insert((i * 24 + 23) / 64);
  }
  return {lines.size(), (count * 24 + 63) / 64};
}

TEST(SpatialOrder, ConsecutiveKeysOfACellGridAreNeighbouringCells) {
  // The centres of an 8 x 8 x 8 grid of cells sorted by key walk the grid
  // one face-neighbour at a time (the Hilbert curve's defining property),
  // through every cell once.
  std::vector<std::pair<std::uint64_t, std::array<int, 3>>> cells;
  for (int x = 0; x < 8; ++x)
    for (int y = 0; y < 8; ++y)
      for (int z = 0; z < 8; ++z)
        cells.push_back({hilbert_key(Vec3((x + 0.5) / 8, (y + 0.5) / 8, (z + 0.5) / 8), Vec3::Zero(), Vec3::Ones()),
                         {x, y, z}});
  std::sort(cells.begin(), cells.end());
  for (std::size_t k = 1; k < cells.size(); ++k) {
    ASSERT_NE(cells[k].first, cells[k - 1].first);
    int steps = 0;
    for (int a = 0; a < 3; ++a) steps += std::abs(cells[k].second[a] - cells[k - 1].second[a]);
    EXPECT_EQ(steps, 1) << "key " << k;
  }
  // Outside the box and NaN clamp instead of overflowing.
  EXPECT_EQ(hilbert_key(Vec3(-1, -1, -1), Vec3::Zero(), Vec3::Ones()), 0u);
  EXPECT_EQ(hilbert_key(Vec3(2, 2, 2), Vec3::Zero(), Vec3::Ones()),
            hilbert_key(Vec3(1, 1, 1), Vec3::Zero(), Vec3::Ones()));
  EXPECT_EQ(hilbert_key(Vec3(std::nan(""), 0, 0), Vec3::Zero(), Vec3::Ones()), 0u);
}

TEST(SpatialOrder, KeepsTheSurfaceItsOrientationAndItsNormals) {
  const SurfaceMesh original = shuffled(make_organ(5000), 7);
  SurfaceMesh m = original;
  const std::vector<Index> new_of_old = reorder_spatially(m);
  ASSERT_EQ(new_of_old.size(), original.vertex_count());
  ASSERT_EQ(m.vertex_count(), original.vertex_count());
  ASSERT_EQ(m.triangle_count(), original.triangle_count());
  // A permutation, moving each position and normal with its vertex.
  std::vector<int> hit(m.vertex_count(), 0);
  for (std::size_t i = 0; i < new_of_old.size(); ++i) {
    ASSERT_LT(new_of_old[i], m.vertex_count());
    ++hit[new_of_old[i]];
    EXPECT_EQ(m.positions[new_of_old[i]], original.positions[i]);
    // The same normal up to rounding (computed again from the renumbered mesh).
    EXPECT_LT((m.normals[new_of_old[i]] - original.normals[i]).norm(), 1e-12);
  }
  EXPECT_TRUE(std::all_of(hit.begin(), hit.end(), [](int h) { return h == 1; }));
  // The same triangles, each a rotation (never a reflection) of its old corners.
  auto canonical = [](Triangle t) {
    while (t[0] > t[1] || t[0] > t[2]) t = Triangle{t[1], t[2], t[0]};
    return t;
  };
  std::multiset<Triangle> before, after;
  for (Triangle t : original.triangles) {
    for (Index& v : t) v = new_of_old[v];
    before.insert(canonical(t));
  }
  for (const Triangle& t : m.triangles) after.insert(canonical(t));
  EXPECT_TRUE(before == after);
  // Adjacency is that of the new numbering.
  SurfaceMesh rebuilt = m;
  build_adjacency(rebuilt);
  EXPECT_EQ(m.vertex_neighbors.offsets, rebuilt.vertex_neighbors.offsets);
  EXPECT_EQ(m.vertex_neighbors.items, rebuilt.vertex_neighbors.items);
  EXPECT_EQ(m.vertex_triangles.items, rebuilt.vertex_triangles.items);
  EXPECT_EQ(m.triangle_neighbors, rebuilt.triangle_neighbors);
}

// A session file keeps an organ's positions and triangles and its reader
// computes the normals from them (finalize). Every way an organ reaches a
// session must give those very normals, bit for bit, or a replay's forces
// differ from the recording in the last bits (found: a generated organ
// renumbered with its old normals permuted replayed 5e-20 N off from tick
// 1162 of a 10 s session).
void expect_normals_as_a_session_reads_them(const SurfaceMesh& m, const std::string& what) {
  SurfaceMesh read;
  read.positions = m.positions;
  read.triangles = m.triangles;
  finalize(read);
  ASSERT_EQ(read.normals.size(), m.normals.size()) << what;
  std::size_t differ = 0;
  for (std::size_t i = 0; i < m.normals.size(); ++i) differ += read.normals[i] != m.normals[i];
  EXPECT_EQ(differ, 0u) << what << ": " << differ << " of " << m.normals.size() << " normals differ";
}

TEST(SpatialOrder, AnOrgansNormalsAreThoseASessionFileGivesBack) {
  SurfaceMesh generated = shuffled(make_organ(20000), 3);
  reorder_spatially(generated);
  expect_normals_as_a_session_reads_them(generated, "generated organ, renumbered");
  expect_normals_as_a_session_reads_them(*load_default_organ().mesh, "default organ");
}

TEST(SpatialOrder, AMillimetreOrgansNormalsAreThoseASessionFileGivesBack) {
  // SOFA's liver, in millimetres: load_organ computes its normals before the scaling to metres.
  PALPA_REQUIRE_SHARED_ORGANS();
  expect_normals_as_a_session_reads_them(*load_organ(palpa::test::shared_organs_dir() / "sofa_liver.vtk").mesh,
                                         "sofa_liver.vtk (millimetres)");
}

TEST(SpatialOrder, IsIdempotent) {
  SurfaceMesh once = shuffled(make_sphere(3000, 0.05), 3);
  reorder_spatially(once);
  SurfaceMesh twice = once;
  const std::vector<Index> again = reorder_spatially(twice);
  for (std::size_t i = 0; i < again.size(); ++i) ASSERT_EQ(again[i], i);
  EXPECT_EQ(twice.positions, once.positions);
  EXPECT_EQ(twice.triangles, once.triangles);
  SurfaceMesh empty;
  EXPECT_TRUE(reorder_spatially(empty).empty());
}

TEST(SpatialOrder, AContactSizedPatchFillsFewCacheLines) {
  // A 15 mm patch of a 100 mm sphere with 100k vertices holds about 560
  // vertices: 210 cache lines of 24-byte states at best. Numbered at random
  // they take about one line each (over 1000 with the straddles); along the
  // curve within twice the best.
  const SurfaceMesh random_order = shuffled(make_sphere(100'000, 0.1), 11);
  SurfaceMesh m = random_order;
  reorder_spatially(m);
  for (const Vec3& dir : {Vec3(0, 0, 1), Vec3(1, 1, 1).normalized(), Vec3(-0.3, 0.8, 0.2).normalized()}) {
    const auto [lines_random, best_random] = lines_near(random_order, 0.1 * dir, 0.015);
    const auto [lines, best] = lines_near(m, 0.1 * dir, 0.015);
    EXPECT_EQ(best, best_random);
    EXPECT_GT(best, 150u);
    EXPECT_GT(lines_random, 3 * best);
    EXPECT_LE(lines, 2 * best) << "patch at " << dir.transpose();
  }
}

}  // namespace
}  // namespace palpa::mesh

namespace palpa::mesh {
namespace {

TEST(SpatialOrder, ASessionsMeshMatchesItsOrganInEitherNumbering) {
  // A session recorded before the spatial order holds the file's numbering;
  // the organ loaded now is renumbered: the same organ either way.
  const SurfaceMesh file_order = shuffled(make_organ(3000), 5);
  SurfaceMesh loaded = file_order;
  reorder_spatially(loaded);
  EXPECT_TRUE(same_mesh_up_to_spatial_order(file_order, loaded));
  EXPECT_TRUE(same_mesh_up_to_spatial_order(loaded, loaded));
  // Another organ, or the same one with one vertex moved or one triangle
  // turned over, is not.
  SurfaceMesh moved = file_order;
  moved.positions[17].x() += 1e-9;
  EXPECT_FALSE(same_mesh_up_to_spatial_order(moved, loaded));
  SurfaceMesh flipped = file_order;
  std::swap(flipped.triangles[3][1], flipped.triangles[3][2]);
  EXPECT_FALSE(same_mesh_up_to_spatial_order(flipped, loaded));
  EXPECT_FALSE(same_mesh_up_to_spatial_order(make_organ(2000), loaded));
}

}  // namespace
}  // namespace palpa::mesh
