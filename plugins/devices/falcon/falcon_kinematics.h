#pragma once
// Kinematics of the Novint Falcon, a delta robot with three parallelogram
// legs (R. E. Stamper's parameterisation; dimensions as documented in
// libnifalcon). Our own derivation and code, SI units.
//
// Device frame: origin at the centre of the base, z pointing out of the
// device toward the user, x right, y up; the workspace is about a 0.1 m cube
// centred near z = 0.11 m.
//
// Leg i sits at angle phi_i around z. In its frame (u along the leg, v along
// the motor axis, w = z):
//   u = cos(phi) x + sin(phi) y - r,   v = -sin(phi) x + cos(phi) y - s,   w = z.
// With theta1 the motor (upper arm) angle, theta3 the out-of-plane angle of
// the parallelogram and L = d + e + b sin(theta3):
//   v + f = b cos(theta3)
//   (u + c - a cos(theta1))^2 + (w - a sin(theta1))^2 = L^2
// so theta1 = atan2(w, u + c) - acos(K / rho), rho = |(u + c, w)|,
// K = (rho^2 + a^2 - L^2) / (2 a) (the knee-out branch).
//
// Encoders: 320 slots x 4 (quadrature) per motor turn, capstan 14.25 mm on an
// arm drum of 110 mm, 35 degrees at encoder 0:
//   theta1 = 35 deg + counts * (14.25 * 360) / (1280 * 110) deg.
// Motor commands: torque (N m) times -10000, as int16.

#include <Eigen/Core>
#include <array>
#include <cstdint>

namespace palpa::plugins::falcon {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

struct Geometry {
  double a = 0.060;        ///< upper arm length, m
  double b = 0.1025;       ///< parallelogram side, m
  double c = 0.014;        ///< end effector offset along u, m
  double d = 0.01125;      ///< parallelogram to end effector joint, m
  double e = 0.01125;      ///< knee to parallelogram joint, m
  double f = -0.025;       ///< end effector offset along v, m
  double r = 0.037233758;  ///< leg base offset along u, m
  double s = -0.027330909; ///< leg base offset along v, m
  std::array<double, 3> phi{};  ///< leg angles around z, rad: 90, -30, -150 degrees + 15 degrees tilt
  Geometry();
};

/// Motor angle (rad) of an encoder count.
double encoder_to_angle(std::int16_t counts);
/// Nearest encoder count of a motor angle (rad), saturated to int16.
std::int16_t angle_to_encoder(double angle);

/// Motor command units per N m of torque (the command is -torque * this).
inline constexpr double kTorqueScale = 10000.0;

class Kinematics {
 public:
  explicit Kinematics(const Geometry& g = Geometry()) : g_(g) {}
  const Geometry& geometry() const { return g_; }

  /// Motor angles theta1 (rad) of the three legs for end effector position p
  /// (m). False when p is out of reach (then `angles` is unspecified).
  bool inverse(const Vec3& p, Vec3& angles) const;

  /// A(i, j) = d theta1_i / d p_j (rad/m) at p, by implicit differentiation
  /// of the leg closure. False out of reach or at a singular pose.
  bool angle_jacobian(const Vec3& p, Mat3& A) const;

  /// Position (m) whose motor angles are `angles` (rad), by Newton's method
  /// started from `p` (in: guess, out: solution). False when it does not
  /// converge to 1e-10 rad within 30 iterations (p then holds the guess).
  bool forward(const Vec3& angles, Vec3& p) const;

  /// Motor torques (N m) that produce force F (N) on the end effector at p:
  /// A^T tau = F (virtual work: tau . dtheta = F . dp). False at a singular pose.
  bool torques(const Vec3& p, const Vec3& force, Vec3& tau) const;

 private:
  Geometry g_;
};

}  // namespace palpa::plugins::falcon
