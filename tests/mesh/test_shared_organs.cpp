// The real organ meshes in ../shared/data/organs load clean, with the counts
// SOURCES.md gives (measured independently with trimesh and edge counting).

#include "common/test_support.h"
#include "mesh/io.h"

#include <Eigen/Geometry>

#include <cmath>

namespace palpa::mesh {
namespace {

struct Organ {
  const char* file;
  bool keep_largest;
  std::size_t raw_vertices;  // "V raw" in SOURCES.md
  std::size_t vertices;      // "V welded"
  std::size_t triangles;
  std::size_t components;
  long genus;                // per component, all components alike
  double abs_volume;         // |signed volume| in file units^3 from SOURCES.md (0: not given)
  bool stored_inside_out;    // SOURCES.md: "inward-facing orientation"
};

const Organ kOrgans[] = {
    {"sofa_liver-smooth.obj", false, 2194, 2194, 4384, 1, 0, 39.3, false},
    {"sofa_liver.vtk", false, 5008, 5008, 10000, 4, 0, 1.48e6, true},
    {"sofa_liver.vtk", true, 5008, 4996, 9988, 1, 0, 1.48e6, true},
    {"sofa_coeur1.off", false, 7778, 7778, 15552, 1, 0, 13865, true},
    {"sofa_coeur1.trian", false, 7778, 7778, 15552, 1, 0, 13865, true},
    {"bp3d_FMA72717_right_cingulate_gyrus.obj", false, 5899, 5860, 11716, 1, 0, 0, false},
    {"gca_EdinGCA_3D_00090_large_intestine_20k.vtk", false, 10000, 10000, 20000, 1, 1, 0, false},
};

TEST(SharedOrgans, LoadClosedManifoldOutwardWithTheDocumentedCounts) {
  PALPA_REQUIRE_SHARED_ORGANS();
  for (const Organ& o : kOrgans) {
    SCOPED_TRACE(std::string(o.file) + (o.keep_largest ? " (largest component)" : ""));
    LoadOptions options;
    options.keep_largest_component = o.keep_largest;
    CleanReport r;
    const SurfaceMesh m = load_mesh(test::shared_organs_dir() / o.file, options, &r);
    const MeshFacts f = analyse(m);
    EXPECT_EQ(r.input_vertices, o.raw_vertices);
    EXPECT_EQ(f.vertices, o.vertices);
    EXPECT_EQ(f.triangles, o.triangles);
    EXPECT_EQ(f.components, o.components);
    EXPECT_EQ(f.euler_characteristic, long(2 * o.components) - 2 * o.genus * long(o.components));
    EXPECT_TRUE(f.closed());
    EXPECT_TRUE(f.manifold());
    EXPECT_TRUE(f.consistently_oriented);
    EXPECT_GT(f.signed_volume, 0.0);
    if (o.abs_volume > 0) {
      EXPECT_NEAR(f.signed_volume, o.abs_volume, 0.01 * o.abs_volume);
    }
    // Inside-out files have every triangle reversed, the others none.
    EXPECT_EQ(r.flipped_triangles, o.stored_inside_out ? o.triangles : 0u);
    EXPECT_EQ(r.welded_vertices + r.unused_vertices, o.raw_vertices - o.vertices);
    // Normals point outward: by the divergence theorem, the integral of
    // (p - c) . n over the surface is 3 V; with vertex normals and a third of
    // the incident triangle areas per vertex it must come out close to that.
    std::vector<double> vertex_area(m.vertex_count(), 0.0);
    for (const Triangle& t : m.triangles) {
      const double a = 0.5 * (m.positions[t[1]] - m.positions[t[0]]).cross(m.positions[t[2]] - m.positions[t[0]]).norm();
      for (Index v : t) vertex_area[v] += a / 3;
    }
    double flux = 0;
    for (std::size_t i = 0; i < m.vertex_count(); ++i) flux += vertex_area[i] * m.normals[i].dot(m.positions[i] - f.bbox_min);
    EXPECT_NEAR(flux / (3 * f.signed_volume), 1.0, 0.05);
  }
}

TEST(SharedOrgans, TrianAndOffCopiesAgree) {
  PALPA_REQUIRE_SHARED_ORGANS();
  const SurfaceMesh a = load_mesh(test::shared_organs_dir() / "sofa_coeur1.trian");
  const SurfaceMesh b = load_mesh(test::shared_organs_dir() / "sofa_coeur1.off");
  ASSERT_EQ(a.vertex_count(), b.vertex_count());
  EXPECT_EQ(a.triangles, b.triangles);
  // The OFF goes through OpenMesh as float32, the .trian is read as double.
  for (std::size_t i = 0; i < a.vertex_count(); ++i) EXPECT_LT((a.positions[i] - b.positions[i]).norm(), 1e-5);
}

TEST(SharedOrgans, CentimetreLiverInMetres) {
  PALPA_REQUIRE_SHARED_ORGANS();
  LoadOptions cm;
  cm.unit_m = 0.01;  // the file's header says centimetres
  const MeshFacts f = analyse(load_mesh(test::shared_organs_dir() / "sofa_liver-smooth.obj", cm));
  EXPECT_NEAR(f.signed_volume, 39.3e-6, 0.01 * 39.3e-6);
  const Vec3 size = f.bbox_max - f.bbox_min;
  EXPECT_NEAR(size.x(), 0.064, 0.002);
  EXPECT_NEAR(size.y(), 0.049, 0.002);
  EXPECT_NEAR(size.z(), 0.044, 0.002);
}

}  // namespace
}  // namespace palpa::mesh
