#pragma once
// Tissues in the units educators use (Young's modulus, Poisson ratio, damping
// ratio, relaxation, stiffening) and their mapping onto the per-vertex local
// model so that the quasi-static force at a spherical probe tip follows Hertz
// contact (docs/TISSUE.md derives it):
//   F(d) = 4/3 * E / (1 - nu^2) * sqrt(R) * d^1.5      (N; E Pa, R m, d m).
// SI inside: Pa, m, s, N.

#include "deform/material.h"

#include <filesystem>
#include <string>
#include <vector>

namespace palpa::tissue {

/// Default probe tip radius: a fingertip, m.
inline constexpr double kDefaultTipRadius = 0.008;
/// Default mass of one vertex's local model, kg (sets how fast the drawn
/// surface follows; the quasi-static force does not depend on it).
inline constexpr double kDefaultVertexMass = 1e-3;

/// One tissue as an educator gives it.
struct Tissue {
  std::string name;               ///< e.g. "liver, healthy"
  double youngs_modulus = 4.1e3;  ///< E, Pa (educators write kPa)
  double poisson = 0.49;          ///< nu, dimensionless, in [0, 0.5)
  /// Damping ratio zeta of the local model linearised at kReferenceDepth
  /// (1: critically damped), dimensionless, >= 0.
  double damping_ratio = 1.0;
  /// Viscoelastic relaxation time tau, s (0: elastic). Under a held press the
  /// force relaxes from (1 + relaxation_fraction) F to F with this time constant.
  double relaxation_time = 0.0;
  /// Extra instantaneous force of a quick press, fraction of F (>= 0); used
  /// only when relaxation_time > 0.
  double relaxation_fraction = 0.0;
  /// Stiffening, 1/m (educators write 1/mm): the force is multiplied by
  /// (1 + stiffening * d), so soft tissue can stiffen at large strain. 0: pure Hertz.
  double stiffening = 0.0;
  std::string source;             ///< the published source of the values (presets)

  friend bool operator==(const Tissue&, const Tissue&) = default;
};

/// The depth (m) at which the damping ratio is defined: the local model's
/// stiffness there, dF/dd = 2 E/(1-nu^2) sqrt(R d), sets the damping
/// b = 2 zeta sqrt(k m).
inline constexpr double kReferenceDepth = 0.005;

/// Checks a tissue: E > 0 and finite (Pa), 0 <= nu < 0.5, zeta >= 0,
/// tau >= 0, relaxation_fraction >= 0, stiffening >= 0, all finite. Throws
/// std::invalid_argument "<what>: <field> must be ..., got <value>".
void validate_tissue(const Tissue& t, const std::string& what);

/// The Hertz coefficient 4/3 E/(1 - nu^2) sqrt(R), N/m^1.5, for tip radius R (m).
double hertz_coefficient(const Tissue& t, double tip_radius);

/// The Hertz force (N) of the tissue at indentation d (m) with tip radius R (m),
/// the closed form above (times the stiffening factor).
double hertz_force(const Tissue& t, double tip_radius, double depth);

/// The per-vertex local model for a tissue and a tip radius (m): the Hertz
/// kind of deform::LocalModelKind with its coefficient, damping from the
/// damping ratio, relaxation and stiffening. Every tissue maps to the same
/// law, so parameters interpolate continuously between vertices.
deform::Material hertz_material(const Tissue& t, double tip_radius, double vertex_mass = kDefaultVertexMass);

/// A preset: a tissue with its published source.
struct Preset {
  std::string key;   ///< e.g. "liver" (what a scenario names)
  Tissue tissue;
};

/// The presets shipped in data/tissues.json (values from
/// ../shared/data/organs/MATERIALS.md, each naming its source). Throws
/// std::runtime_error naming the file and the fault.
std::vector<Preset> load_presets(const std::filesystem::path& file);
/// load_presets(mesh::data_dir() / "tissues.json"), read once.
const std::vector<Preset>& presets();
/// The preset with this key, or nullptr.
const Preset* find_preset(const std::string& key);

}  // namespace palpa::tissue
