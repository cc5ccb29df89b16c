#pragma once
// Shape functions (section III.B): the equilibrium shape of the surface around
// a contact as a function of the distance r (m) from the contact point,
// normalised so that S(0) = 1. Their derivatives give the normal corrections
// of eq. (3).

#include <cmath>

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
  /// Inline: the force field calls it for every vertex of every contact.
  void evaluate(double r, double& value, double& slope) const { evaluate(r, 1.0 / radius, value, slope); }
  /// evaluate() with inverse_radius = 1.0 / radius (1/m) computed once by the
  /// caller, for a loop over many r: the same bits, no division per call
  /// (every function here multiplies by the inverse rather than divides by
  /// the radius).
  void evaluate(double r, double inverse_radius, double& value, double& slope) const;
};

inline void ShapeFunction::evaluate(double r, double inverse_radius, double& value, double& slope) const {
  // value() and derivative() sharing u; every expression as written there.
  value = 0.0;
  slope = 0.0;
  if (!(radius > 0) || !(r < radius)) return;
  const double sign = r < 0 ? -1.0 : 1.0;
  const double u = std::abs(r) * inverse_radius;
  double ds_du = 0.0;
  switch (kind) {
    case ShapeKind::Gaussian:
      value = std::exp(-8.0 * u * u);
      ds_du = -16.0 * u * std::exp(-8.0 * u * u);
      break;
    case ShapeKind::Wendland: {
      const double a = 1.0 - u;
      const double a2 = a * a;
      value = a2 * a2 * (4.0 * u + 1.0);
      ds_du = -20.0 * u * a * a * a;
      break;
    }
    case ShapeKind::VolumeConserving: {
      const double w = 1.0 - u * u;
      value = (1.0 - 5.0 * u * u) * w * w * w;
      ds_du = 8.0 * u * w * w * (5.0 * u * u - 2.0);
      break;
    }
  }
  slope = sign * ds_du * inverse_radius;
}


}  // namespace palpa::deform
