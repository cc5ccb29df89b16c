// The haptic force of eq. (4) and the device-limit clamp.

#include "haptics/force.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace palpa::haptics {

Vec3 contact_force(double normal_reaction, const Vec3& normal, const Vec3& velocity, const ForceParams& p) {
  // eq. (4): tangential velocity T = v - <v, N> N.
  const Vec3 tangential = velocity - velocity.dot(normal) * normal;
  // eq. (4): F_f = Fn N + Fn K (-T / |T|); below slip_speed the friction
  // grows linearly with |T| (|T| replaced by slip_speed) instead of jumping.
  const double speed = tangential.norm();
  const double scale = std::max(speed, p.slip_speed);
  Vec3 force = normal_reaction * normal;
  if (scale > 0) force -= (normal_reaction * p.friction / scale) * tangential;
  return force;
}

Vec3 clamp_force(const Vec3& f, double max_force, bool* clamped) {
  if (clamped) *clamped = false;
  // Non-finite input or limit: no force.
  if (!f.allFinite() || !(max_force >= 0) || !std::isfinite(max_force)) return Vec3::Zero();
  // Compute the magnitude without overflow (components may be near DBL_MAX).
  const double big = f.cwiseAbs().maxCoeff();
  if (big == 0) return Vec3::Zero();
  const Vec3 unit_scaled = f / big;
  const double magnitude = big * unit_scaled.norm();
  if (magnitude <= max_force) return f;
  // Scale the whole vector: direction kept, magnitude max_force. Rounding can
  // leave the norm an ulp or two above the limit; shrink by ulps until it is not.
  if (clamped) *clamped = true;
  Vec3 out = unit_scaled * (max_force / unit_scaled.norm());
  for (int i = 0; i < 8 && out.norm() > max_force; ++i) out *= 1.0 - 4 * std::numeric_limits<double>::epsilon();
  return out.norm() <= max_force ? out : Vec3::Zero();
}

}  // namespace palpa::haptics
