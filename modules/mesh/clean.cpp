// The cleaning pass every loaded mesh goes through: weld duplicate vertices,
// drop degenerate and duplicate triangles, optionally keep the largest
// component, orient every component consistently and outward, and remove
// vertices no triangle uses.

#include "mesh/internal_io.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>

namespace palpa::mesh::internal {
namespace {

// ---------------------------------------------------------------------------
// Union-find over indices (path halving, union by index).
struct DisjointSets {
  std::vector<Index> parent;
  explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), Index{0}); }
  Index find(Index i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void unite(Index a, Index b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

// ---------------------------------------------------------------------------
// Weld: maps every vertex to a representative (the first of its group in file
// order). tolerance == 0 merges bit-equal positions (+0 and -0 are equal);
// tolerance > 0 merges greedily within that distance using a hash grid.
std::vector<Index> weld_map(const std::vector<Vec3>& p, double tolerance) {
  const std::size_t n = p.size();
  std::vector<Index> rep(n);
  if (tolerance <= 0) {
    // Exact: sort by position, group equal runs.
    std::vector<Index> order(n);
    std::iota(order.begin(), order.end(), Index{0});
    auto less = [&](Index a, Index b) {
      if (p[a].x() != p[b].x()) return p[a].x() < p[b].x();
      if (p[a].y() != p[b].y()) return p[a].y() < p[b].y();
      if (p[a].z() != p[b].z()) return p[a].z() < p[b].z();
      return a < b;
    };
    std::sort(order.begin(), order.end(), less);
    for (std::size_t i = 0; i < n;) {
      std::size_t j = i;
      while (j < n && p[order[j]] == p[order[i]]) ++j;
      for (std::size_t k = i; k < j; ++k) rep[order[k]] = order[i];  // order[i] is the smallest index
      i = j;
    }
    return rep;
  }

  // Within a tolerance: cells of size `tolerance`; look in the 27 cells around.
  struct Key {
    std::int64_t x, y, z;
    bool operator==(const Key&) const = default;
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      return std::size_t(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
    }
  };
  std::unordered_map<Key, std::vector<Index>, KeyHash> grid;
  grid.reserve(n);
  auto cell = [&](const Vec3& q) {
    return Key{std::int64_t(std::floor(q.x() / tolerance)), std::int64_t(std::floor(q.y() / tolerance)),
               std::int64_t(std::floor(q.z() / tolerance))};
  };
  const double tol2 = tolerance * tolerance;
  for (std::size_t i = 0; i < n; ++i) {
    const Key c = cell(p[i]);
    Index found = kNoIndex;
    for (int dx = -1; dx <= 1 && found == kNoIndex; ++dx)
      for (int dy = -1; dy <= 1 && found == kNoIndex; ++dy)
        for (int dz = -1; dz <= 1 && found == kNoIndex; ++dz) {
          auto it = grid.find(Key{c.x + dx, c.y + dy, c.z + dz});
          if (it == grid.end()) continue;
          for (Index r : it->second)
            if ((p[r] - p[i]).squaredNorm() <= tol2) {
              found = r;
              break;
            }
        }
    if (found == kNoIndex) {
      grid[c].push_back(Index(i));
      rep[i] = Index(i);
    } else {
      rep[i] = found;
    }
  }
  return rep;
}

// Sorted vertex set of a triangle, as one key.
std::array<Index, 3> sorted(Triangle t) {
  std::sort(t.begin(), t.end());
  return t;
}

// ---------------------------------------------------------------------------
// Orientation: flood-fill across edges shared by exactly two triangles so that
// neighbours traverse their common edge in opposite directions, then decide
// each patch's side: a closed patch is flipped when its signed volume is
// negative; an open patch (no inside) keeps the orientation most of its input
// triangles had. Returns the number of triangles reversed.
std::size_t orient(const std::vector<Vec3>& p, std::vector<Triangle>& tris) {
  const std::size_t nt = tris.size();

  // Half-edges sorted by undirected edge.
  struct HalfEdge {
    std::uint64_t key;  // lo << 32 | hi
    Index tri;
    bool forward;  // traversed lo -> hi
  };
  std::vector<HalfEdge> he;
  he.reserve(3 * nt);
  for (std::size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      const Index a = tris[t][k], b = tris[t][(k + 1) % 3];
      he.push_back({std::uint64_t(std::min(a, b)) << 32 | std::max(a, b), Index(t), a < b});
    }
  std::sort(he.begin(), he.end(), [](const HalfEdge& x, const HalfEdge& y) { return x.key < y.key; });

  // Neighbours across manifold edges, with the parity "must differ in flip".
  std::vector<std::array<std::pair<Index, bool>, 3>> nb(nt);
  std::vector<int> nb_count(nt, 0);
  std::vector<bool> open(nt, false);  // touches a boundary or non-manifold edge
  for (std::size_t i = 0; i < he.size();) {
    std::size_t j = i;
    while (j < he.size() && he[j].key == he[i].key) ++j;
    if (j - i == 2) {
      const HalfEdge& x = he[i];
      const HalfEdge& y = he[i + 1];
      const bool differ = x.forward == y.forward;  // same direction: one of them must flip
      if (nb_count[x.tri] < 3) nb[x.tri][nb_count[x.tri]++] = {y.tri, differ};
      if (nb_count[y.tri] < 3) nb[y.tri][nb_count[y.tri]++] = {x.tri, differ};
    } else {
      for (std::size_t k = i; k < j; ++k) open[he[k].tri] = true;
    }
    i = j;
  }

  // Flood fill patch by patch.
  std::vector<Index> patch(nt, kNoIndex);
  std::vector<char> flip(nt, 0);
  std::vector<Index> stack;
  std::vector<Index> members;
  for (std::size_t seed = 0; seed < nt; ++seed) {
    if (patch[seed] != kNoIndex) continue;
    members.clear();
    stack.push_back(Index(seed));
    patch[seed] = Index(seed);
    while (!stack.empty()) {
      const Index t = stack.back();
      stack.pop_back();
      members.push_back(t);
      for (int k = 0; k < nb_count[t]; ++k) {
        const auto [u, differ] = nb[t][k];
        if (patch[u] != kNoIndex) continue;  // already placed (a conflict means non-orientable)
        patch[u] = Index(seed);
        flip[u] = char(flip[t] ^ char(differ));
        stack.push_back(u);
      }
    }

    // Decide the patch's side.
    bool closed = true;
    std::size_t flipped = 0;
    Vec3 centre = Vec3::Zero();
    for (Index t : members) {
      closed = closed && !open[t];
      flipped += std::size_t(flip[t]);
      centre += p[tris[t][0]] + p[tris[t][1]] + p[tris[t][2]];
    }
    centre /= 3.0 * double(members.size());
    bool reverse_all = false;
    if (closed) {
      double six_volume = 0;
      for (Index t : members) {
        const Vec3 a = p[tris[t][0]] - centre, b = p[tris[t][1]] - centre, c = p[tris[t][2]] - centre;
        const double v = a.dot(b.cross(c));
        six_volume += flip[t] ? -v : v;
      }
      reverse_all = six_volume < 0;
    } else {
      reverse_all = 2 * flipped > members.size();
    }
    if (reverse_all)
      for (Index t : members) flip[t] = char(!flip[t]);
  }

  // Apply.
  std::size_t count = 0;
  for (std::size_t t = 0; t < nt; ++t)
    if (flip[t]) {
      std::swap(tris[t][1], tris[t][2]);
      ++count;
    }
  return count;
}

}  // namespace

// ---------------------------------------------------------------------------
void clean_triangles(std::vector<Vec3>& positions, std::vector<Triangle>& triangles, const LoadOptions& options,
                     CleanReport& report) {
  // 1. Weld duplicate vertices.
  std::size_t welded = 0;
  if (options.weld) {
    const std::vector<Index> rep = weld_map(positions, options.weld_tolerance);
    for (std::size_t i = 0; i < rep.size(); ++i) welded += rep[i] != i;
    report.welded_vertices += welded;
    for (Triangle& t : triangles)
      for (Index& v : t) v = rep[v];
  }

  // 2. Drop degenerate triangles: a repeated vertex or exactly zero area.
  std::erase_if(triangles, [&](const Triangle& t) {
    const bool bad = t[0] == t[1] || t[1] == t[2] || t[0] == t[2] ||
                     (positions[t[1]] - positions[t[0]]).cross(positions[t[2]] - positions[t[0]]).squaredNorm() == 0;
    report.degenerate_triangles += bad;
    return bad;
  });

  // 3. Drop duplicate triangles (same vertex set, either orientation); the first one stays.
  {
    std::vector<Index> order(triangles.size());
    std::iota(order.begin(), order.end(), Index{0});
    std::vector<std::array<Index, 3>> keys(triangles.size());
    for (std::size_t t = 0; t < triangles.size(); ++t) keys[t] = sorted(triangles[t]);
    std::sort(order.begin(), order.end(), [&](Index a, Index b) { return keys[a] != keys[b] ? keys[a] < keys[b] : a < b; });
    std::vector<char> drop(triangles.size(), 0);
    for (std::size_t i = 1; i < order.size(); ++i)
      if (keys[order[i]] == keys[order[i - 1]]) drop[order[i]] = 1;
    std::size_t w = 0;
    for (std::size_t t = 0; t < triangles.size(); ++t)
      if (!drop[t]) triangles[w++] = triangles[t];
    report.duplicate_triangles += triangles.size() - w;
    triangles.resize(w);
  }

  // 4. Keep only the component with the most triangles.
  if (options.keep_largest_component && !triangles.empty()) {
    DisjointSets sets(positions.size());
    for (const Triangle& t : triangles) {
      sets.unite(t[0], t[1]);
      sets.unite(t[0], t[2]);
    }
    std::unordered_map<Index, std::size_t> size;
    for (const Triangle& t : triangles) ++size[sets.find(t[0])];
    Index best = kNoIndex;
    std::size_t best_size = 0;
    for (const Triangle& t : triangles) {  // ties go to the component met first
      const Index r = sets.find(t[0]);
      if (size[r] > best_size) {
        best = r;
        best_size = size[r];
      }
    }
    report.dropped_components += size.size() - 1;
    std::erase_if(triangles, [&](const Triangle& t) { return sets.find(t[0]) != best; });
  }

  // 5. Orient consistently and outward.
  if (options.orient_outward) report.flipped_triangles += orient(positions, triangles);

  // 6. Remove unused vertices, keeping the order of the others (welded-away
  //    vertices are among them but were counted as welded).
  std::vector<char> used(positions.size(), 0);
  for (const Triangle& t : triangles)
    for (Index v : t) used[v] = 1;
  std::vector<Index> remap(positions.size(), kNoIndex);
  Index next = 0;
  for (std::size_t i = 0; i < positions.size(); ++i)
    if (used[i]) {
      remap[i] = next;
      positions[next++] = positions[i];
    }
  report.unused_vertices += positions.size() - next - welded;
  positions.resize(next);
  for (Triangle& t : triangles)
    for (Index& v : t) v = remap[v];
}

}  // namespace palpa::mesh::internal
