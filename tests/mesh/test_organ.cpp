// Organ loading: unit guessing, the default organ, the bundled scenario
// organs (breast, abdomen), real organs.

#include "mesh/organ.h"

#include "common/test_support.h"
#include "mesh/generate.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

namespace palpa::mesh {
namespace {

TEST(Organ, UnitGuessMakesTheLargestExtentOrganSized) {
  EXPECT_EQ(auto_unit_metres(0.2), 1.0);     // metres
  EXPECT_EQ(auto_unit_metres(6.4), 1e-2);    // SOFA liver-smooth, cm
  EXPECT_EQ(auto_unit_metres(194.0), 1e-3);  // SOFA liver.vtk, mm
  EXPECT_EQ(parse_mesh_unit("mm"), MeshUnit::Millimetre);
  EXPECT_EQ(unit_metres(MeshUnit::Centimetre), 1e-2);
  try {
    parse_mesh_unit("inch");
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "unknown mesh unit 'inch' (expected auto, m, cm or mm)");
  }
}

TEST(Organ, DefaultOrganIsClosedAndOrganSized) {
  const Organ o = load_default_organ();
  ASSERT_TRUE(o.mesh);
  EXPECT_TRUE(o.facts.closed());
  const Vec3 ext = o.facts.bbox_max - o.facts.bbox_min;
  EXPECT_GT(ext.maxCoeff(), 0.1);
  EXPECT_LT(ext.maxCoeff(), 0.4);
  EXPECT_GT(o.mesh->vertex_count(), 1000u);
}

TEST(Organ, RealLiverInMillimetresIsScaledAndStripped) {
  PALPA_REQUIRE_SHARED_ORGANS();
  const Organ o = load_organ(palpa::test::shared_organs_dir() / "sofa_liver.vtk");
  EXPECT_TRUE(o.unit_guessed);
  EXPECT_EQ(o.unit_m, 1e-3);
  EXPECT_EQ(o.facts.components, 1u) << "the three specks are dropped";
  EXPECT_NEAR((o.facts.bbox_max - o.facts.bbox_min).maxCoeff(), 0.194, 0.002);
}

TEST(Organ, MissingFileErrorNamesIt) {
  const auto path = palpa::test::temp_dir("organ_missing") / "gone.obj";
  try {
    load_organ(path);
    FAIL() << "no error";
  } catch (const MeshError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path.string(), 0), 0u) << e.what();
  }
}

// An organ is 5 mm to 1 m across: a forgotten unit is refused with the one that fits.
TEST(Organ, SizesThatCannotBeAnOrganAreRefusedWithTheUnitThatFits) {
  const auto dir = palpa::test::temp_dir("organ_sizes");
  auto tet = [&](const char* name, double size) {
    const auto path = dir / name;
    std::ofstream(path) << "v 0 0 0\nv " << size << " 0 0\nv 0 " << size << " 0\nv 0 0 " << size
                        << "\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    return path;
  };
  struct Case {
    const char* name;
    double size;
    MeshUnit unit;
    std::string expected;  // after "<path>: "
  };
  const Case cases[] = {
      {"heart_mm.obj", 138, MeshUnit::Metre,
       "the organ is 138 m across with the unit m; an organ is 5 mm to 1 m across: with the unit mm it is 13.8 cm"},
      {"metres_as_mm.obj", 0.3, MeshUnit::Millimetre,
       "the organ is 0.3 mm across with the unit mm; an organ is 5 mm to 1 m across: with the unit m it is 30 cm"},
      {"huge.obj", 50000, MeshUnit::Auto,
       "the organ is 50 m across with the unit mm (the best guess); an organ is 5 mm to 1 m across, and no unit "
       "(m, cm or mm) makes it so"},
      {"speck.obj", 1e-5, MeshUnit::Auto,
       "the organ is 1e-05 m across with the unit m (the best guess); an organ is 5 mm to 1 m across, and no unit "
       "(m, cm or mm) makes it so"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const auto path = tet(c.name, c.size);
    try {
      load_organ(path, c.unit);
      ADD_FAILURE() << "no error";
    } catch (const MeshError& e) {
      EXPECT_EQ(std::string(e.what()), path.string() + ": " + c.expected);
    }
  }
  // The limits themselves are organs.
  EXPECT_NO_THROW(load_organ(tet("small.obj", 5.0), MeshUnit::Millimetre));
  EXPECT_NO_THROW(load_organ(tet("large.obj", 1.0), MeshUnit::Metre));
}

// Open boundaries and non-manifold edges are named in the load summary.
TEST(Organ, OpenAndNonManifoldSurfacesAreNamedInTheNote) {
  const auto dir = palpa::test::temp_dir("organ_topology");
  // A closed tetrahedron has no note; without one face it has one open boundary.
  std::ofstream(dir / "closed.obj") << "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  std::ofstream(dir / "open.obj") << "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n";
  // Three triangles on the edge 1-2.
  std::ofstream(dir / "fan.obj") << "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 -0.1 0\nv 0 0 0.1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n";
  EXPECT_EQ(load_organ(dir / "closed.obj", MeshUnit::Metre).note, "");
  EXPECT_EQ(load_organ(dir / "open.obj", MeshUnit::Metre).note,
            "not a closed surface: 1 open boundary (3 boundary edges, the first at (50.0, 50.0, 0.0) mm)");
  EXPECT_EQ(load_organ(dir / "fan.obj", MeshUnit::Metre).note,
            "not a closed surface: 1 open boundary (6 boundary edges, the first at (0.0, 50.0, 0.0) mm) and 1 "
            "non-manifold edge (at (50.0, 0.0, 0.0) mm, shared by more than two triangles)");
}

// The bundled scenario organs load in metres, closed and outward as stored,
// and are what their generator makes now (to float32 precision): a changed
// shape without a regenerated file fails here (data/README.md has the commands).
void expect_bundled_file_matches(const std::string& file, SurfaceMesh (*generate)(std::size_t)) {
  const std::filesystem::path path = palpa::test::project_data_dir() / file;
  ASSERT_TRUE(std::filesystem::exists(path)) << path << " is missing (see data/README.md)";
  EXPECT_LT(std::filesystem::file_size(path), 1'000'000u);
  const Organ o = load_organ(path, MeshUnit::Metre);
  ASSERT_TRUE(o.mesh);
  EXPECT_FALSE(o.unit_guessed);
  EXPECT_EQ(o.unit_m, 1.0);
  EXPECT_TRUE(o.facts.closed());
  EXPECT_TRUE(o.facts.consistently_oriented);
  EXPECT_EQ(o.facts.components, 1u);
  EXPECT_EQ(o.facts.euler_characteristic, 2);
  EXPECT_GT(o.facts.signed_volume, 0.0);
  // The file's own numbering (load_organ renumbers in spatial order).
  LoadOptions lo;
  lo.keep_largest_component = true;
  const SurfaceMesh file_mesh = load_mesh(path, lo);
  const SurfaceMesh fresh = generate(20'000);
  ASSERT_EQ(o.mesh->vertex_count(), fresh.vertex_count());
  ASSERT_EQ(file_mesh.vertex_count(), fresh.vertex_count());
  ASSERT_EQ(o.mesh->triangle_count(), fresh.triangle_count());
  double worst = 0;
  for (std::size_t i = 0; i < fresh.vertex_count(); ++i)
    worst = std::max(worst, (file_mesh.positions[i] - fresh.positions[i]).cwiseAbs().maxCoeff());
  EXPECT_LT(worst, 1e-7) << "m; regenerate " << path;  // float32 of coordinates below 0.16 m: < 1e-8
  EXPECT_TRUE(file_mesh.triangles == fresh.triangles);
  EXPECT_NEAR(o.facts.signed_volume / analyse(fresh).signed_volume, 1.0, 1e-5);
}

TEST(BundledOrgans, BreastFileMatchesAFreshGeneration) { expect_bundled_file_matches("breast.ply", make_breast); }

TEST(BundledOrgans, AbdomenFileMatchesAFreshGeneration) { expect_bundled_file_matches("abdomen.ply", make_abdomen); }

}  // namespace
}  // namespace palpa::mesh
