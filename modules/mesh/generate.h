#pragma once
// Procedural meshes: test spheres and planes, the bundled default organ and
// the organ shapes of the shipped training scenarios (breast, abdomen).

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

/// A breast on a flat chest wall: a closed genus-0 surface, a slightly drooping
/// hemi-ellipsoidal dome (base ellipse 0.140 m in x by 0.138 m in y, the lower
/// pole, -y, the fuller; apex sheared 0.010 m towards -y) with a raised areola
/// (1.5 mm high, about 4 cm across) and a nipple (5 mm high, about 1 cm
/// across) on the apex, 0.060 m high in all,
/// closed underneath by the flat chest-wall side in the z = 0 plane. The rim
/// where dome and base meet is rounded by a smooth maximum (blend width 8 mm;
/// it takes about 1 mm off the base width), so normals there are well defined.
/// Frame: base centred at the origin in x, y, dome towards +z, +y cranial.
/// About 0.54 litres.
/// Sampled like make_organ (as many vertices as make_sphere(target_vertices, ...)).
SurfaceMesh make_breast(std::size_t target_vertices);
/// The breast's implicit function (m): negative inside, positive outside.
double breast_implicit(const Vec3& p);
/// The point the breast is star-shaped around (m).
Vec3 breast_center();

/// An abdomen: a closed genus-0 slab, a box 0.30 m (x, left-right) by 0.22 m
/// (y, head-foot) by 0.12 m (z) with vertical edges rounded in plan (radius
/// 0.05 m), a flat back in the plane z = -0.06 and a gently bulging belly on
/// top, z = 0.06 - 0.020 (x / 0.15)^2 - 0.012 (y / 0.11)^2 (so 0.06 at the
/// centre), joined to the flanks and the back by smooth maxima (blend widths
/// 3 cm and 1 cm). Convex, about 6.9 litres. Centred at the origin, belly up,
/// metres. The belly is exactly that paraboloid, untouched by the roundings,
/// over |x| < 0.11, |y| < 0.07, where a scenario lays vessels under it.
/// Sampled like make_organ.
SurfaceMesh make_abdomen(std::size_t target_vertices);
/// The abdomen's implicit function (m): negative inside, positive outside.
double abdomen_implicit(const Vec3& p);
/// The point the abdomen is star-shaped around (m).
Vec3 abdomen_center();

}  // namespace palpa::mesh
