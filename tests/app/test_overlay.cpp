// The replay's overlays (app/replay/overlay.h): the coverage map brought up
// to date tile by tile gives the pixels of a map drawn afresh.

#include "app/replay/overlay.h"

#include "assess/coverage.h"
#include "mesh/generate.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <memory>
#include <random>

namespace palpa::app {
namespace {

TEST(CoverageMap, UpdatedTileByTileItIsTheMapDrawnAfresh) {
  const auto mesh = std::make_shared<const mesh::SurfaceMesh>(mesh::make_organ(5000));
  assess::Coverage coverage(mesh, 0.004);
  const Vec3 view_dir = Vec3(0, -std::sin(0.61), std::cos(0.61)).normalized();
  CoverageMap map(*mesh, view_dir, Vec3::UnitZ(), 240);
  ASSERT_TRUE(map.update(coverage));  // the first draws everything
  EXPECT_EQ(cv::norm(map.image(), map.draw(coverage), cv::NORM_INF), 0.0);
  EXPECT_FALSE(map.update(coverage));  // nothing changed

  std::mt19937 rng(11);
  std::uniform_int_distribution<std::size_t> vertex(0, mesh->vertex_count() - 1);
  std::uniform_real_distribution<double> depth(0.0005, 0.02);
  int changed = 0;
  for (int round = 0; round < 40; ++round) {
    const cv::Mat before = map.image().clone();
    // A few contacts anywhere, each its own episode, at random depths.
    for (int k = 0; k < 3; ++k)
      coverage.add(mesh->positions[vertex(rng)], depth(rng), static_cast<std::uint32_t>(3 * round + k));
    const bool updated = map.update(coverage);
    const cv::Mat fresh = map.draw(coverage);
    ASSERT_EQ(cv::norm(map.image(), fresh, cv::NORM_INF), 0.0) << "round " << round;
    // update() says whether the picture could have changed.
    if (cv::norm(before, fresh, cv::NORM_INF) > 0) {
      EXPECT_TRUE(updated) << "round " << round;
    }
    changed += updated;
  }
  EXPECT_GT(changed, 10);  // the rounds did change the map
}

}  // namespace
}  // namespace palpa::app
