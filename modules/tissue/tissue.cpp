// Tissues in Pa onto the Hertz local model (docs/TISSUE.md).

#include "tissue/tissue.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace palpa::tissue {

namespace {

[[noreturn]] void fail(const std::string& what, const char* field, const char* rule, double value, const char* unit) {
  std::ostringstream msg;
  msg << what << ": " << field << " must be " << rule << ", got " << value << unit;
  throw std::invalid_argument(msg.str());
}

}  // namespace

void validate_tissue(const Tissue& t, const std::string& what) {
  if (!(t.youngs_modulus > 0) || !std::isfinite(t.youngs_modulus))
    fail(what, "Young's modulus", "positive and finite", t.youngs_modulus, " Pa");
  if (!(t.poisson >= 0 && t.poisson < 0.5)) fail(what, "Poisson ratio", "in [0, 0.5)", t.poisson, "");
  if (!(t.damping_ratio >= 0) || !std::isfinite(t.damping_ratio))
    fail(what, "damping ratio", "non-negative and finite", t.damping_ratio, "");
  if (!(t.relaxation_time >= 0) || !std::isfinite(t.relaxation_time))
    fail(what, "relaxation time", "non-negative and finite", t.relaxation_time, " s");
  if (!(t.relaxation_fraction >= 0) || !std::isfinite(t.relaxation_fraction))
    fail(what, "relaxation fraction", "non-negative and finite", t.relaxation_fraction, "");
  if (!(t.stiffening >= 0) || !std::isfinite(t.stiffening))
    fail(what, "stiffening", "non-negative and finite", t.stiffening, " 1/m");
}

double hertz_coefficient(const Tissue& t, double tip_radius) {
  return 4.0 / 3.0 * t.youngs_modulus / (1.0 - t.poisson * t.poisson) * std::sqrt(tip_radius);
}

double hertz_force(const Tissue& t, double tip_radius, double depth) {
  if (!(depth > 0)) return 0.0;
  return hertz_coefficient(t, tip_radius) * depth * std::sqrt(depth) * (1.0 + t.stiffening * depth);
}

deform::Material hertz_material(const Tissue& t, double tip_radius, double vertex_mass) {
  validate_tissue(t, "tissue '" + t.name + "'");
  if (!(tip_radius > 0) || !std::isfinite(tip_radius))
    fail("probe", "tip radius", "positive and finite", tip_radius, " m");
  if (!(vertex_mass > 0) || !std::isfinite(vertex_mass))
    fail("tissue '" + t.name + "'", "vertex mass", "positive and finite", vertex_mass, " kg");
  deform::Material m;
  m.model = deform::LocalModelKind::Hertz;
  m.mass = vertex_mass;
  m.hertz = hertz_coefficient(t, tip_radius);
  m.alpha = t.stiffening;
  // The small-signal stiffness at the reference depth sets the damping (and
  // is what max_stiffness reports): dF/dd = 1.5 c sqrt(d) there.
  m.stiffness = 1.5 * m.hertz * std::sqrt(kReferenceDepth);
  m.damping = 2.0 * t.damping_ratio * std::sqrt(m.stiffness * vertex_mass);
  if (t.relaxation_time > 0 && t.relaxation_fraction > 0) {
    m.relaxation = t.relaxation_fraction;
    m.tau = t.relaxation_time;
  } else {
    m.relaxation = 0.0;
    m.tau = 1.0;  // unused without relaxation
  }
  m.k2 = 0.0;
  return m;
}

}  // namespace palpa::tissue
