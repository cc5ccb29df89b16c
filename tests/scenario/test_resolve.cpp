// Placing a scenario's lesions: below surface points, and seeded random ones
// (the same on every machine, inside their ranges and region, apart).
// Resolving on an organ already loaded (an edited scenario of a running
// session) gives what resolving from the file gives, with the same errors.

#include "common/test_support.h"
#include "mesh/generate.h"
#include "scenario/resolve.h"

#include <gtest/gtest.h>

namespace palpa::scenario {
namespace {

mesh::SurfaceMesh ball() { return mesh::make_sphere(6000, 0.05); }

Scenario with_random(std::uint64_t seed) {
  Scenario s;
  s.file = "case.json";
  tissue::Region upper;
  upper.name = "upper";
  upper.kind = tissue::RegionKind::HalfSpace;
  upper.point = Vec3::Zero();
  upper.normal = -Vec3::UnitZ();  // inside where z >= 0
  s.regions = {upper};
  s.random_lesions.count = 6;
  s.random_lesions.seed = seed;
  s.random_lesions.region = "upper";
  return s;
}

TEST(PlaceLesions, ASurfacePointLesionSitsItsDepthBelowTheNearestVertex) {
  const auto m = ball();
  Scenario s;
  LesionSpec l;
  l.from_surface = true;
  l.surface_point = Vec3(0, 0, 0.06);
  l.depth = 0.015;
  s.lesions = {l};
  const auto out = place_lesions(s, m);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR((out[0].centre - Vec3(0, 0, 0.035)).norm(), 0.0, 1e-9);
  EXPECT_EQ(out[0].name, "lesion 1");
}

TEST(PlaceLesions, RandomLesionsAreSeededInRangeInTheirRegionAndApart) {
  const auto m = ball();
  const Scenario s = with_random(42);
  const auto a = place_lesions(s, m), b = place_lesions(s, m);
  ASSERT_EQ(a.size(), 6u);
  const RandomLesions& r = s.random_lesions;
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k], b[k]) << "the same seed gives the same lesions";
    const double radius = a[k].semi_axes.x();
    EXPECT_GE(radius, r.radius_min);
    EXPECT_LE(radius, r.radius_max);
    EXPECT_GE(a[k].modulus_ratio, r.ratio_min);
    EXPECT_LE(a[k].modulus_ratio, r.ratio_max);
    // On a sphere the centre is depth below a surface point along the radius.
    const double depth = 0.05 - a[k].centre.norm();
    EXPECT_GE(depth, std::max(r.depth_min, radius + 0.001) - 1e-9);
    EXPECT_LE(depth, std::max(r.depth_max, radius + 0.001) + 1e-9);
    EXPECT_GT(a[k].centre.z(), -1e-9) << "below a surface point of the region (z >= 0)";
    for (std::size_t j = 0; j < k; ++j)
      EXPECT_GT((a[k].centre - a[j].centre).norm(), radius + a[j].semi_axes.x()) << k << " and " << j << " overlap";
  }
  const auto c = place_lesions(with_random(43), m);
  EXPECT_NE(a[0].centre, c[0].centre) << "another seed, other lesions";
}

TEST(PlaceLesions, AnEmptyRegionIsNamed) {
  const auto m = ball();
  Scenario s = with_random(1);
  s.regions[0].point = Vec3(0, 0, 1);  // inside where z >= 1 m: nothing
  try {
    place_lesions(s, m);
    FAIL();
  } catch (const ScenarioError& e) {
    EXPECT_STREQ(e.what(), "case.json: /random_lesions/region: the region 'upper' holds no vertex of the organ");
  }
}

TEST(ResolveOn, GivesWhatResolveGivesOnTheSameOrganAndTheSameErrors) {
  const Scenario s = load_scenario(palpa::test::project_data_dir() / "scenarios" / "liver_tumour.json");
  const Resolved a = resolve(s);
  const Resolved b = resolve_on(s, a.organ);
  EXPECT_EQ(b.organ.mesh, a.organ.mesh) << "the organ is not loaded again";
  EXPECT_EQ(b.scenario, a.scenario);
  EXPECT_EQ(b.lesions, a.lesions);
  EXPECT_EQ(b.tissues, a.tissues);
  EXPECT_EQ(b.base, a.base);
  EXPECT_EQ(b.materials->tissues, a.materials->tissues);
  EXPECT_EQ(b.materials->tissue_of, a.materials->tissue_of);
  EXPECT_EQ(b.materials->scale, a.materials->scale);
  ASSERT_EQ(b.field->lesion_count, a.field->lesion_count);
  for (std::size_t k = 0; k < a.field->lesion_count; ++k) {
    EXPECT_EQ(b.field->lesions[k].centre, a.field->lesions[k].centre);
    EXPECT_EQ(b.field->lesions[k].size2, a.field->lesions[k].size2);
  }
  // The running session's tissue: the resolved map and field themselves.
  const auto t = tissue_model(b);
  EXPECT_EQ(t->map, b.materials);
  EXPECT_EQ(t->field, b.field);

  // An edit that does not resolve: the same error either way.
  Scenario bad = s;
  ASSERT_FALSE(bad.lesions.empty());
  bad.lesions[0].lesion.semi_axes = Vec3(0.01, 0, 0.01);
  std::string from_file, on_organ;
  try {
    resolve(bad);
  } catch (const ScenarioError& e) {
    from_file = e.what();
  }
  try {
    resolve_on(bad, a.organ);
  } catch (const ScenarioError& e) {
    on_organ = e.what();
  }
  EXPECT_FALSE(from_file.empty());
  EXPECT_EQ(on_organ, from_file);
  EXPECT_NE(on_organ.find("semi-axis"), std::string::npos) << on_organ;
  // No organ to resolve on.
  try {
    resolve_on(s, mesh::Organ{});
    FAIL();
  } catch (const ScenarioError& e) {
    EXPECT_EQ(e.pointer(), "/organ");
  }
}

}  // namespace
}  // namespace palpa::scenario
