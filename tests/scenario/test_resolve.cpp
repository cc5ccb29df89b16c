// Resolving lesions on an organ: a surface point and depth land below the
// nearest vertex; random lesions stay in their ranges and region, and a seed
// gives the same lesions every time (another seed, others).

#include "mesh/generate.h"
#include "scenario/scenario.h"
#include "scenario_fixture.h"

#include <gtest/gtest.h>

namespace palpa::scenario {
namespace {

Scenario sphere_case() {
  Scenario s;
  s.file = "case.json";
  LesionSpec a;
  a.lesion.name = "a";
  a.lesion.centre = Vec3(0.01, 0, 0);
  LesionSpec b;
  b.lesion.name = "b";
  b.from_surface = true;
  b.surface_point = Vec3(0, 0, 0.06);  // above the top of a 50 mm sphere
  b.depth = 0.012;
  s.lesions = {a, b};
  return s;
}

TEST(ResolveLesions, SurfacePointAndDepthLandBelowTheNearestVertex) {
  const mesh::SurfaceMesh sphere = mesh::make_sphere(4000, 0.05);
  const auto lesions = resolve_lesions(sphere_case(), sphere);
  ASSERT_EQ(lesions.size(), 2u);
  EXPECT_EQ(lesions[0].centre, Vec3(0.01, 0, 0));
  // Below the top vertex along the inward normal: on the z axis, 50 - 12 mm up.
  EXPECT_NEAR(lesions[1].centre.z(), 0.038, 1e-3);
  EXPECT_NEAR(lesions[1].centre.head<2>().norm(), 0.0, 2e-3);
  EXPECT_EQ(lesions[1].name, "b");
}

TEST(ResolveLesions, RandomLesionsAreSeededInRangeAndInTheRegion) {
  const mesh::SurfaceMesh sphere = mesh::make_sphere(4000, 0.05);
  Scenario s = sphere_case();
  s.random_lesions.count = 20;
  s.random_lesions.seed = 7;
  s.random_lesions.region = "upper";
  std::vector<float> upper(sphere.vertex_count());
  for (std::size_t i = 0; i < upper.size(); ++i) upper[i] = sphere.positions[i].z() > 0.02 ? 1.f : 0.f;
  const auto first = resolve_lesions(s, sphere, upper);
  ASSERT_EQ(first.size(), 22u);
  for (std::size_t k = 2; k < first.size(); ++k) {
    const auto& l = first[k];
    EXPECT_EQ(l.name, "random " + std::to_string(k - 1));
    const double r = l.semi_axes.x();
    EXPECT_GE(r, s.random_lesions.radius_min);
    EXPECT_LE(r, s.random_lesions.radius_max);
    const double depth = 0.05 - l.centre.norm();  // a sphere: depth along the radius
    EXPECT_GE(depth, s.random_lesions.depth_min - 1e-4);
    EXPECT_LE(depth, s.random_lesions.depth_max + 1e-4);
    EXPECT_GE(l.modulus_ratio, s.random_lesions.ratio_min);
    EXPECT_LE(l.modulus_ratio, s.random_lesions.ratio_max);
    EXPECT_GT(l.centre.z() / l.centre.norm(), 0.02 / 0.05 - 1e-3) << "below a vertex of the region";
  }
  EXPECT_EQ(resolve_lesions(s, sphere, upper), first);  // the seed fixes them
  s.random_lesions.seed = 8;
  EXPECT_NE(resolve_lesions(s, sphere, upper), first);
  std::vector<float> none(sphere.vertex_count(), 0.f);
  try {
    resolve_lesions(s, sphere, none);
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(std::string(e.what()), "case.json: /random_lesions/region: no vertex of the organ lies in region \"upper\"");
  }
  EXPECT_THROW(resolve_lesions(s, sphere, {}), std::invalid_argument);
}

}  // namespace
}  // namespace palpa::scenario
