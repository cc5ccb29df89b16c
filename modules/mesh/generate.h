#pragma once
// Procedural meshes: test spheres and planes, and the bundled default organ.

#include "mesh/surface_mesh.h"

namespace palpa::mesh {

/// A closed sphere centred at `center` (m) with radius `radius` (m) and
/// 6 n^2 + 2 vertices, n = round(sqrt((target_vertices - 2) / 6)) >= 1: a cube
/// with n x n cells per face projected onto the sphere (equi-angular, so
/// triangles are well shaped). Vertices lie exactly on the sphere.
SurfaceMesh make_sphere(std::size_t target_vertices, double radius, const Vec3& center = Vec3::Zero());

/// An open flat grid in the z = 0 plane, normals +z, nx by ny vertices (each at
/// least 2), spacing in m, centred on the origin.
SurfaceMesh make_plane(int nx, int ny, double spacing);

/// The default organ: a closed, liver-like genus-0 surface defined by an
/// implicit function (a tapered wedge with a thick right and a thin left lobe,
/// a falciform groove, an umbilical notch and a hollow back border), sampled
/// along the rays of make_sphere's cube-sphere from organ_center(), so it has
/// as many vertices as make_sphere(target_vertices, ...). About 0.21 x 0.14 x 0.09 m
/// (x: right lobe to left lobe tip, y: front to back, z: up), about 1.1 litres.
SurfaceMesh make_organ(std::size_t target_vertices);

/// The default organ's implicit function at p (m): negative inside, positive
/// outside, zero on the surface. Near the surface its magnitude is roughly the
/// distance to it (m), but only its sign is relied on.
double organ_implicit(const Vec3& p);

/// The point the default organ is star-shaped around (m): every ray from it
/// crosses the surface exactly once, which make_organ relies on.
Vec3 organ_center();

}  // namespace palpa::mesh
