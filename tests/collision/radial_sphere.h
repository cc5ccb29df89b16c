#pragma once
// A sphere whose vertex normals are exactly radial (p / |p|), for tests that
// check the contact query against closed forms: with these normals the
// interpolated normal at a point C of a triangle is parallel to C, so the
// foot of the interpolated normal through a probe lies on the ray from the
// centre through the probe, and the focal distance is the radius.

#include "mesh/generate.h"

#include <cstddef>

namespace palpa::test {

/// mesh::make_sphere(vertices, radius) (radius in m) with its normals set to p / |p|.
inline mesh::SurfaceMesh radial_sphere(std::size_t vertices, double radius) {
  mesh::SurfaceMesh m = mesh::make_sphere(vertices, radius);
  for (std::size_t i = 0; i < m.vertex_count(); ++i) m.normals[i] = m.positions[i].normalized();
  return m;
}

}  // namespace palpa::test
