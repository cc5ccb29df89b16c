#pragma once
// The scene palpa-loop-bench runs and palpa-bench's hovering section ticks
// (palpa_bench_hover.h): the default organ's material and the paths of the
// three probes on top of it, so that the two measure the same thing.

#include "core/types.h"
#include "deform/material.h"

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>

namespace palpa::bench::loop_scene {

/// The organ's uniform material: 300 N/m per vertex, 2 N s/m, 1 g.
inline deform::Material material() {
  deform::Material m;
  m.stiffness = 300;
  m.damping = 2;
  m.mass = 1e-3;
  return m;
}

inline constexpr int kProbes = 3;
/// Probe i works around the vertex nearest (kProbeX[i], 0, 1) m, on top of
/// the organ, along that vertex's normal.
inline constexpr double kProbeX[kProbes] = {-0.05, 0.0, 0.05};
/// Period of a path (s) and how much later in it probe i starts (i kPhase, s).
inline constexpr double kPeriod = 3.0;
inline constexpr double kPhase = 0.7;

/// Where a probe is at time t (s) of its path: from 4 mm above `point`
/// along `normal` to 4 mm below and back (period kPeriod) while circling
/// 3 mm round it (period kPeriod / 2). m.
inline Vec3 path_point(const Vec3& point, const Vec3& normal, double t) {
  const Vec3 t1 = normal.unitOrthogonal(), t2 = normal.cross(t1);
  const double height = 0.004 - 0.008 * 0.5 * (1 - std::cos(2 * std::numbers::pi * t / kPeriod));
  const double a = 2 * std::numbers::pi * t / (kPeriod / 2);
  return point + height * normal + 0.003 * (std::cos(a) * t1 + std::sin(a) * t2);
}

}  // namespace palpa::bench::loop_scene
