// palpa-bench's account of the contact query's tree path and of the tick's
// query's paths (see palpa_bench_fallback.h).

#include "palpa_bench_fallback.h"

#include <algorithm>
#include <utility>

namespace palpa::bench {

const char* walk_end_name(std::size_t end) {
  switch (static_cast<collision::WalkEnd>(end)) {
    case collision::WalkEnd::Answer: return "answer";
    case collision::WalkEnd::BadInput: return "bad input";
    case collision::WalkEnd::Jump: return "jump";
    case collision::WalkEnd::Unsolved: return "unsolved";
    case collision::WalkEnd::Above: return "above";
    case collision::WalkEnd::TooDeep: return "too deep";
    case collision::WalkEnd::Border: return "border";
    case collision::WalkEnd::SteppedBack: return "stepped back";
    case collision::WalkEnd::OutOfSteps: return "out of steps";
    case collision::WalkEnd::OutOfReach: return "out of reach";
  }
  return "?";
}

std::string walk_end_counts_text(const WalkEndCounts& counts) {
  std::string text;
  for (std::size_t e = 0; e < counts.size(); ++e) {
    if (counts[e] == 0) continue;
    text += (text.empty() ? "" : ", ") + std::string(walk_end_name(e)) + " " + std::to_string(counts[e]);
  }
  return text.empty() ? "none" : text;
}

namespace {

// Replays one of the contact queries (`query`: query_contact or
// track_contact, called as (mesh, tree, probe, cursor, in_contact)) over
// `paths` as palpa-bench's timed methods do: ticks [warm_begin, paths.ticks),
// every probe, "in contact" = the last answer lay below the undeformed
// surface. For each query from timed_begin on, calls each(probe, in_contact,
// cursor before the query, answer, time of the timed run in ns).
template <class Query, class Each>
void replay_timed(const mesh::SurfaceMesh& mesh, const collision::VertexTree& tree, const ProbePaths& paths,
                  int probes, std::size_t warm_begin, std::size_t timed_begin, const std::vector<double>& timed_ns,
                  Query&& query, Each&& each) {
  std::vector<collision::ContactCursor> cursors(static_cast<std::size_t>(probes));
  std::vector<char> touching(static_cast<std::size_t>(probes), 0);
  std::size_t i = 0;  // timed query
  for (std::size_t k = warm_begin; k < paths.ticks; ++k) {
    for (int p = 0; p < probes; ++p) {
      const Vec3& q = paths.at(k, p);
      collision::ContactCursor& cursor = cursors[static_cast<std::size_t>(p)];
      const bool in_contact = touching[static_cast<std::size_t>(p)] != 0;
      const collision::ContactCursor before = cursor;
      const collision::ContactAnswer ca = query(mesh, tree, q, cursor, in_contact);
      touching[static_cast<std::size_t>(p)] = ca.surface.triangle != kNoIndex && ca.surface.offset < 0;
      if (k < timed_begin) continue;
      const double ns = i < timed_ns.size() ? timed_ns[i] : 0.0;
      ++i;
      each(q, in_contact, before, ca, ns);
    }
  }
}

}  // namespace

TreePathSplit split_tree_path(const mesh::SurfaceMesh& mesh, const collision::VertexTree& tree,
                              const ProbePaths& paths, int probes, std::size_t warm_begin, std::size_t timed_begin,
                              const std::vector<double>& local_ns) {
  TreePathSplit s;
  std::vector<double> walk_ns, tree_ns, nearest_ns, ring_ns, wide_ns;
  auto each = [&](const Vec3& q, bool in_contact, const collision::ContactCursor& before,
                const collision::ContactAnswer& ca, double ns) {
    ++s.queries;
    if (ca.path == collision::ContactPath::Walk) {
      ++s.walk;
      walk_ns.push_back(ns);
      return;
    }
    if (ca.path != collision::ContactPath::Tree) return;
    ++s.tree;
    tree_ns.push_back(ns);
    if (in_contact && before.triangle < mesh.triangle_count()) {
      ++s.tree_in_contact;
      collision::WalkTrace trace;
      collision::walk_surface_point(mesh, q, before.triangle, trace);
      // A walk that answers here was declined by query_contact's jump test.
      const collision::WalkEnd end =
          trace.end == collision::WalkEnd::Answer ? collision::WalkEnd::Jump : trace.end;
      ++s.declines[static_cast<std::size_t>(end)];
    }
    // The two parts again, from the cursor the query started with.
    collision::SearchCursor search = before.tree;
    const auto t0 = Clock::now();
    const collision::NearestVertex nv = tree.nearest_local(q, search);
    const auto t1 = Clock::now();
    const collision::SurfacePoint sp = collision::locate_surface_point(mesh, q, nv.vertex);
    const auto t2 = Clock::now();
    nearest_ns.push_back(elapsed_ns(t0, t1));
    // The one ring held the foot when the answer is inside a triangle with
    // the nearest vertex as a corner; otherwise the search widened.
    bool ring = false;
    if (sp.inside && sp.triangle < mesh.triangle_count()) {
      const mesh::Triangle& tri = mesh.triangles[sp.triangle];
      ring = tri[0] == nv.vertex || tri[1] == nv.vertex || tri[2] == nv.vertex;
    }
    (ring ? ring_ns : wide_ns).push_back(elapsed_ns(t1, t2));
  };
  replay_timed(mesh, tree, paths, probes, warm_begin, timed_begin, local_ns, collision::query_contact, each);
  s.walk_query = latency_of(walk_ns);
  s.tree_query = latency_of(tree_ns);
  s.nearest = latency_of(nearest_ns);
  s.locate_ring = latency_of(ring_ns);
  s.locate_wide = latency_of(wide_ns);
  return s;
}

TrackPathSplit split_track_paths(const mesh::SurfaceMesh& mesh, const collision::VertexTree& tree,
                                 const ProbePaths& paths, int probes, std::size_t warm_begin, std::size_t timed_begin,
                                 const std::vector<double>& track_ns) {
  TrackPathSplit s;
  std::vector<double> walk_ns, proxy_ns, released_ns, tree_ns, out_ns;
  std::vector<std::pair<double, int>> proxy_triangles;  // (time, triangles of the first walk)
  auto each = [&](const Vec3& q, bool in_contact, const collision::ContactCursor& before,
                const collision::ContactAnswer& ca, double ns) {
    ++s.queries;
    const bool from_proxy = in_contact && before.triangle < mesh.triangle_count();
    if (!from_proxy) {
      out_ns.push_back(ns);
    } else if (ca.path == collision::ContactPath::Walk) {
      walk_ns.push_back(ns);
    } else if (ca.path == collision::ContactPath::Tree) {
      tree_ns.push_back(ns);
    } else if (ca.path == collision::ContactPath::Proxy) {
      (ca.surface.offset < 0 ? proxy_ns : released_ns).push_back(ns);
      collision::WalkTrace trace;
      collision::walk_surface_point(mesh, q, before.triangle, trace);
      ++s.proxy_walk_ends[static_cast<std::size_t>(trace.end)];
      if (ca.surface.offset < 0) proxy_triangles.emplace_back(ns, trace.count);
    }
  };
  replay_timed(mesh, tree, paths, probes, warm_begin, timed_begin, track_ns, collision::track_contact, each);
  if (!proxy_triangles.empty()) {
    std::sort(proxy_triangles.begin(), proxy_triangles.end());
    const std::size_t n = proxy_triangles.size(), slow = n - n * 9 / 10;
    double all = 0, tail = 0;
    for (std::size_t k = 0; k < n; ++k) {
      all += proxy_triangles[k].second;
      if (k >= n - slow) tail += proxy_triangles[k].second;
    }
    s.proxy_walk_triangles = all / static_cast<double>(n);
    s.proxy_walk_triangles_slowest_tenth = tail / static_cast<double>(slow);
  }
  s.walk = latency_of(walk_ns);
  s.proxy = latency_of(proxy_ns);
  s.proxy_released = latency_of(released_ns);
  s.tree_in_contact = latency_of(tree_ns);
  s.out_of_contact = latency_of(out_ns);
  return s;
}

}  // namespace palpa::bench
