#pragma once
// Buried lesions and the law by which they are felt (docs/TISSUE.md).
//
// A probe pressed to depth d (m) at the surface point p with outward normal n
// has its tip at q = p - d n. A lesion (ellipsoid centre c, semi-axes a) adds
// to the tissue's quasi-static force F(d) the fraction
//   C = (rho - 1) * eta * w(g / L)
// where rho is the lesion's modulus ratio to the surrounding tissue,
//   g  = the distance from q to the lesion surface (m; 0 when q is inside),
//        measured along the ray from c (exact for a sphere),
//   L  = kLesionReach * sqrt(R d), the depth the stress under a Hertz contact
//        of tip radius R reaches (kLesionReach contact radii a_c = sqrt(R d)),
//   eta = a_eq^2 / (a_eq^2 + a_c^2), a_eq = (a_x a_y a_z)^(1/3): a lesion
//        smaller than the contact patch carries part of the load only,
//   w(s) = (1 - s)^2 (1 + 2 s) for 0 <= s <= 1, 0 beyond (C1, decreasing).
// So: nothing is felt until sqrt(R d) reaches g / kLesionReach (a deep lesion
// needs a deep press); at fixed d, C falls monotonically with depth and is 0
// beyond g = L; C grows with size and with rho, so a larger or stiffer lesion
// stays above a given contrast deeper; the footprint (where g < L) grows with
// d; C is continuous in the probe position, so sliding over an edge at
// constant depth never makes the force jump. Hidden lesions act on the felt
// force only, never on the drawn surface.

#include "core/types.h"

#include <cstdint>
#include <string>

namespace palpa::tissue {

/// Contact radii the stress under the tip reaches, dimensionless.
inline constexpr double kLesionReach = 2.5;

enum class Visibility : std::uint8_t {
  Hidden = 0,     ///< felt, never drawn (the trainee finds it by feel)
  Shown = 1,      ///< drawn as an inclusion
  AfterExam = 2,  ///< hidden during the exam, drawn in the debriefing
};

struct Lesion {
  std::string name;
  Vec3 centre = Vec3::Zero();              ///< organ frame, m
  Vec3 semi_axes = Vec3::Constant(0.005);  ///< along the organ frame's x, y, z, m (> 0)
  double modulus_ratio = 3.0;              ///< lesion E / surrounding E, dimensionless (> 0)
  Visibility visibility = Visibility::Hidden;

  friend bool operator==(const Lesion&, const Lesion&) = default;
};

/// Checks a lesion (finite centre, semi-axes > 0, ratio > 0 and finite);
/// throws std::invalid_argument "<what>: <field> must be ..., got <value>".
void validate_lesion(const Lesion& l, const std::string& what);

/// A lesion as the haptic tick reads it: plain data, no strings.
struct LesionData {
  Vec3 centre = Vec3::Zero();     ///< m
  Vec3 inv_axes = Vec3::Ones();   ///< 1 / semi-axes, 1/m
  double size2 = 0;               ///< a_eq^2, m^2
  double excess = 0;              ///< rho - 1
};
LesionData lesion_data(const Lesion& l);

/// Distance (m) from point q to the lesion's surface along the ray from its
/// centre; 0 inside.
double lesion_gap(const LesionData& l, const Vec3& q);

/// The smooth cut-off w(s) above, dimensionless.
double lesion_falloff(double s);

/// The contrast C above (fraction of the tissue's force, dimensionless) for
/// the tip at q (m), indentation depth (m) and tip radius (m). 0 for depth <= 0.
double lesion_contrast(const LesionData& l, const Vec3& tip, double depth, double tip_radius);

}  // namespace palpa::tissue
