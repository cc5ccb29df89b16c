#include "mesh/spatial_order.h"

#include <algorithm>
#include <array>
#include <numeric>

namespace palpa::mesh {

namespace {

constexpr int kBits = 20;  // per axis: 2^20 cells, a 60-bit key

// Skilling's transform ("Programming the Hilbert curve", 2004): turns the
// three coordinates into the "transposed" Hilbert index in place; the key
// is then the coordinates' bits interleaved, most significant first.
std::uint64_t hilbert_index(std::array<std::uint32_t, 3> x) {
  constexpr std::uint32_t top = 1u << (kBits - 1);
  for (std::uint32_t q = top; q > 1; q >>= 1) {
    const std::uint32_t p = q - 1;
    for (int i = 0; i < 3; ++i) {
      if (x[i] & q) {
        x[0] ^= p;
      } else {
        const std::uint32_t t = (x[0] ^ x[i]) & p;
        x[0] ^= t;
        x[i] ^= t;
      }
    }
  }
  for (int i = 1; i < 3; ++i) x[i] ^= x[i - 1];
  std::uint32_t t = 0;
  for (std::uint32_t q = top; q > 1; q >>= 1)
    if (x[2] & q) t ^= q - 1;
  for (auto& v : x) v ^= t;
  std::uint64_t key = 0;
  for (int b = kBits - 1; b >= 0; --b)
    for (int i = 0; i < 3; ++i) key = (key << 1) | ((x[i] >> b) & 1u);
  return key;
}

}  // namespace

std::uint64_t hilbert_key(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  constexpr double cells = double(1u << kBits);
  std::array<std::uint32_t, 3> q{};
  for (int a = 0; a < 3; ++a) {
    const double extent = hi[a] - lo[a];
    double u = extent > 0 ? (p[a] - lo[a]) / extent : 0.0;
    if (!(u > 0)) u = 0;  // also NaN
    q[a] = static_cast<std::uint32_t>(std::min(u * cells, cells - 1));
  }
  return hilbert_index(q);
}

std::vector<Index> reorder_spatially(SurfaceMesh& mesh) {
  const std::size_t n = mesh.vertex_count();
  std::vector<Index> new_of_old(n);
  if (n == 0) return new_of_old;

  Vec3 lo = mesh.positions.front(), hi = lo;
  for (const Vec3& p : mesh.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // One cube around the box, so the curve's cells are cubes (a long organ
  // does not get stretched cells).
  const double side = (hi - lo).maxCoeff();
  hi = lo + Vec3::Constant(side);

  std::vector<std::pair<std::uint64_t, Index>> keyed(n);
  for (std::size_t i = 0; i < n; ++i) keyed[i] = {hilbert_key(mesh.positions[i], lo, hi), static_cast<Index>(i)};
  std::sort(keyed.begin(), keyed.end());  // ties: the old index decides
  bool identity = true;
  for (std::size_t k = 0; k < n; ++k) {
    new_of_old[keyed[k].second] = static_cast<Index>(k);
    identity = identity && keyed[k].second == k;
  }

  if (!identity) {
    std::vector<Vec3> positions(n);
    for (std::size_t i = 0; i < n; ++i) positions[new_of_old[i]] = mesh.positions[i];
    mesh.positions = std::move(positions);
    for (Triangle& t : mesh.triangles)
      for (Index& v : t) v = new_of_old[v];
  }

  // Triangles by their sorted corner indices; corners rotated (not swapped)
  // so the smallest comes first, which keeps the orientation and makes the
  // order unique.
  auto rotated = [](Triangle t) {
    while (t[0] > t[1] || t[0] > t[2]) t = Triangle{t[1], t[2], t[0]};
    return t;
  };
  auto sorted = [](const Triangle& t) {
    std::array<Index, 3> s{t[0], t[1], t[2]};
    std::sort(s.begin(), s.end());
    return s;
  };
  bool triangles_in_order = true;
  for (std::size_t f = 0; f < mesh.triangles.size() && triangles_in_order; ++f) {
    const Triangle r = rotated(mesh.triangles[f]);
    triangles_in_order = r == mesh.triangles[f] && (f == 0 || sorted(mesh.triangles[f - 1]) <= sorted(r));
  }
  if (!triangles_in_order) {
    for (Triangle& t : mesh.triangles) t = rotated(t);
    std::stable_sort(mesh.triangles.begin(), mesh.triangles.end(),
                     [&](const Triangle& a, const Triangle& b) { return sorted(a) < sorted(b); });
  }

  // The normals from the numbered mesh itself, always: a session file keeps
  // positions and triangles only and its reader computes them so; permuted
  // (or computed before a change of unit) they would differ in the last bits
  // and a replay would not be bit-identical.
  if (!mesh.normals.empty()) compute_normals(mesh);
  if ((!identity || !triangles_in_order) && !mesh.vertex_neighbors.offsets.empty()) build_adjacency(mesh);
  return new_of_old;
}

bool same_mesh_up_to_spatial_order(const SurfaceMesh& recorded, const SurfaceMesh& loaded) {
  if (recorded.positions == loaded.positions && recorded.triangles == loaded.triangles) return true;
  if (recorded.vertex_count() != loaded.vertex_count() || recorded.triangle_count() != loaded.triangle_count())
    return false;
  SurfaceMesh renumbered;
  renumbered.positions = recorded.positions;
  renumbered.triangles = recorded.triangles;
  reorder_spatially(renumbered);
  return renumbered.positions == loaded.positions && renumbered.triangles == loaded.triangles;
}

}  // namespace palpa::mesh
