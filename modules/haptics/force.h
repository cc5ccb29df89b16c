#pragma once
// The haptic force of eq. (4) (section III.E): a normal reaction from the
// local model at the interpolated virtual vertex plus friction from the probe
// velocity, clamped to the device's maximum force.

#include "core/types.h"

namespace palpa::haptics {

struct ForceParams {
  /// K of eq. (4): friction coefficient, dimensionless (tangential / normal).
  double friction = 0.3;
  /// Below this tangential speed (m/s) friction grows linearly with speed
  /// instead of jumping, so a probe at rest feels no chatter.
  double slip_speed = 1e-3;
  /// Maximum force magnitude, N: larger forces are scaled down, direction kept.
  double max_force = 10.0;
};

/// eq. (4): F = Fn N + Fn K (-T / |T|), where T is the tangential part of the
/// probe velocity v (m/s) with respect to the unit normal N, Fn >= 0 the
/// normal reaction (N) from the local model. Friction opposes the sliding
/// direction; |T| is regularised below slip_speed. Returns N, before clamping.
Vec3 contact_force(double normal_reaction, const Vec3& normal, const Vec3& velocity, const ForceParams& p);

/// Scales f so that |f| <= max_force holds exactly as f.norm() computes it
/// (direction kept); non-finite input or limit gives zero. N. When `clamped`
/// is given, it says whether the force was scaled down.
Vec3 clamp_force(const Vec3& f, double max_force, bool* clamped = nullptr);

}  // namespace palpa::haptics
