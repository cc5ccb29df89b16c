// The vertex AABB tree of section V.A: median-split build, branch-and-bound
// nearest vertex, and the local search that resumes from the last leaf.

#include "collision/vertex_tree.h"

#include "core/huge_pages.h"

#include "mesh/surface_mesh.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace palpa::collision {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Squared distance between a query and a point, always written the same way
// so that every path (tree, brute force) rounds identically.
inline double dist2(const double q[3], const Vec3& p) {
  const double dx = p.x() - q[0];
  const double dy = p.y() - q[1];
  const double dz = p.z() - q[2];
  return dx * dx + dy * dy + dz * dz;
}

// Largest float <= x and smallest float >= x (boxes are rounded outward;
// beyond the float range they open to infinity).
inline float float_down(double x) {
  constexpr float kMax = std::numeric_limits<float>::max();
  if (x > kMax) return kMax;
  if (x < -kMax) return -std::numeric_limits<float>::infinity();
  float f = static_cast<float>(x);
  if (static_cast<double>(f) > x) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
inline float float_up(double x) {
  constexpr float kMax = std::numeric_limits<float>::max();
  if (x > kMax) return std::numeric_limits<float>::infinity();
  if (x < -kMax) return -kMax;
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

// Sort key of a coordinate: NaN sorts last, so the median split stays a
// strict weak ordering even for bad input (such vertices are never returned).
inline double split_key(double x) { return x == x ? x : kInf; }

}  // namespace

NearestVertex nearest_brute_force(std::span<const Vec3> positions, const Vec3& query) {
  // Test every vertex; the first of equally near vertices wins.
  const double q[3] = {query.x(), query.y(), query.z()};
  NearestVertex best{kNoIndex, kInf};
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const double d = dist2(q, positions[i]);
    if (d < best.distance_sq) best = {static_cast<Index>(i), d};
  }
  return best;
}

VertexTree::VertexTree(std::span<const Vec3> positions, int leaf_size) {
  leaf_size_ = std::max(1, leaf_size);
  const std::size_t n = positions.size();
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), Index{0});
  if (n == 0) return;

  // Recursive median split; nodes come out in depth-first pre-order.
  nodes_.reserve(4 * (n / static_cast<std::size_t>(leaf_size_) + 1));
  build_node(positions, 0, static_cast<Index>(n), kNoIndex, 0);

  // Points in tree order, and the leaf that holds each tree position.
  points_.resize(n);
  for (std::size_t i = 0; i < n; ++i) points_[i] = positions[order_[i]];
  leaf_of_.assign(n, kNoIndex);
  for (Index k = 0; k < nodes_.size(); ++k) {
    const Node& nd = nodes_[k];
    if (nd.left != kNoIndex) continue;
    for (Index i = nd.begin; i < nd.end; ++i) leaf_of_[i] = k;
  }
  core::prefer_huge_pages(order_);
  core::prefer_huge_pages(points_);
  core::prefer_huge_pages(leaf_of_);
  core::prefer_huge_pages(nodes_);
}

double triangle_reach(const Vec3& a, const Vec3& b, const Vec3& c) {
  // The farthest point is a vertex of the corners' Voronoi diagram cut by
  // the triangle: the circumcentre when it lies in the triangle, else where
  // a short edge's perpendicular bisector meets the longest edge,
  // |ac|^2 |ab| / (|ab|^2 + |ac|^2 - |bc|^2) from the end a they share.
  const double ab = (b - a).squaredNorm(), bc = (c - b).squaredNorm(), ca = (a - c).squaredNorm();
  if (!std::isfinite(ab + bc + ca)) return std::numeric_limits<double>::quiet_NaN();
  const double twice_area = (b - a).cross(c - a).norm();
  const double longest = std::max({ab, bc, ca});
  if (2 * longest <= ab + bc + ca && twice_area > 0) return std::sqrt(ab * bc * ca) / (2 * twice_area);
  // The two other edges' squared lengths, from each end of the longest.
  double s1 = ca, s2 = bc;                   // longest ab: from a, from b
  if (longest == bc) s1 = ab, s2 = ca;       // longest bc: from b, from c
  else if (longest == ca) s1 = bc, s2 = ab;  // longest ca: from c, from a
  const double root = std::sqrt(longest);
  double reach = 0;
  if (longest + s1 - s2 > 0) reach = std::max(reach, s1 * root / (longest + s1 - s2));
  if (longest + s2 - s1 > 0) reach = std::max(reach, s2 * root / (longest + s2 - s1));
  return reach;
}

VertexTree::VertexTree(const mesh::SurfaceMesh& mesh, int leaf_size)
    : VertexTree(std::span<const Vec3>(mesh.positions), leaf_size) {
  const std::size_t n = mesh.vertex_count();
  std::vector<double> reach(n, 0.0);
  for (const mesh::Triangle& t : mesh.triangles) {
    if (t[0] >= n || t[1] >= n || t[2] >= n) return;  // not a mesh: no bound
    const double r = triangle_reach(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]);
    if (!std::isfinite(r)) return;  // a non-finite corner: no bound
    for (Index v : t) reach[v] = std::max(reach[v], r);
  }
  for (const Vec3& p : mesh.positions)
    if (!p.allFinite()) return;
  point_reach_.resize(n);
  for (std::size_t i = 0; i < n; ++i) point_reach_[i] = float_up(reach[order_[i]]);
  // Nodes come in pre-order, so each node's children follow it: fill from
  // the back (a leaf from its points, an inner node from its children).
  node_reach_.assign(nodes_.size(), 0.0f);
  for (std::size_t k = nodes_.size(); k-- > 0;) {
    const Node& nd = nodes_[k];
    float r = 0;
    if (nd.left == kNoIndex) {
      for (Index i = nd.begin; i < nd.end; ++i) r = std::max(r, point_reach_[i]);
    } else {
      r = std::max(node_reach_[nd.left], node_reach_[nd.right]);
    }
    node_reach_[k] = r;
  }
  core::prefer_huge_pages(point_reach_);
  core::prefer_huge_pages(node_reach_);
}

Index VertexTree::build_node(std::span<const Vec3> positions, Index begin, Index end, Index parent,
                             int depth) {
  // Tight box of the node's vertices (double), rounded outward to float.
  Vec3 lo = Vec3::Constant(kInf), hi = Vec3::Constant(-kInf);
  for (Index i = begin; i < end; ++i) {
    lo = lo.cwiseMin(positions[order_[i]]);
    hi = hi.cwiseMax(positions[order_[i]]);
  }
  const Index self = static_cast<Index>(nodes_.size());
  Node node{};
  for (int k = 0; k < 3; ++k) {
    node.lo[k] = float_down(lo[k]);
    node.hi[k] = float_up(hi[k]);
  }
  node.parent = parent;
  node.left = node.right = kNoIndex;
  node.begin = begin;
  node.end = end;
  nodes_.push_back(node);
  depth_ = std::max(depth_, depth);
  if (end - begin <= static_cast<Index>(leaf_size_)) return self;

  // Split at the median of the longest axis: the left half lies on or below
  // the split plane, the right half on or above it.
  int axis = 0;
  const Vec3 ext = hi - lo;
  if (ext[1] > ext[axis]) axis = 1;
  if (ext[2] > ext[axis]) axis = 2;
  const Index mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](Index a, Index b) { return split_key(positions[a][axis]) < split_key(positions[b][axis]); });

  const Index left = build_node(positions, begin, mid, self, depth + 1);
  const Index right = build_node(positions, mid, end, self, depth + 1);
  nodes_[self].left = left;
  nodes_[self].right = right;
  return self;
}

int VertexTree::depth() const { return depth_; }

namespace {

// Squared distance from q to a box (0 inside). Each axis term is a monotone
// function of the same differences dist2 uses, so it never exceeds the
// computed distance of a vertex inside the box. Per axis at most one of the
// two gaps (lo - q, q - hi) is positive since lo <= hi.
template <class NodeT>
inline double box_dist2(const NodeT& n, const double q[3]) {
#if defined(__SSE2__)
  // x and y in one register, z in another; maxpd keeps this branch free
  // (the hot loop of every query). Same operations and order as below.
  const __m128d zero = _mm_setzero_pd();
  const __m128d qxy = _mm_loadu_pd(q);
  const __m128d qz = _mm_load_sd(q + 2);
  const __m128d lo_xy = _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(n.lo))));
  const __m128d hi_xy = _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(n.hi))));
  const __m128d lo_z = _mm_cvtss_sd(zero, _mm_load_ss(n.lo + 2));
  const __m128d hi_z = _mm_cvtss_sd(zero, _mm_load_ss(n.hi + 2));
  const __m128d exy = _mm_add_pd(_mm_max_pd(_mm_sub_pd(lo_xy, qxy), zero), _mm_max_pd(_mm_sub_pd(qxy, hi_xy), zero));
  const __m128d ez = _mm_add_sd(_mm_max_sd(_mm_sub_sd(lo_z, qz), zero), _mm_max_sd(_mm_sub_sd(qz, hi_z), zero));
  const __m128d sxy = _mm_mul_pd(exy, exy);
  const __m128d sz = _mm_mul_sd(ez, ez);
  return _mm_cvtsd_f64(_mm_add_sd(_mm_add_sd(sxy, _mm_unpackhi_pd(sxy, sxy)), sz));
#else
  double e[3];
  for (int k = 0; k < 3; ++k)
    e[k] = std::max(n.lo[k] - q[k], 0.0) + std::max(q[k] - n.hi[k], 0.0);
  return e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
#endif
}

// True when the ball of squared radius r2 around q lies strictly inside the
// box, with margins that cover the float rounding of the box and the double
// rounding of the test, so no vertex outside the box can be nearer.
template <class NodeT>
inline bool contains_ball(const NodeT& n, const double q[3], double r2) {
  const double r = std::sqrt(r2) * (1 + 1e-12);
  for (int k = 0; k < 3; ++k) {
    const double lo = n.lo[k], hi = n.hi[k];
    const double margin = (std::abs(lo) + std::abs(hi)) * 0x1p-22 + (std::abs(q[k]) + r) * 1e-15 + 1e-30;
    if (!(q[k] - r - lo > margin) || !(hi - q[k] - r > margin)) return false;
  }
  return true;
}

}  // namespace

template <class Bound, class Scan>
void VertexTree::branch_and_bound(Index root, double& best, Bound bound, Scan scan) const {
  // Depth-first with an explicit stack of (node, bound): nearer child first,
  // nodes whose bound is no less than the best are pruned.
  struct Entry {
    Index node;
    double bound;
  };
  std::array<Entry, kMaxDepth + 2> stack;
  int top = 0;
  stack[top++] = {root, bound(nodes_[root])};
  while (top > 0) {
    const Entry e = stack[--top];
    if (e.bound >= best) continue;
    const Node* n = &nodes_[e.node];
    // Descend to a leaf, pushing the farther child of each inner node when it
    // may still hold a better vertex (selects written to avoid branches).
    while (n->left != kNoIndex) {
      const double bl = bound(nodes_[n->left]);
      const double br = bound(nodes_[n->right]);
      const bool right_first = br < bl;
      const Index near = right_first ? n->right : n->left;
      const Index far = right_first ? n->left : n->right;
      const double bn = right_first ? br : bl;
      const double bf = right_first ? bl : br;
      stack[top] = {far, bf};
      top += bf < best;
      if (bn >= best) {
        n = nullptr;
        break;
      }
      n = &nodes_[near];
    }
    if (n != nullptr) scan(*n);
  }
}

void VertexTree::search(Index root, const double q[3], double& best, Index& best_pos) const {
  // Bound: the squared distance to the box. Scan the leaf's points
  // (contiguous in tree order).
  branch_and_bound(
      root, best, [q](const Node& n) { return box_dist2(n, q); },
      [&](const Node& leaf) {
        for (Index i = leaf.begin; i < leaf.end; ++i) {
          const double d = dist2(q, points_[i]);
          if (d < best) {
            best = d;
            best_pos = i;
          }
        }
      });
}

NearestVertex VertexTree::nearest(const Vec3& query) const {
  if (nodes_.empty()) return {kNoIndex, kInf};
  const double q[3] = {query.x(), query.y(), query.z()};
  double best = kInf;
  Index pos = kNoIndex;
  search(0, q, best, pos);
  if (pos == kNoIndex) return {kNoIndex, kInf};
  return {order_[pos], best};
}

NearestVertex VertexTree::nearest_local(const Vec3& query, SearchCursor& cursor) const {
  // No usable cursor: full query, then remember the answer's leaf.
  const Index start = cursor.leaf;
  if (start >= nodes_.size() || nodes_[start].left != kNoIndex) {
    if (nodes_.empty()) return {kNoIndex, kInf};
    const double q[3] = {query.x(), query.y(), query.z()};
    double best = kInf;
    Index pos = kNoIndex;
    search(0, q, best, pos);
    if (pos == kNoIndex) return {kNoIndex, kInf};
    cursor.leaf = leaf_of_[pos];
    return {order_[pos], best};
  }

  // Best candidate in the last leaf.
  const double q[3] = {query.x(), query.y(), query.z()};
  double best = kInf;
  Index pos = kNoIndex;
  const Node& leaf = nodes_[start];
  for (Index i = leaf.begin; i < leaf.end; ++i) {
    const double d = dist2(q, points_[i]);
    if (d < best) {
      best = d;
      pos = i;
    }
  }

  // Climb: a box that contains the ball through the best candidate holds
  // every nearer vertex (siblings are split by planes), and everything below
  // it has been searched, so stop there. On the way up, search each sibling
  // subtree whose box is nearer than the best (this covers the part of the
  // parent not yet seen, so the parent need not be searched again).
  Index node = start;
  while (node != 0 && !contains_ball(nodes_[node], q, best)) {
    const Node& parent = nodes_[nodes_[node].parent];
    const Index sibling = parent.left == node ? parent.right : parent.left;
    if (box_dist2(nodes_[sibling], q) < best) search(sibling, q, best, pos);
    node = nodes_[node].parent;
  }
  if (pos == kNoIndex) return {kNoIndex, kInf};
  cursor.leaf = leaf_of_[pos];
  return {order_[pos], best};
}

double VertexTree::clearance(const Vec3& query, double cap) const {
  if (node_reach_.empty() || nodes_.empty() || !query.allFinite() || !(cap > 0)) return 0.0;
  const double q[3] = {query.x(), query.y(), query.z()};
  // Bound: the box's distance, rounded down a little so that it never
  // exceeds a vertex's own, less the largest reach inside it. `best` only
  // falls, from the cap.
  double best = cap;
  const Node* const first = nodes_.data();
  branch_and_bound(
      0, best,
      [&](const Node& n) {
        return std::sqrt(box_dist2(n, q)) * (1 - 1e-12) - node_reach_[static_cast<std::size_t>(&n - first)];
      },
      [&](const Node& leaf) {
        for (Index i = leaf.begin; i < leaf.end; ++i)
          best = std::min(best, std::sqrt(dist2(q, points_[i])) - point_reach_[i]);
      });
  return std::max(best, 0.0);
}

bool VertexTree::check_invariants() const {
  const std::size_t n = order_.size();
  if (n == 0) return nodes_.empty() && points_.empty();
  if (nodes_.empty() || points_.size() != n || leaf_of_.size() != n) return false;

  // order_ is a permutation (every vertex exactly once).
  std::vector<char> seen(n, 0);
  for (Index v : order_) {
    if (v >= n || seen[v]) return false;
    seen[v] = 1;
  }
  if (nodes_[0].parent != kNoIndex || nodes_[0].begin != 0 || nodes_[0].end != n) return false;

  std::vector<Index> covered(n, kNoIndex);
  int max_depth = 0;
  for (Index k = 0; k < nodes_.size(); ++k) {
    const Node& nd = nodes_[k];
    if (nd.begin >= nd.end || nd.end > n) return false;
    for (int a = 0; a < 3; ++a)
      if (!(nd.lo[a] <= nd.hi[a])) return false;
    int d = 0;
    for (Index p = k; nodes_[p].parent != kNoIndex; p = nodes_[p].parent) ++d;
    max_depth = std::max(max_depth, d);

    if (nd.left == kNoIndex) {
      // Leaf: small, its points inside its box, each position in one leaf only.
      if (nd.right != kNoIndex || nd.end - nd.begin > static_cast<Index>(leaf_size_)) return false;
      for (Index i = nd.begin; i < nd.end; ++i) {
        if (covered[i] != kNoIndex || leaf_of_[i] != k) return false;
        covered[i] = k;
        for (int a = 0; a < 3; ++a)
          if (!(points_[i][a] >= nd.lo[a] && points_[i][a] <= nd.hi[a])) return false;
      }
      continue;
    }
    // Inner node: children partition its range, lie inside its box and are
    // separated by a plane on some axis.
    if (nd.right == kNoIndex || nd.left >= nodes_.size() || nd.right >= nodes_.size()) return false;
    const Node& l = nodes_[nd.left];
    const Node& r = nodes_[nd.right];
    if (l.parent != k || r.parent != k) return false;
    if (l.begin != nd.begin || l.end != r.begin || r.end != nd.end) return false;
    for (const Node* c : {&l, &r})
      for (int a = 0; a < 3; ++a)
        if (c->lo[a] < nd.lo[a] || c->hi[a] > nd.hi[a]) return false;
    bool separated = false;
    for (int a = 0; a < 3 && !separated; ++a) {
      double lmax = -kInf, rmin = kInf;
      for (Index i = l.begin; i < l.end; ++i) lmax = std::max(lmax, points_[i][a]);
      for (Index i = r.begin; i < r.end; ++i) rmin = std::min(rmin, points_[i][a]);
      separated = lmax <= rmin;
    }
    if (!separated) return false;
  }
  for (Index c : covered)
    if (c == kNoIndex) return false;
  return max_depth == depth_ && depth_ <= kMaxDepth;
}

}  // namespace palpa::collision
