#pragma once
// Spatial vertex and triangle order: numbering vertices along a Hilbert curve
// through the bounding box so that vertices close on the surface are close in
// memory. A contact's field, the deformation step's active set, the tick's
// walk and the renderer's vertex fetch then touch a few contiguous runs of
// each per-vertex array instead of lines scattered over all of it.

#include "mesh/surface_mesh.h"

#include <cstdint>
#include <vector>

namespace palpa::mesh {

/// Position of p along a 3-D Hilbert curve through the box [lo, hi] (m),
/// each axis quantised to 2^20 cells; points outside are clamped to the box.
/// Neighbouring keys are neighbouring cells.
std::uint64_t hilbert_key(const Vec3& p, const Vec3& lo, const Vec3& hi);

/// Renumbers the vertices in Hilbert order of their positions (ties keep
/// their old order) and sorts the triangles by their smallest, middle and
/// largest new vertex index; each triangle keeps its corners' cyclic order,
/// so its orientation. Normals (when the mesh had them) are computed again
/// from the renumbered mesh (compute_normals: the same vectors up to
/// rounding, and bit for bit what a session file's reader computes from the
/// positions and triangles it keeps); adjacency (vertex_neighbors,
/// vertex_triangles, triangle_neighbors) is rebuilt when the mesh had it.
/// The geometry, the topology and every other per-vertex value are those
/// of the input, only numbered differently; normals a caller set by other
/// means are replaced by compute_normals'. Idempotent: a second call
/// changes nothing. Returns new_of_old (size:
/// the vertex count): vertex i of the input is vertex new_of_old[i].
std::vector<Index> reorder_spatially(SurfaceMesh& mesh);

/// True when `loaded` has exactly the positions and triangles of `recorded`,
/// or of `recorded` renumbered by reorder_spatially: the same organ file,
/// recorded before or after organs were numbered in spatial order
/// (2026-12-03). Bitwise comparison; O(V log V) when a renumbering is tried.
bool same_mesh_up_to_spatial_order(const SurfaceMesh& recorded, const SurfaceMesh& loaded);

}  // namespace palpa::mesh
