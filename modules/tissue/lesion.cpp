// The felt-lesion law of lesion.h (derived in docs/TISSUE.md).

#include "tissue/lesion.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace palpa::tissue {

void validate_lesion(const Lesion& l, const std::string& what) {
  auto fail = [&](const char* field, const char* rule, double value, const char* unit) {
    std::ostringstream msg;
    msg << what << ": " << field << " must be " << rule << ", got " << value << unit;
    throw std::invalid_argument(msg.str());
  };
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(l.centre[k])) fail("centre", "finite", l.centre[k], " m");
  for (int k = 0; k < 3; ++k)
    if (!(l.semi_axes[k] > 0) || !std::isfinite(l.semi_axes[k])) fail("semi-axis", "positive and finite", l.semi_axes[k], " m");
  if (!(l.modulus_ratio > 0) || !std::isfinite(l.modulus_ratio))
    fail("modulus ratio", "positive and finite", l.modulus_ratio, "");
}

LesionData lesion_data(const Lesion& l) {
  LesionData d;
  d.centre = l.centre;
  d.inv_axes = l.semi_axes.cwiseInverse();
  const double a_eq = std::cbrt(l.semi_axes.x() * l.semi_axes.y() * l.semi_axes.z());
  d.size2 = a_eq * a_eq;
  d.excess = l.modulus_ratio - 1.0;
  return d;
}

double lesion_gap(const LesionData& l, const Vec3& q) {
  const Vec3 rel = q - l.centre;
  const double scaled = rel.cwiseProduct(l.inv_axes).norm();  // 1 on the surface
  if (!(scaled > 1.0)) return 0.0;
  // Along the ray from the centre the surface is at rel / scaled.
  return rel.norm() * (1.0 - 1.0 / scaled);
}

double lesion_falloff(double s) {
  if (!(s < 1.0)) return 0.0;
  if (s <= 0.0) return 1.0;
  const double u = 1.0 - s;
  return u * u * (1.0 + 2.0 * s);
}

double lesion_contrast(const LesionData& l, const Vec3& tip, double depth, double tip_radius) {
  if (!(depth > 0) || !(tip_radius > 0) || l.excess == 0.0) return 0.0;
  const double contact2 = tip_radius * depth;  // a_c^2
  const double reach = kLesionReach * std::sqrt(contact2);
  const double eta = l.size2 / (l.size2 + contact2);
  return l.excess * eta * lesion_falloff(lesion_gap(l, tip) / reach);
}

}  // namespace palpa::tissue
