// Inward thickness by ray casting against a bounding-volume hierarchy of the
// triangles, and convex radii of curvature from the vertex normals.

#include "mesh/thickness.h"

#include "core/shared_by_owner.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <thread>
#include <variant>

namespace palpa::mesh {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Barycentric slack of a hit: a ray through a vertex or along an edge must
// not slip between the triangles that share it.
constexpr double kEdgeTolerance = 1e-9;

struct Box {
  Vec3 lo = Vec3::Constant(kInf), hi = Vec3::Constant(-kInf);
  void grow(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void grow(const Box& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
};

// A node holds either two children (count == 0: left child at `first`,
// right child at first + 1) or `count` triangles order[first .. first+count).
struct Node {
  Box box;
  Index first = 0;
  Index count = 0;
};

constexpr Index kLeafSize = 4;

class TriangleBvh {
 public:
  explicit TriangleBvh(const SurfaceMesh& mesh) : mesh_(mesh) {
    const std::size_t n = mesh.triangle_count();
    order_.resize(n);
    std::iota(order_.begin(), order_.end(), Index{0});
    centroids_.resize(n);
    boxes_.resize(n);
    for (std::size_t t = 0; t < n; ++t) {
      const Triangle& tri = mesh.triangles[t];
      for (Index v : tri) boxes_[t].grow(mesh.positions[v]);
      centroids_[t] = (mesh.positions[tri[0]] + mesh.positions[tri[1]] + mesh.positions[tri[2]]) / 3.0;
    }
    if (n == 0) return;
    nodes_.reserve(2 * n / kLeafSize + 2);
    nodes_.push_back({});
    build(0, 0, static_cast<Index>(n));
  }

  // The nearest hit t > 0 of the ray o + t d (d unit) with a triangle not
  // having vertex `skip` as a corner; +inf when none.
  double first_hit(const Vec3& o, const Vec3& d, Index skip) const {
    if (nodes_.empty()) return kInf;
    const Vec3 inv(1.0 / d.x(), 1.0 / d.y(), 1.0 / d.z());
    double best = kInf;
    std::array<Index, 64> stack;
    std::size_t top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[stack[--top]];
      if (!(slab(node.box, o, inv) < best)) continue;
      if (node.count > 0) {
        for (Index k = node.first; k < node.first + node.count; ++k) {
          const Index t = order_[k];
          const Triangle& tri = mesh_.triangles[t];
          if (tri[0] == skip || tri[1] == skip || tri[2] == skip) continue;
          const double h = intersect(tri, o, d);
          if (h < best) best = h;
        }
      } else if (top + 2 <= stack.size()) {
        // Nearer child last, so it is visited first.
        const double a = slab(nodes_[node.first].box, o, inv), b = slab(nodes_[node.first + 1].box, o, inv);
        if (a <= b) {
          stack[top++] = node.first + 1;
          stack[top++] = node.first;
        } else {
          stack[top++] = node.first;
          stack[top++] = node.first + 1;
        }
      }
    }
    return best;
  }

 private:
  void build(Index node_index, Index first, Index count) {
    Box box, cbox;
    for (Index k = first; k < first + count; ++k) {
      box.grow(boxes_[order_[k]]);
      cbox.grow(centroids_[order_[k]]);
    }
    nodes_[node_index].box = box;
    const Vec3 ext = cbox.hi - cbox.lo;
    if (count <= kLeafSize || !(ext.maxCoeff() > 0)) {
      nodes_[node_index].first = first;
      nodes_[node_index].count = count;
      return;
    }
    int axis = 0;
    if (ext.y() > ext[axis]) axis = 1;
    if (ext.z() > ext[axis]) axis = 2;
    const Index half = count / 2;
    std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                     [&](Index a, Index b) {
                       const double ca = centroids_[a][axis], cb = centroids_[b][axis];
                       return ca < cb || (ca == cb && a < b);
                     });
    const Index left = static_cast<Index>(nodes_.size());
    nodes_.push_back({});
    nodes_.push_back({});
    nodes_[node_index].first = left;
    nodes_[node_index].count = 0;
    build(left, first, half);
    build(left + 1, first + half, count - half);
  }

  // Entry distance of the ray into the box (0 when it starts inside); +inf on a miss.
  static double slab(const Box& b, const Vec3& o, const Vec3& inv) {
    double t0 = 0, t1 = kInf;
    for (int k = 0; k < 3; ++k) {
      if (std::isinf(inv[k])) {
        // The ray is parallel to this slab: inside it or a miss.
        if (o[k] < b.lo[k] || o[k] > b.hi[k]) return kInf;
        continue;
      }
      double a = (b.lo[k] - o[k]) * inv[k], c = (b.hi[k] - o[k]) * inv[k];
      if (a > c) std::swap(a, c);
      if (a > t0) t0 = a;
      if (c < t1) t1 = c;
    }
    return t0 <= t1 ? t0 : kInf;
  }

  // Moller-Trumbore: distance t > 0 along d to the triangle, +inf on a miss.
  double intersect(const Triangle& tri, const Vec3& o, const Vec3& d) const {
    const Vec3& a = mesh_.positions[tri[0]];
    const Vec3 e1 = mesh_.positions[tri[1]] - a, e2 = mesh_.positions[tri[2]] - a;
    const Vec3 q = d.cross(e2);
    const double det = e1.dot(q);
    if (!(std::abs(det) > 0)) return kInf;
    const Vec3 s = o - a;
    const double u = s.dot(q) / det;
    if (u < -kEdgeTolerance || u > 1 + kEdgeTolerance) return kInf;
    const Vec3 r = s.cross(e1);
    const double v = d.dot(r) / det;
    if (v < -kEdgeTolerance || u + v > 1 + kEdgeTolerance) return kInf;
    const double t = e2.dot(r) / det;
    return t > 0 ? t : kInf;
  }

  const SurfaceMesh& mesh_;
  std::vector<Index> order_;
  std::vector<Vec3> centroids_;
  std::vector<Box> boxes_;
  std::vector<Node> nodes_;
};

}  // namespace

std::vector<double> inward_thickness(const SurfaceMesh& mesh) {
  const std::size_t n = mesh.vertex_count();
  std::vector<double> out(n, kInf);
  if (mesh.normals.size() != n) return out;
  const TriangleBvh bvh(mesh);
  // Each vertex's ray on its own: blocks of vertices on a few threads (the
  // result does not depend on how they are shared out).
  auto cast = [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Vec3& nrm = mesh.normals[i];
      const double len = nrm.norm();
      if (!(len > 0) || !std::isfinite(len)) continue;
      out[i] = bvh.first_hit(mesh.positions[i], -nrm / len, static_cast<Index>(i));
    }
  };
  const std::size_t threads =
      n < 20000 ? 1 : std::clamp<std::size_t>(std::thread::hardware_concurrency(), 1, 8);
  std::vector<std::thread> pool;
  const std::size_t block = (n + threads - 1) / threads;
  for (std::size_t k = 1; k < threads; ++k)
    pool.emplace_back(cast, std::min(n, k * block), std::min(n, (k + 1) * block));
  cast(0, std::min(n, block));
  for (std::thread& t : pool) t.join();
  return out;
}

std::vector<double> convex_radius(const SurfaceMesh& mesh) {
  const std::size_t n = mesh.vertex_count();
  std::vector<double> out(n, kInf);
  if (mesh.normals.size() != n || mesh.vertex_neighbors.rows() != n) return out;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& pi = mesh.positions[i];
    const Vec3& ni = mesh.normals[i];
    double r = kInf;
    for (Index j : mesh.vertex_neighbors.row(static_cast<Index>(i))) {
      const Vec3 dp = mesh.positions[j] - pi, dn = mesh.normals[j] - ni;
      if (!(dn.dot(dp) > 0)) continue;  // not converging inwards (flat or concave)
      const double dn_len = dn.norm();
      if (dn_len > 0) r = std::min(r, dp.norm() / dn_len);
    }
    out[i] = r;
  }
  return out;
}

std::shared_ptr<const std::vector<double>> shared_inward_thickness(const std::shared_ptr<const SurfaceMesh>& mesh) {
  // Construction time only (never on the haptic thread): a lock is fine.
  static SharedByOwner<SurfaceMesh, std::vector<double>, std::monostate> cache;
  return cache.get(mesh, {}, [&] { return inward_thickness(*mesh); });
}

}  // namespace palpa::mesh
