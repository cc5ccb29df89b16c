#pragma once
// palpa-bench's account of the contact query's tree path: why the
// in-contact walk declined (collision::WalkEnd) on the queries that went to
// the tree, and what the tree path's two parts cost. Target 3 compares the
// query with CGAL's hinted query at p99, and on meshes where the walk
// declines on more than 1% of the queries that p99 falls among the tree
// path's queries: this says which decline it is and which part is slow.

#include "collision/contact.h"
#include "collision/vertex_tree.h"
#include "mesh/surface_mesh.h"
#include "palpa_bench_path.h"
#include "palpa_bench_util.h"

#include <array>
#include <cstddef>
#include <vector>

namespace palpa::bench {

struct TreePathSplit {
  std::size_t queries = 0;       ///< queries replayed (the timed ones)
  std::size_t walk = 0;          ///< answered by the walk
  std::size_t tree = 0;          ///< answered on the tree path
  std::size_t tree_in_contact = 0;  ///< of those, after a walk that declined (the probe was in contact)
  /// Of tree_in_contact, how many per collision::WalkEnd (index = its
  /// value, one slot per value up to OutOfSteps). A walk that would have
  /// answered counts as Jump: only query_contact's jump test declines it.
  std::array<std::size_t, static_cast<std::size_t>(collision::WalkEnd::OutOfSteps) + 1> declines{};
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

/// The walk's end as printed ("too deep", "jump", ...).
const char* walk_end_name(std::size_t end);

}  // namespace palpa::bench
