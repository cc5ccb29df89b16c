// palpa-bench, issue 8: fan and sliver meshes (see the header).

#include "palpa_bench_meshes.h"

#include "mesh/generate.h"

#include <cmath>
#include <map>
#include <numbers>
#include <utility>
#include <vector>

namespace palpa::bench {

namespace {

// Keeps the vertices the triangles use, renumbered in their order, and finalizes.
mesh::SurfaceMesh compact(const std::vector<Vec3>& positions, const std::vector<mesh::Triangle>& triangles) {
  std::vector<Index> remap(positions.size(), kNoIndex);
  mesh::SurfaceMesh out;
  for (const auto& t : triangles)
    for (Index v : t)
      if (remap[v] == kNoIndex) {
        remap[v] = static_cast<Index>(out.positions.size());
        out.positions.push_back(positions[v]);
      }
  // Renumber in the original vertex order (keeps the sphere's locality).
  Index next = 0;
  for (std::size_t v = 0; v < positions.size(); ++v)
    if (remap[v] != kNoIndex) {
      remap[v] = next;
      out.positions[next++] = positions[v];
    }
  out.triangles.reserve(triangles.size());
  for (const auto& t : triangles) out.triangles.push_back({remap[t[0]], remap[t[1]], remap[t[2]]});
  mesh::finalize(out);
  return out;
}

}  // namespace

mesh::SurfaceMesh make_fan_sphere(std::size_t target_vertices, double radius, int fans, double fan_radius) {
  // The disks take about fans * (fan_radius / 2 radius)^2 of the sphere's vertices: start larger.
  const double share = fans * (fan_radius * fan_radius) / (4 * radius * radius);
  const auto start = static_cast<std::size_t>(static_cast<double>(target_vertices) / std::max(0.2, 1 - share));
  const mesh::SurfaceMesh s = mesh::make_sphere(start, radius);
  const std::size_t n = s.vertex_count();
  // Fan centres: the vertices nearest a Fibonacci lattice.
  std::vector<Index> centre(fans);
  for (int f = 0; f < fans; ++f) {
    const double z = 1 - (2.0 * f + 1) / fans, r = std::sqrt(1 - z * z);
    const double phi = f * std::numbers::pi * (3 - std::sqrt(5.0));
    const Vec3 d = radius * Vec3(r * std::cos(phi), r * std::sin(phi), z);
    Index best = 0;
    for (Index v = 1; v < n; ++v)
      if ((s.positions[v] - d).squaredNorm() < (s.positions[best] - d).squaredNorm()) best = v;
    centre[f] = best;
  }
  // Which disk each vertex is in (-1: none).
  std::vector<int> disk(n, -1);
  for (Index v = 0; v < n; ++v)
    for (int f = 0; f < fans; ++f)
      if ((s.positions[v] - s.positions[centre[f]]).norm() < fan_radius) disk[v] = f;
  // Triangles touching a disk go; their edges not shared with another removed
  // triangle are the holes' boundaries, each filled towards its centre.
  std::vector<mesh::Triangle> kept;
  std::map<std::pair<Index, Index>, int> removed_edges;  // directed edge -> disk
  for (const auto& t : s.triangles) {
    int f = -1;
    for (Index v : t)
      if (disk[v] >= 0) f = disk[v];
    if (f < 0) {
      kept.push_back(t);
      continue;
    }
    for (int k = 0; k < 3; ++k) removed_edges[{t[k], t[(k + 1) % 3]}] = f;
  }
  for (const auto& [e, f] : removed_edges) {
    if (removed_edges.count({e.second, e.first})) continue;  // inside the hole
    kept.push_back({e.first, e.second, centre[f]});
  }
  return compact(s.positions, kept);
}

mesh::SurfaceMesh make_sliver_sphere(std::size_t target_vertices, double radius) {
  const mesh::SurfaceMesh s = mesh::make_sphere(target_vertices / 3, radius);
  std::vector<Vec3> positions = s.positions;
  std::vector<mesh::Triangle> triangles;
  triangles.reserve(3 * s.triangle_count());
  for (const auto& t : s.triangles) {
    const Vec3 mid = 0.5 * (s.positions[t[0]] + s.positions[t[1]]);
    const Vec3 p = (mid + 0.02 * (s.positions[t[2]] - mid)).normalized() * radius;
    const auto pi = static_cast<Index>(positions.size());
    positions.push_back(p);
    triangles.push_back({t[0], t[1], pi});
    triangles.push_back({t[1], t[2], pi});
    triangles.push_back({t[2], t[0], pi});
  }
  return compact(positions, triangles);
}

}  // namespace palpa::bench
