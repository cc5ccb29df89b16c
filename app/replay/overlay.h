#pragma once
// What palpa-replay draws on a frame and palpa-assess on its report
// (OpenCV, BGR images): the force-time strip with the pressure bands, the
// timeline, the probes' levels, and the coverage map (the organ's vertices
// seen along the camera's direction, coloured by the highest level at
// which each was covered).

#include "assess/coverage.h"
#include "core/types.h"
#include "mesh/surface_mesh.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <deque>
#include <string>
#include <utility>
#include <vector>

namespace palpa::app {

/// Colour (BGR) of probe j's curve, and of each pressure level.
cv::Scalar probe_colour(std::size_t j);
cv::Scalar level_colour(assess::Level l);

/// The force-time strip in `area` of `img`: |F| (N) of each probe over the
/// last `span` s before `now` (s), the bands of a quarter, half and all of
/// the force limit (N; 0: none) shaded, the limit drawn.
void draw_force_strip(cv::Mat& img, const cv::Rect& area, const std::vector<std::deque<std::pair<double, double>>>& force,
                      double now, double span, double limit);

/// The timeline in `area`: the session from 0 to `duration` (s), the
/// replayed window `from` .. `to` (s), `now` (s), the snapshots, the marks
/// and the times over the limit (s).
void draw_timeline(cv::Mat& img, const cv::Rect& area, double now, double duration, double from, double to,
                   const std::vector<double>& snapshots, const std::vector<double>& marks,
                   const std::vector<std::pair<double, double>>& over_limit);

/// Lines of text top left, on a dark band.
void draw_text_block(cv::Mat& img, const std::vector<std::string>& lines, cv::Point at, double scale = 0.55);

/// The coverage map (size x size pixels, BGR): vertices projected along
/// `view_dir` (from the organ towards the eye) with `up` upwards, the
/// nearest drawn last, grey when never covered. The projection is made once.
class CoverageMap {
 public:
  CoverageMap(const mesh::SurfaceMesh& mesh, const Vec3& view_dir, const Vec3& up, int size);
  /// The whole map, drawn afresh.
  cv::Mat draw(const assess::Coverage& coverage) const;
  /// Brings image() up to `coverage`, redrawing only the tiles of the map
  /// where a vertex's level changed since the last update (the first draws
  /// all): the same pixels as draw(). False when nothing changed.
  bool update(const assess::Coverage& coverage);
  /// The map as the last update() left it (empty before the first).
  const cv::Mat& image() const { return image_; }

 private:
  struct Dot {
    Index vertex;
    cv::Point at;
    double shade;
  };
  void draw_dot(cv::Mat& img, const Dot& d, assess::Level level, cv::Point origin) const;
  // The first and last tile (along either axis) a dot centred at pixel v touches.
  std::pair<int, int> tile_span(int v) const;
  std::vector<Dot> dots_;  // back to front
  int size_, radius_;
  // update(): the image, each dot's level in it, and per tile of kTile x
  // kTile pixels the dots that touch it, in drawing order.
  static constexpr int kTile = 16;
  int tiles_ = 0;  // per side
  cv::Mat image_;
  std::vector<assess::Level> drawn_;
  std::vector<std::uint32_t> tile_offsets_, tile_dots_;
  std::vector<std::uint8_t> tile_dirty_;
};

/// CoverageMap(...).draw(coverage), once.
cv::Mat coverage_map(const assess::Coverage& coverage, const Vec3& view_dir, const Vec3& up, int size);

}  // namespace palpa::app
