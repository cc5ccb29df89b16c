// Frame overlays (overlay.h).

#include "app/replay/overlay.h"

#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace palpa::app {

cv::Scalar probe_colour(std::size_t j) {
  static const cv::Scalar c[] = {{230, 140, 30}, {40, 160, 240}, {200, 60, 200}, {60, 200, 60},
                                 {30, 30, 220},  {200, 200, 40}, {120, 120, 120}, {0, 0, 0}};
  return c[j % 8];
}

cv::Scalar level_colour(assess::Level l) {
  switch (l) {
    case assess::Level::Light: return {90, 200, 90};
    case assess::Level::Medium: return {40, 210, 230};
    case assess::Level::Deep: return {50, 60, 220};
    default: return {170, 170, 170};
  }
}

void draw_force_strip(cv::Mat& img, const cv::Rect& area, const std::vector<std::deque<std::pair<double, double>>>& force,
                      double now, double span, double limit) {
  cv::Mat roi = img(area);
  roi.convertTo(roi, -1, 0.35, 25 * 0.65);  // in place, one pass
  // The scale follows the forces shown (at least a third of the limit, 0.5 N).
  double top = std::max(0.5, limit > 0 ? limit / 3 : 0.0);
  for (const auto& f : force)
    for (const auto& [t, v] : f)
      if (now - t <= span) top = std::max(top, 1.2 * v);
  const auto y_of = [&](double v) { return area.y + area.height - 1 - static_cast<int>((area.height - 2) * v / top); };
  // The curves in quarter pixels (cv::polylines' shift of 2 bits).
  constexpr int kSub = 4;
  const auto sub_point = [&](double t, double v) {
    const double x = area.x + (area.width - 1) * (1.0 - (now - t) / span);
    const double y = area.y + area.height - 1 - (area.height - 2) * v / top;
    return cv::Point(static_cast<int>(std::lround(kSub * x)), static_cast<int>(std::lround(kSub * y)));
  };
  // Pressure bands relative to the task's force limit.
  if (limit > 0) {
    const double edges[] = {0, 0.25 * limit, 0.5 * limit, limit, top};
    const cv::Scalar fill[] = {{60, 90, 60}, {60, 100, 110}, {50, 80, 130}, {50, 50, 120}};
    for (int b = 0; b < 4; ++b) {
      cv::Rect band(area.x, y_of(edges[b + 1]), area.width, std::max(1, y_of(edges[b]) - y_of(edges[b + 1])));
      band &= area;
      if (band.area() <= 0) continue;
      cv::Mat sub = img(band);
      sub.convertTo(sub, -1, 0.6);
      cv::add(sub, fill[b] * 0.4, sub);
    }
    if (limit <= top) {
      cv::line(img, {area.x, y_of(limit)}, {area.x + area.width - 1, y_of(limit)}, {60, 60, 255}, 1, cv::LINE_AA);
      cv::putText(img, cv::format("limit %.1f N", limit), {area.x + area.width / 2, y_of(limit) - 4},
                  cv::FONT_HERSHEY_SIMPLEX, 0.4, {90, 90, 255}, 1, cv::LINE_AA);
    } else {
      cv::putText(img, cv::format("limit %.1f N (above)", limit), {area.x + area.width / 2, area.y + 14},
                  cv::FONT_HERSHEY_SIMPLEX, 0.4, {90, 90, 255}, 1, cv::LINE_AA);
    }
  }
  for (std::size_t j = 0; j < force.size(); ++j) {
    std::vector<cv::Point> pts;
    for (const auto& [t, v] : force[j])
      if (now - t <= span) {
        const cv::Point p = sub_point(t, v);
        if (pts.empty() || p != pts.back()) pts.push_back(p);
      }
    // Two pixels wide: two one-pixel anti-aliased lines half a pixel above
    // and below (a thick anti-aliased polyline costs ten times as much: a
    // filled polygon and two round caps per segment).
    if (pts.size() > 1)
      for (const int dy : {-kSub / 2, kSub / 2}) {
        for (cv::Point& p : pts) p.y += dy;
        cv::polylines(img, pts, false, probe_colour(j), 1, cv::LINE_AA, 2);
        for (cv::Point& p : pts) p.y -= dy;
      }
    if (!force[j].empty())
      cv::putText(img, cv::format("probe %zu  %.2f N", j + 1, force[j].back().second),
                  {area.x + area.width - 150, area.y + 16 + 16 * static_cast<int>(j)}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
                  probe_colour(j), 1, cv::LINE_AA);
  }
  cv::putText(img, cv::format("|F| (N), last %.0f s; top %.1f N", span, top), {area.x + 4, area.y + 14},
              cv::FONT_HERSHEY_SIMPLEX, 0.4, {220, 220, 220}, 1, cv::LINE_AA);
}

void draw_timeline(cv::Mat& img, const cv::Rect& area, double now, double duration, double from, double to,
                   const std::vector<double>& snapshots, const std::vector<double>& marks,
                   const std::vector<std::pair<double, double>>& over_limit) {
  cv::rectangle(img, area, {30, 30, 30}, cv::FILLED);
  const double d = std::max(duration, 1e-9);
  const auto x_of = [&](double t) { return area.x + static_cast<int>((area.width - 1) * std::clamp(t / d, 0.0, 1.0)); };
  const int mid = area.y + area.height / 2;
  cv::rectangle(img, cv::Point(x_of(from), mid - 3), cv::Point(x_of(to), mid + 3), {90, 90, 90}, cv::FILLED);
  cv::rectangle(img, cv::Point(x_of(from), mid - 3), cv::Point(x_of(now), mid + 3), {200, 170, 90}, cv::FILLED);
  for (const auto& [a, b] : over_limit)
    cv::rectangle(img, cv::Point(x_of(a), area.y + 2), cv::Point(std::max(x_of(a) + 1, x_of(b)), area.y + 6),
                  {60, 60, 255}, cv::FILLED);
  for (double s : snapshots) cv::line(img, {x_of(s), mid + 5}, {x_of(s), area.y + area.height - 2}, {150, 150, 150});
  for (double m : marks) {
    const std::vector<cv::Point> tri = {{x_of(m), mid - 5}, {x_of(m) - 5, area.y + 1}, {x_of(m) + 5, area.y + 1}};
    cv::fillConvexPoly(img, tri, {40, 220, 250}, cv::LINE_AA);
  }
  cv::line(img, {x_of(now), area.y}, {x_of(now), area.y + area.height - 1}, {255, 255, 255}, 2);
  cv::putText(img, cv::format("%.1f / %.1f s", now, duration), {area.x + area.width - 120, area.y + area.height - 4},
              cv::FONT_HERSHEY_SIMPLEX, 0.4, {230, 230, 230}, 1, cv::LINE_AA);
}

void draw_text_block(cv::Mat& img, const std::vector<std::string>& lines, cv::Point at, double scale) {
  if (lines.empty()) return;
  const int lh = static_cast<int>(26 * scale / 0.55);
  int w = 0;
  for (const auto& l : lines) {
    int base = 0;
    w = std::max(w, cv::getTextSize(l, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &base).width);
  }
  cv::Rect r(at.x - 6, at.y - lh + 4, w + 12, lh * static_cast<int>(lines.size()) + 6);
  r &= cv::Rect(0, 0, img.cols, img.rows);
  if (r.area() <= 0) return;
  cv::Mat sub = img(r);
  sub = sub * 0.4;
  for (std::size_t k = 0; k < lines.size(); ++k)
    cv::putText(img, lines[k], {at.x, at.y + lh * static_cast<int>(k)}, cv::FONT_HERSHEY_SIMPLEX, scale,
                {240, 240, 240}, 1, cv::LINE_AA);
}

cv::Mat coverage_map(const assess::Coverage& coverage, const Vec3& view_dir, const Vec3& up, int size) {
  return CoverageMap(coverage.mesh(), view_dir, up, size).draw(coverage);
}

namespace {
const cv::Scalar kMapBackground(40, 40, 40);
}

void CoverageMap::draw_dot(cv::Mat& img, const Dot& d, assess::Level level, cv::Point origin) const {
  cv::circle(img, d.at - origin, radius_, level_colour(level) * d.shade, cv::FILLED);
}

cv::Mat CoverageMap::draw(const assess::Coverage& coverage) const {
  cv::Mat img(size_, size_, CV_8UC3, kMapBackground);
  for (const Dot& d : dots_) draw_dot(img, d, coverage.highest()[d.vertex], {0, 0});
  return img;
}

std::pair<int, int> CoverageMap::tile_span(int v) const {
  // A filled circle (no anti-aliasing) stays within radius_ of its centre.
  return {std::clamp((v - radius_) / kTile, 0, tiles_ - 1), std::clamp((v + radius_) / kTile, 0, tiles_ - 1)};
}

bool CoverageMap::update(const assess::Coverage& coverage) {
  const auto& level = coverage.highest();
  if (image_.empty()) {
    image_ = draw(coverage);
    drawn_.resize(dots_.size());
    for (std::size_t k = 0; k < dots_.size(); ++k) drawn_[k] = level[dots_[k].vertex];
    return true;
  }
  // The tiles a changed dot touches.
  bool changed = false;
  for (std::size_t k = 0; k < dots_.size(); ++k) {
    const assess::Level now = level[dots_[k].vertex];
    if (now == drawn_[k]) continue;
    drawn_[k] = now;
    changed = true;
    const auto [x0, x1] = tile_span(dots_[k].at.x);
    const auto [y0, y1] = tile_span(dots_[k].at.y);
    for (int ty = y0; ty <= y1; ++ty)
      for (int tx = x0; tx <= x1; ++tx) tile_dirty_[ty * tiles_ + tx] = 1;
  }
  if (!changed) return false;
  // Each dirty tile afresh: background, then every dot touching it in order,
  // drawn into the tile alone (integer offsets: the pixels draw() gives).
  for (int t = 0; t < tiles_ * tiles_; ++t) {
    if (!tile_dirty_[t]) continue;
    tile_dirty_[t] = 0;
    const cv::Rect r = cv::Rect((t % tiles_) * kTile, (t / tiles_) * kTile, kTile, kTile) & cv::Rect(0, 0, size_, size_);
    if (r.area() <= 0) continue;
    cv::Mat tile = image_(r);
    tile.setTo(kMapBackground);
    for (std::uint32_t q = tile_offsets_[t]; q < tile_offsets_[t + 1]; ++q) {
      const std::uint32_t k = tile_dots_[q];
      draw_dot(tile, dots_[k], drawn_[k], r.tl());
    }
  }
  return true;
}

CoverageMap::CoverageMap(const mesh::SurfaceMesh& m, const Vec3& view_dir, const Vec3& up, int size)
    : size_(size), radius_(std::max(1, size / 160)) {
  const Vec3 w = view_dir.normalized();
  const Vec3 u = up.cross(w).normalized();
  const Vec3 v = w.cross(u);
  double umin = 1e300, umax = -1e300, vmin = 1e300, vmax = -1e300;
  for (const Vec3& p : m.positions) {
    umin = std::min(umin, p.dot(u));
    umax = std::max(umax, p.dot(u));
    vmin = std::min(vmin, p.dot(v));
    vmax = std::max(vmax, p.dot(v));
  }
  const double ext = std::max(umax - umin, vmax - vmin) * 1.05;
  const double cu = 0.5 * (umin + umax), cv_ = 0.5 * (vmin + vmax);
  // Back to front, only vertices facing the eye.
  std::vector<Index> order(m.vertex_count());
  std::iota(order.begin(), order.end(), Index{0});
  std::sort(order.begin(), order.end(), [&](Index a, Index b) { return m.positions[a].dot(w) < m.positions[b].dot(w); });
  for (Index i : order) {
    if (m.normals[i].dot(w) <= 0) continue;
    const Vec3& p = m.positions[i];
    const int x = static_cast<int>(size * (0.5 + (p.dot(u) - cu) / ext));
    const int y = static_cast<int>(size * (0.5 - (p.dot(v) - cv_) / ext));
    dots_.push_back({i, {x, y}, 0.55 + 0.45 * m.normals[i].dot(w)});
  }
  // Which dots touch which tile (for update()), in drawing order.
  tiles_ = (size_ + kTile - 1) / kTile;
  tile_offsets_.assign(static_cast<std::size_t>(tiles_) * tiles_ + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<std::uint32_t> fill(tile_offsets_.begin(), tile_offsets_.end() - 1);
    for (std::size_t k = 0; k < dots_.size(); ++k) {
      const auto [x0, x1] = tile_span(dots_[k].at.x);
      const auto [y0, y1] = tile_span(dots_[k].at.y);
      for (int ty = y0; ty <= y1; ++ty)
        for (int tx = x0; tx <= x1; ++tx) {
          const std::size_t t = static_cast<std::size_t>(ty) * tiles_ + tx;
          if (pass == 0)
            ++tile_offsets_[t + 1];
          else
            tile_dots_[fill[t]++] = static_cast<std::uint32_t>(k);
        }
    }
    if (pass == 0) {
      std::partial_sum(tile_offsets_.begin(), tile_offsets_.end(), tile_offsets_.begin());
      tile_dots_.resize(tile_offsets_.back());
    }
  }
  tile_dirty_.assign(static_cast<std::size_t>(tiles_) * tiles_, 0);
}

}  // namespace palpa::app
