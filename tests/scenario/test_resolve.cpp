// Placing a scenario's lesions: below surface points, and seeded random ones
// (the same on every machine, inside their ranges and region, apart).

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

}  // namespace
}  // namespace palpa::scenario
