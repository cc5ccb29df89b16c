#pragma once
// palpa-bench's account of the contact query's tree path: why the
// in-contact walk declined (collision::WalkEnd) on the queries that went to
// the tree, and what the tree path's two parts cost. Target 3 compares the
// query with CGAL's hinted query at p99, and on meshes where the walk
// declines on more than 1% of the queries that p99 falls among the tree
// path's queries: this says which decline it is and which part is slow.
// The same for the haptic tick's own query (collision::track_contact):
// its latency on each of its paths, and why the proxy's first walk
// declined.

#include "collision/contact.h"
#include "collision/vertex_tree.h"
#include "mesh/surface_mesh.h"
#include "palpa_bench_path.h"
#include "palpa_bench_util.h"

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace palpa::bench {

/// A count per collision::WalkEnd (index = its value, one slot per value up
/// to OutOfReach).
using WalkEndCounts = std::array<std::size_t, static_cast<std::size_t>(collision::WalkEnd::OutOfReach) + 1>;

struct TreePathSplit {
  std::size_t queries = 0;       ///< queries replayed (the timed ones)
  std::size_t walk = 0;          ///< answered by the walk
  std::size_t tree = 0;          ///< answered on the tree path
  std::size_t tree_in_contact = 0;  ///< of those, after a walk that declined (the probe was in contact)
  /// Of tree_in_contact, how many per collision::WalkEnd. A walk that
  /// would have answered counts as Jump: only query_contact's jump test
  /// declines it.
  WalkEndCounts declines{};
  Latency walk_query;     ///< the timed query's latency (us) on the walk's queries
  Latency tree_query;     ///< the same on the tree path's queries
  /// The tree path's parts, run again right after the query (caches warm):
  /// nearest_local, and locate_surface_point when the foot was on a
  /// triangle around the nearest vertex (one ring) or only wider.
  Latency nearest;
  Latency locate_ring;
  Latency locate_wide;
};

/// Replays query_contact over `paths` as palpa-bench's `local` method does
/// (ticks [warm_begin, timed_begin) untimed, then every tick; "in contact"
/// = the last answer lay below the undeformed surface) and splits the timed
/// queries by path. `local_ns`: that method's time per timed query (ns), in
/// the same order.
TreePathSplit split_tree_path(const mesh::SurfaceMesh& mesh, const collision::VertexTree& tree,
                              const ProbePaths& paths, int probes, std::size_t warm_begin, std::size_t timed_begin,
                              const std::vector<double>& local_ns);

/// The tick's query (track_contact) split the same way: its latency on each
/// of its paths, where the proxy path is split by what it did, and why the
/// first walk from the proxy declined there.
struct TrackPathSplit {
  std::size_t queries = 0;  ///< queries replayed (the timed ones)
  Latency walk;             ///< path Walk
  /// path Proxy below the surface: the proxy held in its cone or slid
  /// (and maybe walked again from where it slid)
  Latency proxy;
  /// path Proxy with the probe above the slid proxy: the tree was asked
  /// before the contact was let go, and found the probe above the surface
  Latency proxy_released;
  Latency tree_in_contact;  ///< path Tree in contact: came out above the proxy, below another part of the surface
  Latency out_of_contact;   ///< paths Tree and Clear out of contact (query_contact's)
  /// Of the proxy paths, how many per collision::WalkEnd of the first walk
  /// from the proxy's triangle (replayed without the jump test); Answer: it
  /// answered, but farther than the foot can have moved (the proxy chases
  /// it) or after a jump.
  WalkEndCounts proxy_walk_ends{};
  /// Triangles that first walk visited, on average over the proxy paths
  /// below the surface, and over the slowest tenth of them (each triangle
  /// visited is prepared and solved again every tick).
  double proxy_walk_triangles = 0;
  double proxy_walk_triangles_slowest_tenth = 0;
};

/// Replays track_contact over `paths` as palpa-bench's `track` method does
/// (same verdict, same ticks) and splits the timed queries by path.
/// `track_ns`: that method's time per timed query (ns), in the same order.
TrackPathSplit split_track_paths(const mesh::SurfaceMesh& mesh, const collision::VertexTree& tree,
                                 const ProbePaths& paths, int probes, std::size_t warm_begin, std::size_t timed_begin,
                                 const std::vector<double>& track_ns);

/// The walk's end as printed ("too deep", "jump", ...).
const char* walk_end_name(std::size_t end);

/// The non-zero counts as printed ("too deep 63, stepped back 4"), or
/// "none".
std::string walk_end_counts_text(const WalkEndCounts& counts);

}  // namespace palpa::bench
