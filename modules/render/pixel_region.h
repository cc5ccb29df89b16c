#pragma once
// Rectangles of a frame's pixels and where world points land in a frame:
// what lets a scene redraw only the pixels that changed.

#include "core/types.h"

#include <array>

namespace palpa::render {

/// A rectangle of a frame's pixels: columns [x0, x1) and rows [y0, y1), rows
/// counted from the bottom (VTK's display coordinates). Empty when x1 <= x0
/// or y1 <= y0.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x1 <= x0 || y1 <= y0; }
  /// Grows this rectangle to take in `o` (an empty one changes nothing).
  void unite(const PixelRect& o);
  /// Whether the two share a pixel (never when either is empty).
  bool overlaps(const PixelRect& o) const {
    return !empty() && !o.empty() && x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1;
  }
};

/// Where world points (m) land in a scene's frame, for the camera as it was
/// when made (OffscreenScene::projection()).
class PixelProjection {
 public:
  PixelProjection() = default;
  /// world_to_clip: the camera's composite projection (world -> clip
  /// coordinates), width x height pixels.
  PixelProjection(const Eigen::Matrix4d& world_to_clip, int width, int height);
  /// Pixel coordinates (x, y from the bottom-left corner, continuous) of `p`;
  /// false when p is not in front of the eye.
  bool project(const Vec3& p, double& x, double& y) const;
  /// A box of projected points, padded by `margin` pixels on every side and
  /// clipped to the frame: every pixel a triangle with corners among the
  /// points can cover.
  class Cover {
   public:
    explicit Cover(const PixelProjection& proj) : proj_(&proj) {}
    /// Takes in world point p (m); a point not in front of the eye makes the
    /// cover the whole frame.
    void add(const Vec3& p);
    /// Takes in the 8 corners of an axis-aligned box {xmin, xmax, ...} (m);
    /// an empty box (min > max) adds nothing.
    void add_box(const std::array<double, 6>& b);
    bool whole() const { return whole_; }
    PixelRect rect(int margin) const;

   private:
    const PixelProjection* proj_;
    double x0_ = 1, x1_ = -1, y0_ = 1, y1_ = -1;
    bool whole_ = false;
  };
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  Eigen::Matrix4d m_ = Eigen::Matrix4d::Identity();
  int width_ = 0, height_ = 0;
};

}  // namespace palpa::render
