#pragma once
// Local models (section III.A): each vertex is an independent 1-DoF system
// along its undeformed normal. All models share one interface; integration is
// unconditionally stable for any positive parameters and time step.

#include "deform/material.h"

namespace palpa::deform {

/// State of one vertex's local model.
struct VertexState {
  double h = 0;  ///< height along the undeformed normal, m (negative = pushed in)
  double v = 0;  ///< dh/dt, m/s
  double q = 0;  ///< Viscoelastic only: dashpot elongation of the Maxwell arm, m
};

/// The interface every local model implements.
class LocalModel {
 public:
  virtual ~LocalModel() = default;
  virtual LocalModelKind kind() const = 0;

  /// Advances `s` by dt seconds under a constant external force f (N, along
  /// the outward normal). Stable for any mass, damping, stiffness > 0 and dt > 0.
  virtual void step(const Material& m, VertexState& s, double f, double dt) const = 0;

  /// Static force (N, along the outward normal) that holds the vertex at
  /// height h at equilibrium (a relaxed Maxwell arm for Viscoelastic: force k h).
  /// Used by force fields to drive vertices to the shape function's surface.
  virtual double equilibrium_force(const Material& m, double h) const = 0;

  /// Instantaneous restoring force (N, along the outward normal, so >= 0 when
  /// pushed in) of a vertex at height h moving at velocity v with internal state q.
  /// Used by the haptic force of eq. (4) on the interpolated virtual vertex.
  virtual double restoring_force(const Material& m, double h, double v, double q) const = 0;
};

/// The shared instance of each model.
const LocalModel& local_model(LocalModelKind kind);

/// Exact discretisation of eq. (1) over one step of dt seconds with the force
/// held constant during the step (zero-order hold): with x = (h, v) and
/// h_f = f / k, x' - (h_f, 0) = exp(A dt) (x - (h_f, 0)), A = [[0, 1], [-k/m, -b/m]].
/// Stable for any m, k, dt > 0 and b >= 0 (it is the exact flow), and its fixed
/// point is exactly h = f / k. make() does the transcendental work once so
/// apply() is five multiply-adds; DeformableSurface caches one per material.
struct LinearStep {
  double p00 = 1, p01 = 0, p10 = 0, p11 = 1;  ///< exp(A dt): 1, s, 1/s, 1
  double inv_k = 0;                           ///< 1 / stiffness, m/N

  /// Coefficients for material m (its mass, damping, stiffness) and step dt (s > 0).
  static LinearStep make(const Material& m, double dt);

  /// Advances s by one step under the constant force f (N).
  void apply(VertexState& s, double f) const {
    const double hf = f * inv_k;
    const double dh = s.h - hf;
    const double v = s.v;
    s.h = hf + p00 * dh + p01 * v;
    s.v = p10 * dh + p11 * v;
  }
};

/// Spring force s(h) of the Exponential model, N (same sign as h):
/// sign(h) k (exp(alpha |h|) - 1) / alpha, k h when alpha = 0. Beyond
/// alpha |h| = kExponentialCap it continues linearly with the slope it has
/// there (C1, still convex), so forces stay finite for any finite h.
double exponential_spring(const Material& m, double h);

/// Spring force s(h) of the Hertz model, N (same sign as h):
/// sign(h) hertz ((|h| + d0)^1.5 - d0^1.5)(1 + alpha |h|), d0 = kHertzSoftening.
double hertz_spring(const Material& m, double h);

/// alpha |h| beyond which the Exponential spring continues linearly.
inline constexpr double kExponentialCap = 40.0;

}  // namespace palpa::deform
