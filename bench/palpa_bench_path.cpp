// Deterministic probe trajectories for palpa-bench.

#include "palpa_bench_path.h"

#include "palpa_bench_util.h"

#include <Eigen/Geometry>

#include <cmath>

namespace palpa::bench {

namespace {

// Smooth normal at a point of a triangle: barycentric blend of the vertex
// normals (falls back to the face normal when the blend vanishes).
Vec3 interpolated_normal(const mesh::SurfaceMesh& mesh, Index tri, const Vec3& p) {
  const auto& t = mesh.triangles[tri];
  const Vec3& a = mesh.positions[t[0]];
  const Vec3& b = mesh.positions[t[1]];
  const Vec3& c = mesh.positions[t[2]];
  const Vec3 face = (b - a).cross(c - a);
  const double area2 = face.squaredNorm();
  Vec3 w(1.0 / 3, 1.0 / 3, 1.0 / 3);
  if (area2 > 0) {
    w[0] = (b - p).cross(c - p).dot(face) / area2;
    w[1] = (c - p).cross(a - p).dot(face) / area2;
    w[2] = 1.0 - w[0] - w[1];
  }
  const Vec3 n = w[0] * mesh.normals[t[0]] + w[1] * mesh.normals[t[1]] + w[2] * mesh.normals[t[2]];
  if (n.norm() > 1e-12) return n.normalized();
  return area2 > 0 ? Vec3(face.normalized()) : Vec3(Vec3::UnitZ());
}

// Unit vector in the plane orthogonal to n, as close to d as possible.
Vec3 tangent(const Vec3& d, const Vec3& n) {
  Vec3 t = d - d.dot(n) * n;
  if (t.norm() < 1e-9) t = n.unitOrthogonal();
  return t.normalized();
}

}  // namespace

ProbePaths make_probe_paths(const mesh::SurfaceMesh& mesh, const CgalClosestPoint& cgal,
                            const PathOptions& o) {
  ProbePaths paths;
  paths.probes = o.probes;
  paths.ticks = o.ticks;
  paths.position.resize(o.ticks * o.probes);
  paths.velocity.resize(o.ticks * o.probes);
  Random rng(o.seed);
  const double step = o.speed * o.dt;
  for (int p = 0; p < o.probes; ++p) {
    // Seeded start vertex and heading.
    const auto v0 = static_cast<Index>(rng.below(mesh.vertex_count()));
    CgalHit hit = cgal.closest_point_and_triangle(mesh.positions[v0]);
    Vec3 n = interpolated_normal(mesh, hit.triangle, hit.point);
    const Vec3 random_dir(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5);
    Vec3 heading = tangent(random_dir, n);
    Vec3 previous = hit.point - o.depth * n;
    for (std::size_t k = 0; k < o.ticks; ++k) {
      // Probe below the current surface point; velocity by finite difference.
      const Vec3 probe = hit.point - o.depth * n;
      paths.position[k * o.probes + p] = probe;
      paths.velocity[k * o.probes + p] = k == 0 ? Vec3(o.speed * heading) : Vec3((probe - previous) / o.dt);
      previous = probe;
      // Turn the heading about the normal by a seeded angle, slide, project
      // back onto the surface and keep the heading tangent there.
      const double a = (2 * rng.uniform() - 1) * o.turn;
      heading = std::cos(a) * heading + std::sin(a) * n.cross(heading);
      hit = cgal.closest_point_and_triangle(hit.point + step * heading);
      n = interpolated_normal(mesh, hit.triangle, hit.point);
      heading = tangent(heading, n);
    }
  }
  return paths;
}

}  // namespace palpa::bench
