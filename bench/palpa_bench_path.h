#pragma once
// Deterministic probe trajectories for palpa-bench: probes slide over the
// surface at a constant speed, a fixed depth below it, turning by seeded
// random angles; sampled once per haptic tick.

#include "core/types.h"
#include "mesh/surface_mesh.h"
#include "palpa_bench_cgal.h"

#include <cstdint>
#include <vector>

namespace palpa::bench {

struct PathOptions {
  int probes = 3;
  std::size_t ticks = 0;     ///< samples per probe
  double dt = 1e-3;          ///< tick period, s (1 kHz)
  double speed = 0.03;       ///< sliding speed along the surface, m/s
  double depth = 1e-3;       ///< probe below the undeformed surface along its normal, m
  double turn = 0.05;        ///< largest heading change per tick, rad (uniform in [-turn, turn])
  std::uint64_t seed = 1;
};

/// Probe positions and velocities, tick-major: entry [tick * probes + probe].
struct ProbePaths {
  int probes = 0;
  std::size_t ticks = 0;
  std::vector<Vec3> position;  ///< m
  std::vector<Vec3> velocity;  ///< m/s, finite difference of positions (first tick: speed * heading)

  const Vec3& at(std::size_t tick, int probe) const { return position[tick * probes + probe]; }
  const Vec3& velocity_at(std::size_t tick, int probe) const { return velocity[tick * probes + probe]; }
};

/// Generates the paths. Each probe starts at a seeded random vertex with a
/// seeded random heading; every tick its surface point moves speed * dt along
/// the heading and is projected back onto the triangles with CGAL's closest
/// point (an independent reference, not the code under test); the probe is
/// that point minus depth along the interpolated vertex normal there.
ProbePaths make_probe_paths(const mesh::SurfaceMesh& mesh, const CgalClosestPoint& cgal,
                            const PathOptions& options);

}  // namespace palpa::bench
