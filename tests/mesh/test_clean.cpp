// The cleaning pass, driven through from_polygons (and load_mesh for STL):
// welding, degenerate / duplicate triangles, orientation, components, units.

#include "common/test_support.h"
#include "mesh/io.h"

#include <array>
#include <cmath>
#include <fstream>

namespace palpa::mesh {
namespace {

using Polygons = std::vector<std::vector<long long>>;

// The unit cube [0,1]^3: 8 corners and 12 outward triangles.
const std::vector<Vec3> kCorners = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0),
                                    Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(1, 1, 1), Vec3(0, 1, 1)};
const Polygons kCubeTriangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                 {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};

// The cube as a triangle soup: every triangle has its own three vertices (like STL).
void cube_soup(std::vector<Vec3>& v, Polygons& p, double jitter = 0) {
  v.clear();
  p.clear();
  for (const auto& t : kCubeTriangles) {
    std::vector<long long> ids;
    for (long long c : t) {
      ids.push_back(static_cast<long long>(v.size()));
      v.push_back(kCorners[c] + Vec3::Constant(jitter * double(v.size() % 3)));
    }
    p.push_back(ids);
  }
}

TEST(Weld, CubeSoupBecomesEightVerticesClosed) {
  std::vector<Vec3> v;
  Polygons p;
  cube_soup(v, p);
  CleanReport r;
  const SurfaceMesh m = from_polygons(v, p, {}, "cube", &r);
  const MeshFacts f = analyse(m);
  EXPECT_EQ(f.vertices, 8u);
  EXPECT_EQ(f.triangles, 12u);
  EXPECT_TRUE(f.closed());
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_EQ(f.euler_characteristic, 2);
  EXPECT_NEAR(f.signed_volume, 1.0, test::kRoundoff);
  EXPECT_EQ(r.input_vertices, 36u);
  EXPECT_EQ(r.welded_vertices, 28u);
  EXPECT_EQ(r.unused_vertices, 0u);
  EXPECT_EQ(r.flipped_triangles, 0u);
}

TEST(Weld, ToleranceMergesNearDuplicatesOnly) {
  std::vector<Vec3> v;
  Polygons p;
  cube_soup(v, p, 1e-7);  // copies differ by up to 2e-7 per axis
  LoadOptions exact;
  const MeshFacts fe = analyse(from_polygons(v, p, exact, "cube"));
  EXPECT_GT(fe.vertices, 8u);
  EXPECT_FALSE(fe.closed());

  LoadOptions near;
  near.weld_tolerance = 1e-6;
  const MeshFacts fn = analyse(from_polygons(v, p, near, "cube"));
  EXPECT_EQ(fn.vertices, 8u);
  EXPECT_TRUE(fn.closed());

  LoadOptions off;
  off.weld = false;
  cube_soup(v, p);
  const MeshFacts fo = analyse(from_polygons(v, p, off, "cube"));
  EXPECT_EQ(fo.vertices, 36u);
  EXPECT_EQ(fo.boundary_edges, 36u);
}

TEST(Clean, DropsDegenerateAndDuplicateTriangles) {
  std::vector<Vec3> v = kCorners;
  v.push_back(Vec3(0.5, 0, 0));  // 8: on the edge 0-1, for a zero-area triangle
  Polygons p = kCubeTriangles;
  p.push_back({0, 0, 1});  // repeated vertex
  p.push_back({0, 8, 1});  // collinear: zero area
  p.push_back({0, 2, 1});  // duplicate of the first triangle
  p.push_back({0, 1, 2});  // the same vertex set, reversed
  CleanReport r;
  const SurfaceMesh m = from_polygons(v, p, {}, "cube", &r);
  EXPECT_EQ(m.triangle_count(), 12u);
  EXPECT_EQ(m.vertex_count(), 8u);
  EXPECT_EQ(r.input_triangles, 16u);
  EXPECT_EQ(r.degenerate_triangles, 2u);
  EXPECT_EQ(r.duplicate_triangles, 2u);
  EXPECT_EQ(r.unused_vertices, 1u);
  EXPECT_TRUE(analyse(m).closed());
}

TEST(Orient, InsideOutCubeIsFlipped) {
  Polygons p = kCubeTriangles;
  for (auto& t : p) std::swap(t[1], t[2]);
  CleanReport r;
  const SurfaceMesh m = from_polygons(kCorners, p, {}, "cube", &r);
  const MeshFacts f = analyse(m);
  EXPECT_EQ(r.flipped_triangles, 12u);
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_NEAR(f.signed_volume, 1.0, test::kRoundoff);
  // Outward normals: the corner (1,1,1) points away from the centre.
  EXPECT_GT(m.normals[6].dot(Vec3(1, 1, 1)), 0.0);
}

TEST(Orient, MixedOrientationBecomesConsistentAndOutward) {
  Polygons p = kCubeTriangles;
  for (std::size_t t = 0; t < p.size(); t += 3) std::swap(p[t][1], p[t][2]);  // 4 of 12 reversed
  CleanReport r;
  const MeshFacts f = analyse(from_polygons(kCorners, p, {}, "cube", &r));
  EXPECT_EQ(r.flipped_triangles, 4u);
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_NEAR(f.signed_volume, 1.0, test::kRoundoff);

  LoadOptions keep;
  keep.orient_outward = false;
  EXPECT_FALSE(analyse(from_polygons(kCorners, p, keep, "cube")).consistently_oriented);
}

TEST(Orient, OpenSurfaceKeepsTheMajorityOrientation) {
  // A strip of three triangles, the middle one reversed: it is the one flipped.
  const std::vector<Vec3> v = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(0, 2, 0)};
  const Polygons p = {{0, 1, 2}, {1, 2, 3}, {2, 3, 4}};  // +z, -z, +z
  CleanReport r;
  const SurfaceMesh m = from_polygons(v, p, {}, "strip", &r);
  EXPECT_EQ(r.flipped_triangles, 1u);
  EXPECT_TRUE(analyse(m).consistently_oriented);
  for (const Vec3& n : m.normals) EXPECT_EQ(n, Vec3(0, 0, 1));
}

TEST(Components, KeepLargestDropsSpecks) {
  std::vector<Vec3> v = kCorners;
  Polygons p = kCubeTriangles;
  // Two tiny tetrahedra far away (like the specks in sofa_liver.vtk).
  for (int s = 0; s < 2; ++s) {
    const long long b = static_cast<long long>(v.size());
    const Vec3 o(5.0 + s, 5, 5);
    v.insert(v.end(), {o, o + Vec3(0.01, 0, 0), o + Vec3(0, 0.01, 0), o + Vec3(0, 0, 0.01)});
    p.insert(p.end(), {{b, b + 2, b + 1}, {b, b + 1, b + 3}, {b, b + 3, b + 2}, {b + 1, b + 2, b + 3}});
  }
  EXPECT_EQ(analyse(from_polygons(v, p, {}, "specks")).components, 3u);

  LoadOptions largest;
  largest.keep_largest_component = true;
  CleanReport r;
  const SurfaceMesh m = from_polygons(v, p, largest, "specks", &r);
  const MeshFacts f = analyse(m);
  EXPECT_EQ(f.components, 1u);
  EXPECT_EQ(f.vertices, 8u);
  EXPECT_EQ(f.triangles, 12u);
  EXPECT_EQ(r.dropped_components, 2u);
  EXPECT_EQ(r.unused_vertices, 8u);
  EXPECT_NEAR(f.signed_volume, 1.0, test::kRoundoff);
}

TEST(Units, MillimetresBecomeMetres) {
  std::vector<Vec3> mm;
  for (const Vec3& c : kCorners) mm.push_back(1000.0 * c);
  LoadOptions o;
  o.unit_m = 1e-3;
  const MeshFacts f = analyse(from_polygons(mm, kCubeTriangles, o, "cube_mm"));
  EXPECT_NEAR(f.signed_volume, 1.0, 1e-12);
  EXPECT_NEAR(f.area, 6.0, 1e-12);
  EXPECT_NEAR((f.bbox_max - Vec3(1, 1, 1)).norm(), 0.0, 1e-15);
}

TEST(Polygons, QuadsAreFanTriangulated) {
  const Polygons quads = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  const MeshFacts f = analyse(from_polygons(kCorners, quads, {}, "quads"));
  EXPECT_EQ(f.triangles, 12u);
  EXPECT_TRUE(f.closed());
  EXPECT_NEAR(f.signed_volume, 1.0, test::kRoundoff);
}

// An STL cube written by hand: every facet repeats its corners, as STL does.
TEST(Weld, HandWrittenStlCubeHasEightVertices) {
  const auto dir = test::temp_dir("mesh_clean_stl");
  const auto path = dir / "cube.stl";
  {
    std::ofstream out(path);
    out << "solid cube\n";
    for (const auto& t : kCubeTriangles) {
      out << "  facet normal 0 0 0\n    outer loop\n";
      for (long long c : t)
        out << "      vertex " << kCorners[c].x() << ' ' << kCorners[c].y() << ' ' << kCorners[c].z() << "\n";
      out << "    endloop\n  endfacet\n";
    }
    out << "endsolid cube\n";
  }
  CleanReport r;
  const SurfaceMesh m = load_mesh(path, {}, &r);
  const MeshFacts f = analyse(m);
  EXPECT_EQ(f.vertices, 8u);
  EXPECT_EQ(f.triangles, 12u);
  EXPECT_TRUE(f.closed());
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_NEAR(f.signed_volume, 1.0, test::kRoundoff);
  EXPECT_EQ(r.input_vertices, 36u);
  EXPECT_EQ(r.welded_vertices, 28u);
}

}  // namespace
}  // namespace palpa::mesh
