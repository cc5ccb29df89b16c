// Pixel rectangles and the world -> pixel projection.

#include "render/pixel_region.h"

#include <algorithm>
#include <cmath>

namespace palpa::render {

void PixelRect::unite(const PixelRect& o) {
  if (o.empty()) return;
  if (empty()) {
    *this = o;
    return;
  }
  x0 = std::min(x0, o.x0);
  y0 = std::min(y0, o.y0);
  x1 = std::max(x1, o.x1);
  y1 = std::max(y1, o.y1);
}

PixelProjection::PixelProjection(const Eigen::Matrix4d& world_to_clip, int width, int height)
    : m_(world_to_clip), width_(width), height_(height) {}

bool PixelProjection::project(const Vec3& p, double& x, double& y) const {
  const Eigen::Vector4d c = m_ * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
  if (!(c.w() > 0) || !std::isfinite(c.x()) || !std::isfinite(c.y())) return false;
  x = (c.x() / c.w() + 1.0) * 0.5 * width_;
  y = (c.y() / c.w() + 1.0) * 0.5 * height_;
  return true;
}

void PixelProjection::Cover::add(const Vec3& p) {
  if (whole_) return;
  double x = 0, y = 0;
  if (!proj_->project(p, x, y)) {
    whole_ = true;
    return;
  }
  if (x0_ > x1_) {
    x0_ = x1_ = x;
    y0_ = y1_ = y;
    return;
  }
  x0_ = std::min(x0_, x);
  x1_ = std::max(x1_, x);
  y0_ = std::min(y0_, y);
  y1_ = std::max(y1_, y);
}

void PixelProjection::Cover::add_box(const std::array<double, 6>& b) {
  if (b[0] > b[1] || b[2] > b[3] || b[4] > b[5]) return;
  for (int k = 0; k < 8; ++k) add(Vec3(b[(k & 1) ? 1 : 0], b[(k & 2) ? 3 : 2], b[(k & 4) ? 5 : 4]));
}

PixelRect PixelProjection::Cover::rect(int margin) const {
  const int w = proj_->width(), h = proj_->height();
  if (whole_) return {0, 0, w, h};
  if (x0_ > x1_) return {};
  // A fragment belongs to a triangle when its pixel's centre does, so a
  // triangle's pixels lie in the box of its corners' projections; the
  // margin takes in the last bits the GPU's float arithmetic may differ by.
  auto clampd = [](double v, int hi) { return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(hi))); };
  return {clampd(std::floor(x0_) - margin, w), clampd(std::floor(y0_) - margin, h),
          clampd(std::floor(x1_) + 1 + margin, w), clampd(std::floor(y1_) + 1 + margin, h)};
}

}  // namespace palpa::render
