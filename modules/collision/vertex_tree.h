#pragma once
// The AABB tree of section V.A whose boxes hold vertices, not triangles:
// every child box lies inside its parent, and sibling boxes are separated by
// the median split plane, so a box that contains the search sphere contains
// every vertex that can be nearer. That makes the local search exact: it
// resumes from the last leaf and climbs until a box fully contains the
// sphere through the best candidate.

#include "core/types.h"

#include <span>
#include <vector>

namespace palpa::collision {

/// Result of a nearest-vertex query.
struct NearestVertex {
  Index vertex = kNoIndex;  ///< index into the positions given to build()
  double distance_sq = 0;   ///< squared distance, m^2
};

/// Per-probe memory of the local search (which leaf answered last). Plain
/// data; zero-initialised means "no previous answer".
struct SearchCursor {
  Index leaf = kNoIndex;
};

class VertexTree {
 public:
  VertexTree() = default;
  /// Builds over the given positions (m); leaf_size vertices at most per leaf.
  explicit VertexTree(std::span<const Vec3> positions, int leaf_size = 8);

  /// Full query from the root (branch and bound). Thread-safe, no allocation.
  NearestVertex nearest(const Vec3& query) const;

  /// Local search of section V.A: starts from cursor.leaf, climbs to the
  /// first box that contains the sphere around the query through the best
  /// candidate so far, searches below it, and updates the cursor. Same answer
  /// as nearest() (ties aside). No allocation.
  NearestVertex nearest_local(const Vec3& query, SearchCursor& cursor) const;

  std::size_t node_count() const { return nodes_.size(); }
  std::size_t vertex_count() const { return order_.size(); }
  /// Depth of the deepest leaf (root = 0).
  int depth() const;

  /// Checks the structural invariants (children inside parents, every vertex
  /// in exactly one leaf, inside its leaf's box); for tests.
  bool check_invariants() const;

 private:
  struct Node {
    float lo[3], hi[3];   // box, m (float; rounded outward so it still contains its vertices)
    Index parent;         // kNoIndex for the root
    Index left, right;    // children; kNoIndex for a leaf
    Index begin, end;     // range into order_/points_ (leaves and inner nodes)
  };
  // Deepest search stack any query needs (median splits keep depth <= 32).
  static constexpr int kMaxDepth = 64;

  Index build_node(std::span<const Vec3> positions, Index begin, Index end, Index parent, int depth);
  // Branch and bound below `root` with the running best (squared distance, m^2,
  // and tree position), which it lowers when it finds a nearer vertex.
  void search(Index root, const double q[3], double& best, Index& best_pos) const;

  int leaf_size_ = 8;
  int depth_ = 0;
  std::vector<Node> nodes_;
  std::vector<Index> order_;      // tree order -> original vertex index
  std::vector<Vec3> points_;      // positions in tree order
  std::vector<Index> leaf_of_;    // tree position -> leaf node (for cursors)
};

/// Reference answer by testing every vertex (for tests and the benchmark).
NearestVertex nearest_brute_force(std::span<const Vec3> positions, const Vec3& query);

}  // namespace palpa::collision
