// Organ loading: unit guessing, the default organ, real organs.

#include "mesh/organ.h"

#include "common/test_support.h"

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

}  // namespace
}  // namespace palpa::mesh
