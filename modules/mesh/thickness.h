#pragma once
// Local thickness and curvature of a closed surface, per vertex: how far a
// vertex can be drawn inwards along its normal before the surface passes
// through itself (the opposite side of a thin part, or the neighbours'
// normals crossing at the centre of curvature).

#include "mesh/surface_mesh.h"

#include <memory>
#include <vector>

namespace palpa::mesh {

/// Per vertex: the distance (m) from the vertex along its inward normal
/// (-normal) to the first triangle of the mesh the ray meets, triangles
/// incident to the vertex excepted; +infinity when the ray meets none (an
/// open mesh, or a vertex with a zero normal). Needs positions, triangles
/// and normals (finalize()). Uses a bounding-volume hierarchy of the
/// triangles, O(T log T) to build, and casts the rays on up to 8 threads.
/// Deterministic (the same bits however the rays are shared out).
std::vector<double> inward_thickness(const SurfaceMesh& mesh);

/// inward_thickness(*mesh) (m per vertex), shared by mesh object: while a
/// result is held (by anyone), a later call for the same mesh object returns
/// it instead of casting the rays again. A session's coverage holds it for
/// its life; its surfaces' drawn limits (deform) are computed from it and
/// keep only the limits, so they reuse the coverage's rays when the coverage
/// is made first (palpa-replay and palpa-assess make it first). The mesh
/// must not change while shared (Palpa's meshes are const once built).
/// Thread-safe.
std::shared_ptr<const std::vector<double>> shared_inward_thickness(const std::shared_ptr<const SurfaceMesh>& mesh);

/// Per vertex: the convex radius of curvature (m), the smallest
/// |p_j - p_i| / |n_j - n_i| over the neighbours j whose normals converge
/// inwards with vertex i's ((n_j - n_i) . (p_j - p_i) > 0): pushing i and j
/// that far inwards along their normals brings them together (on a sphere
/// of radius R with radial normals it is R). +infinity where no neighbour
/// converges (flat or concave). Needs normals and vertex_neighbors.
std::vector<double> convex_radius(const SurfaceMesh& mesh);

}  // namespace palpa::mesh
