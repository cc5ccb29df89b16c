// prep::prepare_cached: a second call with the same bytes and parameters is a
// hit that gives the same mesh; other bytes or parameters are a miss.

#include "prep/prep.h"

#include "common/test_support.h"
#include "mesh/generate.h"
#include "mesh/io.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

namespace palpa::prep {
namespace {

TEST(PrepCache, SecondCallIsAHitWithTheSameMesh) {
  const auto dir = test::temp_dir("prep_cache");
  const auto cache = dir / "cache";
  const auto file = dir / "sphere.ply";
  mesh::save_mesh(mesh::make_sphere(600, 0.03), file);
  PrepOptions o;
  o.unit_m = 1.0;
  o.edge_m = 0.004;
  o.fit_rounds = 0;

  PrepReport first, second;
  const mesh::SurfaceMesh a = prepare_cached(file, o, &first, cache);
  EXPECT_FALSE(first.from_cache);
  EXPECT_EQ(first.cache_key.size(), 32u);
  EXPECT_TRUE(std::filesystem::exists(cache / (first.cache_key + ".ply")));
  EXPECT_TRUE(std::filesystem::exists(cache / (first.cache_key + ".json")));

  const mesh::SurfaceMesh b = prepare_cached(file, o, &second, cache);
  EXPECT_TRUE(second.from_cache);
  EXPECT_EQ(second.cache_key, first.cache_key);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(second.after.triangles, first.after.triangles);
  EXPECT_DOUBLE_EQ(second.hausdorff_m, first.hausdorff_m);

  // Other parameters: another key, a miss.
  PrepOptions other = o;
  other.edge_m = 0.005;
  EXPECT_NE(cache_key(file, other), first.cache_key);
  PrepReport third;
  prepare_cached(file, other, &third, cache);
  EXPECT_FALSE(third.from_cache);

  // Other bytes under the same name: a miss.
  mesh::save_mesh(mesh::make_sphere(600, 0.031), file);
  EXPECT_NE(cache_key(file, o), first.cache_key);
  PrepReport fourth;
  prepare_cached(file, o, &fourth, cache);
  EXPECT_FALSE(fourth.from_cache);

  // A damaged entry is prepared again.
  std::ofstream(cache / (fourth.cache_key + ".json")) << "not json";
  PrepReport fifth;
  prepare_cached(file, o, &fifth, cache);
  EXPECT_FALSE(fifth.from_cache);
}

TEST(PrepCache, DefaultFolderFollowsTheEnvironment) {
  const char* old_p = std::getenv("PALPA_PREP_CACHE");
  const char* old_x = std::getenv("XDG_CACHE_HOME");
  const std::string keep_p = old_p ? old_p : "", keep_x = old_x ? old_x : "";
  ::unsetenv("PALPA_PREP_CACHE");
  ::setenv("XDG_CACHE_HOME", "/tmp/xdg", 1);
  EXPECT_EQ(default_cache_dir(), std::filesystem::path("/tmp/xdg/palpa/prep"));
  ::setenv("PALPA_PREP_CACHE", "/tmp/prepcache", 1);
  EXPECT_EQ(default_cache_dir(), std::filesystem::path("/tmp/prepcache"));
  if (old_p) ::setenv("PALPA_PREP_CACHE", keep_p.c_str(), 1); else ::unsetenv("PALPA_PREP_CACHE");
  if (old_x) ::setenv("XDG_CACHE_HOME", keep_x.c_str(), 1); else ::unsetenv("XDG_CACHE_HOME");
}

}  // namespace
}  // namespace palpa::prep
