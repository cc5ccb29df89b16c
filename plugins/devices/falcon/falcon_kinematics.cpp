#include "falcon_kinematics.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace palpa::plugins::falcon {

namespace {

constexpr double kDegPerCount = 14.25 * 360.0 / (320.0 * 4.0 * 110.0);
constexpr double kOffsetDeg = 35.0;
constexpr double kDeg = std::numbers::pi / 180.0;

}  // namespace

Geometry::Geometry() {
  const double tilt = std::numbers::pi / 12;  // 15 degrees
  phi = {std::numbers::pi / 2 + tilt, -std::numbers::pi / 6 + tilt, -5 * std::numbers::pi / 6 + tilt};
}

double encoder_to_angle(std::int16_t counts) { return (kOffsetDeg + counts * kDegPerCount) * kDeg; }

std::int16_t angle_to_encoder(double angle) {
  const double counts = std::round((angle / kDeg - kOffsetDeg) / kDegPerCount);
  return static_cast<std::int16_t>(std::clamp(counts, -32768.0, 32767.0));
}

// Closed form per leg (see the header).
bool Kinematics::inverse(const Vec3& p, Vec3& angles) const {
  if (!p.allFinite()) return false;
  for (int i = 0; i < 3; ++i) {
    const double cp = std::cos(g_.phi[i]), sp = std::sin(g_.phi[i]);
    const double u = cp * p[0] + sp * p[1] - g_.r;
    const double v = -sp * p[0] + cp * p[1] - g_.s;
    const double w = p[2];
    const double cos3 = (v + g_.f) / g_.b;
    if (!(cos3 >= -1.0 && cos3 <= 1.0)) return false;
    const double sin3 = std::sqrt(1.0 - cos3 * cos3);
    const double L = g_.d + g_.e + g_.b * sin3;
    const double A = u + g_.c, B = w;
    const double rho = std::hypot(A, B);
    if (!(rho > 0)) return false;
    const double K = (rho * rho + g_.a * g_.a - L * L) / (2 * g_.a);
    const double q = K / rho;
    if (!(q >= -1.0 && q <= 1.0)) return false;
    angles[i] = std::atan2(B, A) - std::acos(q);
  }
  return true;
}

// Implicit differentiation of G(theta1, p) = (A - a cos t)^2 + (B - a sin t)^2 - L(v)^2 = 0:
// d theta1 / dp = -(dG/dp) / (dG/dtheta1).
bool Kinematics::angle_jacobian(const Vec3& p, Mat3& J) const {
  Vec3 theta;
  if (!inverse(p, theta)) return false;
  for (int i = 0; i < 3; ++i) {
    const double cp = std::cos(g_.phi[i]), sp = std::sin(g_.phi[i]);
    const double u = cp * p[0] + sp * p[1] - g_.r;
    const double v = -sp * p[0] + cp * p[1] - g_.s;
    const double cos3 = (v + g_.f) / g_.b;
    const double sin3 = std::sqrt(std::max(0.0, 1.0 - cos3 * cos3));
    if (!(sin3 > 1e-9)) return false;
    const double L = g_.d + g_.e + g_.b * sin3;
    const double A = u + g_.c, B = p[2];
    const double c1 = std::cos(theta[i]), s1 = std::sin(theta[i]);
    const double dG_dt = 2 * g_.a * (A * s1 - B * c1);
    if (!(std::abs(dG_dt) > 1e-15)) return false;
    const double dG_dA = 2 * (A - g_.a * c1);
    const double dG_dB = 2 * (B - g_.a * s1);
    const double dL_dv = -cos3 / sin3;           // L = d + e + b sqrt(1 - ((v + f)/b)^2)
    const double dG_dv = -2 * L * dL_dv;
    // Chain rule through u(x, y), v(x, y), w = z.
    const Vec3 dG_dp(dG_dA * cp + dG_dv * -sp, dG_dA * sp + dG_dv * cp, dG_dB);
    J.row(i) = -dG_dp.transpose() / dG_dt;
  }
  return J.allFinite();
}

// Newton: p <- p - A^-1 (theta(p) - target).
bool Kinematics::forward(const Vec3& target, Vec3& p) const {
  if (!target.allFinite() || !p.allFinite()) return false;
  Vec3 x = p;
  for (int it = 0; it < 30; ++it) {
    Vec3 theta;
    Mat3 A;
    if (!inverse(x, theta) || !angle_jacobian(x, A)) return false;
    const Vec3 err = theta - target;
    if (err.cwiseAbs().maxCoeff() < 1e-10) {
      p = x;
      return true;
    }
    Eigen::FullPivLU<Mat3> lu(A);
    if (!lu.isInvertible()) return false;
    Vec3 step = lu.solve(err);
    // Keep steps modest so the iterate stays reachable.
    const double n = step.norm();
    if (n > 0.02) step *= 0.02 / n;
    x -= step;
  }
  return false;
}

bool Kinematics::torques(const Vec3& p, const Vec3& force, Vec3& tau) const {
  Mat3 A;
  if (!angle_jacobian(p, A)) return false;
  Eigen::FullPivLU<Mat3> lu(A.transpose());
  if (!lu.isInvertible()) return false;
  tau = lu.solve(force);
  return tau.allFinite();
}

}  // namespace palpa::plugins::falcon
