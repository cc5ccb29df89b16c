#include "palpa_bench_query_loop.h"

#include "collision/contact.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <vector>

namespace palpa::bench {

namespace {

// FNV-1a, 64 bits, over the bytes of each value in turn.
struct Fnv1a {
  std::uint64_t h = 14695981039346656037ull;
  template <typename T>
  void add(const T& v) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &v, sizeof(T));
    for (unsigned char c : bytes) {
      h ^= c;
      h *= 1099511628211ull;
    }
  }
  void add(const Vec3& v) {
    for (int k = 0; k < 3; ++k) add(v[k]);
  }
};

}  // namespace

QueryLoopResult run_query_loop(const mesh::SurfaceMesh& mesh, const collision::VertexTree& tree,
                               const ProbePaths& paths, int probes, int passes) {
  QueryLoopResult r;
  probes = std::clamp(probes, 1, paths.probes);
  r.queries = paths.ticks * static_cast<std::size_t>(probes);
  r.passes = passes;
  Fnv1a hash;
  std::vector<double> pass_ns;
  for (int pass = 0; pass < passes; ++pass) {
    std::vector<collision::ContactCursor> cursors(static_cast<std::size_t>(probes));
    std::vector<char> touching(static_cast<std::size_t>(probes), 0);
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < paths.ticks; ++k) {
      for (int p = 0; p < probes; ++p) {
        const collision::ContactAnswer a =
            collision::track_contact(mesh, tree, paths.at(k, p), cursors[p], touching[p] != 0);
        touching[p] = a.surface.triangle != kNoIndex && a.surface.offset < 0;
        if (pass == 0) {
          hash.add(a.surface.triangle);
          hash.add(a.surface.barycentric);
          hash.add(a.surface.point);
          hash.add(a.surface.normal);
          hash.add(a.surface.offset);
          hash.add(a.nearest_vertex);
          hash.add(static_cast<unsigned char>(a.path));
          r.walk += a.path == collision::ContactPath::Walk;
          r.proxy += a.path == collision::ContactPath::Proxy;
          r.tree += a.path == collision::ContactPath::Tree;
          r.clear += a.path == collision::ContactPath::Clear;
        }
      }
    }
    const auto end = std::chrono::steady_clock::now();
    pass_ns.push_back(std::chrono::duration<double, std::nano>(end - start).count());
  }
  r.answer_hash = hash.h;
  if (!pass_ns.empty() && r.queries > 0) {
    std::sort(pass_ns.begin(), pass_ns.end());
    const double q = static_cast<double>(r.queries);
    r.best_ns_per_query = pass_ns.front() / q;
    r.median_ns_per_query = pass_ns[pass_ns.size() / 2] / q;
  }
  return r;
}

}  // namespace palpa::bench
