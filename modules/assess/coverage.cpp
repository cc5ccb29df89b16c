// Pressure levels and coverage (coverage.h).

#include "assess/coverage.h"

#include "mesh/thickness.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace palpa::assess {

const char* level_name(Level l) {
  switch (l) {
    case Level::None: return "none";
    case Level::Light: return "light";
    case Level::Medium: return "medium";
    case Level::Deep: return "deep";
  }
  return "none";
}

Level level_of(double depth, double thickness, bool in_contact) {
  if (!in_contact || !(depth > 0)) return Level::None;
  if (!(thickness > 0) || !std::isfinite(thickness)) return Level::Light;
  const double f = depth / thickness;
  return f < kMediumFraction ? Level::Light : f < kDeepFraction ? Level::Medium : Level::Deep;
}

Coverage::Coverage(std::shared_ptr<const mesh::SurfaceMesh> mesh, double tip_radius,
                   std::shared_ptr<const collision::VertexTree> tree)
    : mesh_(std::move(mesh)), tree_(std::move(tree)), tip_radius_(tip_radius) {
  const std::size_t n = mesh_->vertex_count();
  if (!tree_) tree_ = std::make_shared<collision::VertexTree>(std::span<const Vec3>(mesh_->positions));
  thickness_ = mesh::shared_inward_thickness(mesh_);
  area_.assign(n, 0.0);
  for (const auto& t : mesh_->triangles) {
    const double a = 0.5 * (mesh_->positions[t[1]] - mesh_->positions[t[0]])
                               .cross(mesh_->positions[t[2]] - mesh_->positions[t[0]])
                               .norm();
    for (Index v : t) area_[v] += a / 3.0;
  }
  highest_.assign(n, Level::None);
  peak_force_.assign(n, 0.0);
  mask_.assign(n, 0);
  episodes_.assign(n, 0);
  last_episode_.assign(n, ~0u);
  seen_.assign(n, 0);
}

Index Coverage::nearest(const Vec3& p) const { return tree_->nearest(p).vertex; }

Level Coverage::level_at(const Vec3& point, double depth) const {
  return level_of(depth, (*thickness_)[nearest(point)], true);
}

Level Coverage::add(const Vec3& point, double depth, std::uint32_t episode, double force) {
  const Index start = nearest(point);
  const Level level = level_of(depth, (*thickness_)[start], true);
  if (level == Level::None) return level;
  const double a = std::sqrt(tip_radius_ * depth);  // Hertz contact radius, m
  const Vec3 n = mesh_->normals[start];
  // Breadth-first over the one-ring from the nearest vertex, within a of the
  // point, on vertices facing the contact's side.
  if (++stamp_ == 0) {
    std::fill(seen_.begin(), seen_.end(), 0);
    stamp_ = 1;
  }
  queue_.clear();
  queue_.push_back(start);
  seen_[start] = stamp_;
  const auto& csr = mesh_->vertex_neighbors;
  for (std::size_t q = 0; q < queue_.size(); ++q) {
    const Index v = queue_[q];
    const bool inside = v == start || ((mesh_->positions[v] - point).norm() <= a && mesh_->normals[v].dot(n) > 0);
    if (!inside && v != start) continue;
    if (inside) {
      mask_[v] |= static_cast<std::uint8_t>(1u << static_cast<int>(level));
      highest_[v] = std::max(highest_[v], level);
      peak_force_[v] = std::max(peak_force_[v], force);
      if (last_episode_[v] != episode) {
        last_episode_[v] = episode;
        if (episodes_[v] < 255) ++episodes_[v];
      }
    }
    for (Index w : csr.row(v))
      if (seen_[w] != stamp_) {
        seen_[w] = stamp_;
        queue_.push_back(w);
      }
  }
  return level;
}

}  // namespace palpa::assess
