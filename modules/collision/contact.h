#pragma once
// Contact point interpolation and the 1-D height check (section III.C).

#include "collision/vertex_tree.h"
#include "mesh/surface_mesh.h"

namespace palpa::collision {

/// The virtual vertex under a probe: the point on a triangle of the
/// undeformed surface whose interpolated normal passes through the probe.
struct SurfacePoint {
  Index triangle = kNoIndex;
  Vec3 barycentric = Vec3::Zero();  ///< weights of the triangle's vertices (sum 1)
  Vec3 point = Vec3::Zero();        ///< on the undeformed surface, m
  Vec3 normal = Vec3::UnitZ();      ///< interpolated undeformed normal, unit
  double offset = 0;                ///< (probe - point) . normal, m (negative = below the undeformed surface)
  bool inside = false;              ///< barycentric weights all within the triangle (else clamped to its edge)
};

/// Finds the surface point for `probe` among the triangles around
/// `nearest_vertex` (its one-ring, widened to the neighbours' rings when no
/// triangle contains the projection). No allocation.
SurfacePoint locate_surface_point(const mesh::SurfaceMesh& mesh, const Vec3& probe, Index nearest_vertex);

/// Result of the height check: the probe against the current deformed height
/// interpolated at the virtual vertex.
struct HeightCheck {
  double surface_height = 0;  ///< interpolated h at the virtual vertex, m
  double depth = 0;           ///< -offset: penetration below the undeformed surface, m
  bool in_contact = false;    ///< offset < 0 and offset <= surface_height
};

/// The 1-D height check: the probe touches the surface when it lies below
/// the undeformed surface and not above the current deformed one along the
/// interpolated normal. `heights` holds the current h (m) of the three
/// vertices of sp.triangle, in the triangle's vertex order.
HeightCheck height_check(const SurfacePoint& sp, const Vec3& heights);

}  // namespace palpa::collision
