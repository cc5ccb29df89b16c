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

namespace palpa::mesh {
struct SurfaceMesh;
}

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
  /// Such a tree knows no surface: clearance() bounds nothing.
  explicit VertexTree(std::span<const Vec3> positions, int leaf_size = 8);
  /// Builds over the mesh's positions and keeps each vertex's reach, the
  /// largest triangle_reach of the triangles around it (m), for clearance().
  explicit VertexTree(const mesh::SurfaceMesh& mesh, int leaf_size = 8);

  /// Full query from the root (branch and bound). Thread-safe, no allocation.
  NearestVertex nearest(const Vec3& query) const;

  /// Local search of section V.A: starts from cursor.leaf, climbs to the
  /// first box that contains the sphere around the query through the best
  /// candidate so far, searches below it, and updates the cursor. Same answer
  /// as nearest() (ties aside). No allocation.
  NearestVertex nearest_local(const Vec3& query, SearchCursor& cursor) const;

  /// A lower bound on the distance (m) from `query` to the surface of the
  /// mesh the tree was built from, capped at `cap` (m): the least, over the
  /// vertices, of their distance less their reach. Every point of the
  /// surface lies within its triangle's reach of one of that triangle's
  /// corners, so none is nearer. 0 for a tree built from positions alone, a
  /// mesh with a non-finite position or a non-finite query; a vertex used by
  /// no triangle counts with reach 0. Branch and bound from the root, boxes
  /// pruned by their distance less the largest reach inside them; no
  /// allocation.
  double clearance(const Vec3& query, double cap) const;

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
  // Depth-first branch and bound below `root`: bound(node) is a lower bound
  // on what any vertex below it can give, scan(leaf) lowers `best` over the
  // leaf's points; nodes whose bound is no less than best are pruned.
  template <class Bound, class Scan>
  void branch_and_bound(Index root, double& best, Bound bound, Scan scan) const;
  // Branch and bound below `root` with the running best (squared distance, m^2,
  // and tree position), which it lowers when it finds a nearer vertex.
  void search(Index root, const double q[3], double& best, Index& best_pos) const;
  // Largest reach (m) of each node's vertices, and of each vertex in tree
  // order, rounded up to float; empty when the tree knows no surface.
  std::vector<float> node_reach_;
  std::vector<float> point_reach_;

  int leaf_size_ = 8;
  int depth_ = 0;
  std::vector<Node> nodes_;
  std::vector<Index> order_;      // tree order -> original vertex index
  std::vector<Vec3> points_;      // positions in tree order
  std::vector<Index> leaf_of_;    // tree position -> leaf node (for cursors)
};

/// The farthest a point of the triangle abc lies from the nearest of its
/// corners, m: the circumradius when no angle exceeds 90 degrees; otherwise
/// the distance, along the longest edge, from an end of it to where the
/// perpendicular bisector of the other edge at that end meets it (the
/// larger of the two; half the edge for a degenerate triangle). NaN for
/// non-finite corners.
double triangle_reach(const Vec3& a, const Vec3& b, const Vec3& c);

/// Reference answer by testing every vertex (for tests and the benchmark).
NearestVertex nearest_brute_force(std::span<const Vec3> positions, const Vec3& query);

}  // namespace palpa::collision
