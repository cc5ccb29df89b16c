// Shape functions of section III.B and their analytic derivatives (used by the
// normal correction of eq. 3).

#include "deform/shape_function.h"

#include <cmath>

namespace palpa::deform {

double ShapeFunction::value(double r) const {
  // No support (bad radius) or outside it: no deformation.
  if (!(radius > 0) || !(r < radius)) return 0.0;
  const double u = std::abs(r) * (1.0 / radius);  // as evaluate(): no division by the radius
  switch (kind) {
    case ShapeKind::Gaussian: {
      // exp(-r^2 / (2 sigma^2)), sigma = radius / 4, so the exponent is -8 u^2.
      return std::exp(-8.0 * u * u);
    }
    case ShapeKind::Wendland: {
      // (1 - u)^4 (4u + 1).
      const double a = 1.0 - u;
      const double a2 = a * a;
      return a2 * a2 * (4.0 * u + 1.0);
    }
    case ShapeKind::VolumeConserving: {
      // (1 - 5u^2)(1 - u^2)^3.
      const double w = 1.0 - u * u;
      return (1.0 - 5.0 * u * u) * w * w * w;
    }
  }
  return 0.0;
}

double ShapeFunction::derivative(double r) const {
  // Zero outside the support, as the value is constant (0) there.
  if (!(radius > 0) || !(r < radius)) return 0.0;
  const double sign = r < 0 ? -1.0 : 1.0;
  const double u = std::abs(r) * (1.0 / radius);  // as evaluate(): no division by the radius
  double ds_du = 0.0;
  switch (kind) {
    case ShapeKind::Gaussian:
      // d/du exp(-8u^2) = -16 u exp(-8u^2).
      ds_du = -16.0 * u * std::exp(-8.0 * u * u);
      break;
    case ShapeKind::Wendland: {
      // d/du (1-u)^4 (4u+1) = -20 u (1-u)^3.
      const double a = 1.0 - u;
      ds_du = -20.0 * u * a * a * a;
      break;
    }
    case ShapeKind::VolumeConserving: {
      // d/du (1-5u^2)(1-u^2)^3 = 8u (1-u^2)^2 (5u^2 - 2).
      const double w = 1.0 - u * u;
      ds_du = 8.0 * u * w * w * (5.0 * u * u - 2.0);
      break;
    }
  }
  return sign * ds_du * (1.0 / radius);
}

}  // namespace palpa::deform
