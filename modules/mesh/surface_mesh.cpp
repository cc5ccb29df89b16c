// Vertex normals, adjacency and the topology / geometry facts of a surface.

#include "mesh/surface_mesh.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cstdint>
#include <numeric>

namespace palpa::mesh {

// ---------------------------------------------------------------------------
// Area-weighted normals: each triangle adds its cross product (twice its area
// times its unit normal) to its three vertices; the sums are normalised.
void compute_normals(SurfaceMesh& mesh) {
  mesh.normals.assign(mesh.positions.size(), Vec3::Zero());
  for (const Triangle& t : mesh.triangles) {
    const Vec3& a = mesh.positions[t[0]];
    const Vec3 n = (mesh.positions[t[1]] - a).cross(mesh.positions[t[2]] - a);
    for (Index v : t) mesh.normals[v] += n;
  }
  for (Vec3& n : mesh.normals) {
    const double len = n.norm();
    n = len > 0 ? Vec3(n / len) : Vec3(0, 0, 1);
  }
}

// ---------------------------------------------------------------------------
// Adjacency in two counting passes per table (no per-vertex allocation).
void build_adjacency(SurfaceMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  const std::size_t nt = mesh.triangles.size();

  // Triangles of each vertex, in increasing triangle order.
  Csr& vt = mesh.vertex_triangles;
  vt.offsets.assign(nv + 1, 0);
  for (const Triangle& t : mesh.triangles)
    for (Index v : t) ++vt.offsets[v + 1];
  std::partial_sum(vt.offsets.begin(), vt.offsets.end(), vt.offsets.begin());
  vt.items.resize(vt.offsets[nv]);
  {
    std::vector<Index> fill(vt.offsets.begin(), vt.offsets.end() - 1);
    for (std::size_t t = 0; t < nt; ++t)
      for (Index v : mesh.triangles[t]) vt.items[fill[v]++] = Index(t);
  }

  // One-ring neighbours: both other corners of every incident triangle,
  // sorted and made unique per row, then compacted.
  Csr& vn = mesh.vertex_neighbors;
  std::vector<Index> raw_offsets(nv + 1, 0);
  for (std::size_t v = 0; v < nv; ++v) raw_offsets[v + 1] = raw_offsets[v] + 2 * (vt.offsets[v + 1] - vt.offsets[v]);
  std::vector<Index> raw(raw_offsets[nv]);
  for (std::size_t v = 0; v < nv; ++v) {
    Index w = raw_offsets[v];
    for (Index k = vt.offsets[v]; k < vt.offsets[v + 1]; ++k)
      for (Index u : mesh.triangles[vt.items[k]])
        if (u != v) raw[w++] = u;
    // A degenerate triangle (repeated vertex) gives fewer entries; pad with v and drop it below.
    while (w < raw_offsets[v + 1]) raw[w++] = Index(v);
  }
  vn.offsets.assign(nv + 1, 0);
  vn.items.clear();
  vn.items.reserve(raw.size() / 2);
  for (std::size_t v = 0; v < nv; ++v) {
    auto first = raw.begin() + raw_offsets[v], last = raw.begin() + raw_offsets[v + 1];
    std::sort(first, last);
    last = std::unique(first, last);
    for (auto it = first; it != last; ++it)
      if (*it != v) vn.items.push_back(*it);
    vn.offsets[v + 1] = Index(vn.items.size());
  }

  // Triangle across each edge: the one other triangle in both end vertices'
  // rows; none (kNoIndex) on a border or a non-manifold edge.
  mesh.triangle_neighbors.assign(nt, Triangle{kNoIndex, kNoIndex, kNoIndex});
  for (std::size_t t = 0; t < nt; ++t) {
    const Triangle& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      const Index a = tri[(k + 1) % 3], b = tri[(k + 2) % 3];
      Index found = kNoIndex;
      bool unique = true;
      for (Index s : vt.row(a)) {
        if (s == t || s == found) continue;
        const Triangle& o = mesh.triangles[s];
        if (o[0] != b && o[1] != b && o[2] != b) continue;
        if (found != kNoIndex) unique = false;
        found = s;
      }
      if (unique) mesh.triangle_neighbors[t][k] = found;
    }
  }
}

void finalize(SurfaceMesh& mesh) {
  compute_normals(mesh);
  build_adjacency(mesh);
}

// ---------------------------------------------------------------------------
// Facts: edges from sorted half-edge keys, components by union-find, volume
// by the divergence theorem (sum of signed tetrahedra against the bbox centre).
MeshFacts analyse(const SurfaceMesh& mesh) {
  MeshFacts f;
  f.vertices = mesh.positions.size();
  f.triangles = mesh.triangles.size();

  // Bounding box.
  if (!mesh.positions.empty()) {
    f.bbox_min = f.bbox_max = mesh.positions[0];
    for (const Vec3& p : mesh.positions) {
      f.bbox_min = f.bbox_min.cwiseMin(p);
      f.bbox_max = f.bbox_max.cwiseMax(p);
    }
  }

  // Area and signed volume.
  const Vec3 c = 0.5 * (f.bbox_min + f.bbox_max);
  for (const Triangle& t : mesh.triangles) {
    const Vec3 a = mesh.positions[t[0]] - c, b = mesh.positions[t[1]] - c, d = mesh.positions[t[2]] - c;
    f.area += 0.5 * (b - a).cross(d - a).norm();
    f.signed_volume += a.dot(b.cross(d)) / 6.0;
  }

  // Edges: key = lo << 32 | hi, low bit of a separate flag = direction.
  std::vector<std::uint64_t> half;  // key << 1 | (traversed hi -> lo)
  half.reserve(3 * mesh.triangles.size());
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const Index a = t[k], b = t[(k + 1) % 3];
      const std::uint64_t key = std::uint64_t(std::min(a, b)) << 32 | std::max(a, b);
      half.push_back(key << 1 | std::uint64_t(a > b));
    }
  std::sort(half.begin(), half.end());
  std::size_t edges = 0;
  bool consistent = true;
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i;
    std::size_t backward = 0;
    while (j < half.size() && (half[j] >> 1) == (half[i] >> 1)) backward += half[j++] & 1;
    const std::size_t uses = j - i;
    ++edges;
    if (uses == 1) ++f.boundary_edges;
    if (uses > 2) ++f.nonmanifold_edges;
    if (backward > 1 || uses - backward > 1) consistent = false;  // a direction used twice
    i = j;
  }
  f.consistently_oriented = consistent;
  f.euler_characteristic = long(f.vertices) - long(edges) + long(f.triangles);

  // Components: triangles sharing a vertex are connected.
  std::vector<Index> parent(f.vertices);
  std::iota(parent.begin(), parent.end(), Index{0});
  auto find = [&](Index i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (const Triangle& t : mesh.triangles)
    for (int k = 1; k < 3; ++k) {
      const Index a = find(t[0]), b = find(t[k]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<char> root_seen(f.vertices, 0);
  for (const Triangle& t : mesh.triangles) {
    const Index r = find(t[0]);
    if (!root_seen[r]) {
      root_seen[r] = 1;
      ++f.components;
    }
  }
  return f;
}

}  // namespace palpa::mesh
