#pragma once
// Shape functions (section III.B): the equilibrium shape of the surface around
// a contact as a function of the distance r (m) from the contact point,
// normalised so that S(0) = 1. Their derivatives give the normal corrections
// of eq. (3).

namespace palpa::deform {

enum class ShapeKind : unsigned char {
  /// exp(-r^2 / (2 sigma^2)) with sigma = radius / 4, cut to 0 at r >= radius.
  Gaussian = 0,
  /// Wendland C2: (1 - u)^4 (4u + 1), u = r / radius; compact support.
  Wendland = 1,
  /// Volume conserving: (1 - 5u^2)(1 - u^2)^3; pushes in for u < 1/sqrt(5),
  /// pulls out beyond; its integral over a plane is exactly zero. C2 at u = 1.
  VolumeConserving = 2,
};

/// A shape function with its support radius (m).
struct ShapeFunction {
  ShapeKind kind = ShapeKind::Wendland;
  double radius = 0.02;  ///< support radius, m: S(r) = 0 for r >= radius

  /// S(r), dimensionless.
  double value(double r) const;
  /// dS/dr, 1/m.
  double derivative(double r) const;
  /// Both at once: value = value(r), slope = derivative(r) (1/m), with the
  /// same arithmetic (so the same bits) at the cost of one evaluation.
  void evaluate(double r, double& value, double& slope) const;
};

}  // namespace palpa::deform
