#pragma once
// palpa-bench, issue 8: meshes that are hard on the contact query, generated
// from the bench sphere (palpa_bench_meshes.cpp).

#include "mesh/surface_mesh.h"

#include <cstddef>

namespace palpa::bench {

/// A sphere of radius `radius` (m) with `fans` disks of radius `fan_radius`
/// (m, Euclidean, centres spread by a Fibonacci lattice) re-triangulated as
/// fans: every triangle touching the disk is removed and the hole filled
/// with one thin triangle per boundary edge, all meeting at the vertex
/// nearest the disk's centre (valence = the boundary's length: hundreds for
/// a 15 mm disk at 1M vertices). About `target_vertices` vertices.
mesh::SurfaceMesh make_fan_sphere(std::size_t target_vertices, double radius, int fans, double fan_radius);

/// A sphere whose every triangle (a, b, c) is split in three at a point just
/// inside its edge ab (2% of the way to c, projected onto the sphere): one
/// sliver (a, b, p) of aspect about 50 beside two ordinary triangles. About
/// `target_vertices` vertices (three times the sphere it starts from).
mesh::SurfaceMesh make_sliver_sphere(std::size_t target_vertices, double radius);

}  // namespace palpa::bench
