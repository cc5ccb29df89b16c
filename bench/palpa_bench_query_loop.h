#pragma once
// palpa-bench --query-loop: the haptic tick's contact query
// (collision::track_contact) alone, along the bench's probe paths, with
// nothing else in the loop. For profilers (callgrind counts its
// instructions per query: collect only in palpa::collision::track_contact*)
// and to check that a change of the query keeps every answer's bits (the
// hash of the first pass's answers).

#include "collision/vertex_tree.h"
#include "mesh/surface_mesh.h"
#include "palpa_bench_path.h"

#include <cstddef>
#include <cstdint>

namespace palpa::bench {

struct QueryLoopResult {
  std::size_t queries = 0;  ///< per pass: ticks x probes
  int passes = 0;
  /// FNV-1a over every answer of the first pass (triangle, weights, point,
  /// normal, offset, nearest vertex, path), in order: equal hashes, equal bits.
  std::uint64_t answer_hash = 0;
  double best_ns_per_query = 0;    ///< the fastest pass's time over its queries (steady_clock), ns
  double median_ns_per_query = 0;  ///< the median pass's, ns
  std::size_t walk = 0, proxy = 0, tree = 0, clear = 0;  ///< first pass: answers per path
};

/// Runs `passes` passes of track_contact for the first `probes` probes of
/// `paths`, every tick, each pass from fresh cursors (in contact as the bench
/// says it: the last answer below the undeformed surface).
QueryLoopResult run_query_loop(const mesh::SurfaceMesh& mesh, const collision::VertexTree& tree,
                               const ProbePaths& paths, int probes, int passes);

}  // namespace palpa::bench
