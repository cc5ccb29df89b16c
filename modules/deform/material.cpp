// Per-vertex material parameters: the structure-of-arrays map and the checks
// that keep every local model well posed.

#include "deform/material.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace palpa::deform {

namespace {

// Formats one failed check as "<what>: <field> must be <rule>, got <value> <unit>".
[[noreturn]] void fail(const std::string& what, const char* field, const char* rule, double value,
                       const char* unit) {
  std::ostringstream msg;
  msg << what << ": " << field << " must be " << rule << ", got " << value << ' ' << unit;
  throw std::invalid_argument(msg.str());
}

// True when validate_material would accept m (cheap: no message is built).
bool usable(const Material& m) {
  return static_cast<unsigned>(m.model) <= static_cast<unsigned>(LocalModelKind::Hertz) &&
         m.mass > 0 && std::isfinite(m.mass) && m.damping >= 0 && std::isfinite(m.damping) &&
         m.stiffness > 0 && std::isfinite(m.stiffness) && m.alpha >= 0 && std::isfinite(m.alpha) &&
         m.k2 >= 0 && std::isfinite(m.k2) && m.tau > 0 && std::isfinite(m.tau) && m.hertz >= 0 &&
         std::isfinite(m.hertz) && (m.model != LocalModelKind::Hertz || m.hertz > 0) && m.relaxation >= 0 &&
         std::isfinite(m.relaxation);
}

}  // namespace

void validate_material(const Material& m, const std::string& what) {
  // The model must be one of the enumerated kinds.
  const auto kind = static_cast<unsigned>(m.model);
  if (kind > static_cast<unsigned>(LocalModelKind::Hertz)) {
    throw std::invalid_argument(what + ": unknown local model " + std::to_string(kind));
  }
  // Every parameter finite, with the sign each model needs.
  if (!(m.mass > 0) || !std::isfinite(m.mass)) fail(what, "mass", "positive and finite", m.mass, "kg");
  if (!(m.damping >= 0) || !std::isfinite(m.damping))
    fail(what, "damping", "non-negative and finite", m.damping, "N s/m");
  if (!(m.stiffness > 0) || !std::isfinite(m.stiffness))
    fail(what, "stiffness", "positive and finite", m.stiffness, "N/m");
  if (!(m.alpha >= 0) || !std::isfinite(m.alpha)) fail(what, "alpha", "non-negative and finite", m.alpha, "1/m");
  if (!(m.k2 >= 0) || !std::isfinite(m.k2)) fail(what, "k2", "non-negative and finite", m.k2, "N/m");
  if (!(m.tau > 0) || !std::isfinite(m.tau)) fail(what, "tau", "positive and finite", m.tau, "s");
  if (m.model == LocalModelKind::Hertz) {
    if (!(m.hertz > 0) || !std::isfinite(m.hertz))
      fail(what, "hertz", "positive and finite", m.hertz, "N/m^1.5");
  } else if (!(m.hertz >= 0) || !std::isfinite(m.hertz)) {
    fail(what, "hertz", "non-negative and finite", m.hertz, "N/m^1.5");
  }
  if (!(m.relaxation >= 0) || !std::isfinite(m.relaxation))
    fail(what, "relaxation", "non-negative and finite", m.relaxation, "(fraction)");
}

Material scaled(const Material& m, double scale) { return scaled(m, scale, std::sqrt(scale)); }

MaterialArrays MaterialArrays::uniform(std::size_t n, const Material& m) {
  MaterialArrays a;
  a.model.assign(n, m.model);
  a.mass.assign(n, m.mass);
  a.damping.assign(n, m.damping);
  a.stiffness.assign(n, m.stiffness);
  a.alpha.assign(n, m.alpha);
  a.k2.assign(n, m.k2);
  a.tau.assign(n, m.tau);
  a.hertz.assign(n, m.hertz);
  a.relaxation.assign(n, m.relaxation);
  return a;
}

Material MaterialArrays::at(Index i) const {
  return Material{model[i], mass[i], damping[i], stiffness[i], alpha[i], k2[i], tau[i], hertz[i], relaxation[i]};
}

void MaterialArrays::set(Index i, const Material& m) {
  model[i] = m.model;
  mass[i] = m.mass;
  damping[i] = m.damping;
  stiffness[i] = m.stiffness;
  alpha[i] = m.alpha;
  k2[i] = m.k2;
  tau[i] = m.tau;
  hertz[i] = m.hertz;
  relaxation[i] = m.relaxation;
}

void MaterialArrays::validate(std::size_t expected_size) const {
  // Every array must hold one entry per vertex.
  auto check_size = [&](const char* name, std::size_t size) {
    if (size != expected_size) {
      throw std::invalid_argument("materials: array '" + std::string(name) + "' has " + std::to_string(size) +
                                  " entries, expected " + std::to_string(expected_size));
    }
  };
  check_size("model", model.size());
  check_size("mass", mass.size());
  check_size("damping", damping.size());
  check_size("stiffness", stiffness.size());
  check_size("alpha", alpha.size());
  check_size("k2", k2.size());
  check_size("tau", tau.size());
  check_size("hertz", hertz.size());
  check_size("relaxation", relaxation.size());
  // Every vertex's parameters must be usable.
  for (std::size_t i = 0; i < expected_size; ++i) {
    const Material m = at(static_cast<Index>(i));
    if (!usable(m)) validate_material(m, "material of vertex " + std::to_string(i));
  }
}

}  // namespace palpa::deform
