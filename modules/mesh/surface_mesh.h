#pragma once
// The undeformed organ surface: a closed, consistently oriented triangle mesh
// in metres with unit outward vertex normals and vertex adjacency. It does not
// change during a session (the per-tick state lives in deform::SurfaceState).

#include "core/types.h"

#include <array>
#include <span>
#include <vector>

namespace palpa::mesh {

/// Compressed sparse rows: items of row i are items[offsets[i] .. offsets[i+1]).
struct Csr {
  std::vector<Index> offsets;  ///< size rows+1
  std::vector<Index> items;

  std::span<const Index> row(Index i) const {
    return {items.data() + offsets[i], items.data() + offsets[i + 1]};
  }
  std::size_t rows() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};

using Triangle = std::array<Index, 3>;

/// A triangle surface in metres. Triangles are counter-clockwise seen from
/// outside (right-hand rule gives the outward normal).
struct SurfaceMesh {
  std::vector<Vec3> positions;     ///< undeformed vertex positions, m
  std::vector<Triangle> triangles; ///< vertex indices, outward orientation
  std::vector<Vec3> normals;       ///< unit outward vertex normals (area-weighted)
  Csr vertex_neighbors;            ///< one-ring vertices of each vertex, sorted
  Csr vertex_triangles;            ///< triangles incident to each vertex
  /// Per triangle, the triangle across the edge opposite each corner k (the
  /// edge from corner k+1 to corner k+2, mod 3); kNoIndex on a border edge or
  /// an edge shared by more than two triangles.
  std::vector<Triangle> triangle_neighbors;

  std::size_t vertex_count() const { return positions.size(); }
  std::size_t triangle_count() const { return triangles.size(); }
};

/// Computes area-weighted unit vertex normals from the triangles (a vertex
/// with no non-degenerate incident triangle gets (0,0,1)).
void compute_normals(SurfaceMesh& mesh);

/// Builds vertex_neighbors, vertex_triangles and triangle_neighbors from the triangles.
void build_adjacency(SurfaceMesh& mesh);

/// compute_normals + build_adjacency.
void finalize(SurfaceMesh& mesh);

/// Facts about a mesh's topology and geometry.
struct MeshFacts {
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  std::size_t boundary_edges = 0;     ///< edges with exactly one triangle
  std::size_t nonmanifold_edges = 0;  ///< edges with more than two triangles
  std::size_t components = 0;         ///< connected components of triangles (sharing a vertex)
  long euler_characteristic = 0;      ///< V - E + F
  double area = 0;                    ///< total area, m^2
  double signed_volume = 0;           ///< m^3 (divergence theorem about the bbox centre);
                                      ///< positive when closed and oriented outward
  Vec3 bbox_min = Vec3::Zero();       ///< m
  Vec3 bbox_max = Vec3::Zero();       ///< m
  bool closed() const { return boundary_edges == 0 && nonmanifold_edges == 0; }
  bool manifold() const { return nonmanifold_edges == 0; }
  /// Edge-consistent orientation: every interior edge is used once in each
  /// direction (no directed edge twice; so false whenever an edge has > 2 triangles).
  bool consistently_oriented = false;
  /// Closed, consistently oriented and enclosing a positive volume: seen
  /// from outside, every back face lies behind a front face, so drawing
  /// may skip the back faces without changing the picture.
  bool closed_outward() const { return closed() && consistently_oriented && signed_volume > 0; }
};

/// Measures the facts of a mesh (O(V + F log F)).
MeshFacts analyse(const SurfaceMesh& mesh);

}  // namespace palpa::mesh
