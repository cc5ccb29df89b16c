#pragma once
// Per-vertex material parameters of the local models (section III.A), stored
// as arrays so heterogeneous and time-varying maps can be painted onto them.

#include "core/types.h"

#include <cstddef>
#include <string>
#include <vector>

namespace palpa::deform {

/// The local dynamic model a vertex follows along its undeformed normal.
enum class LocalModelKind : std::uint8_t {
  /// eq. (1): m h'' = -b h' - k h + f.
  Linear = 0,
  /// Stiffening spring: m h'' = -b h' - s(h) + f with
  /// s(h) = sign(h) k (exp(alpha |h|) - 1) / alpha; k is the small-strain stiffness.
  Exponential = 1,
  /// Standard linear solid (Zener): spring k in parallel with a Maxwell arm
  /// (spring k2 in series with a dashpot of time constant tau = eta / k2).
  /// Under constant indentation d the restoring force relaxes from
  /// (k + k2) d to k d with time constant tau.
  Viscoelastic = 2,
  /// Hertz contact (tissue::hertz_material maps a tissue in Pa onto it):
  /// spring s(h) = sign(h) S(|h|), S(d) = hertz ((d + d0)^1.5 - d0^1.5)(1 + alpha d)
  /// with d0 = kHertzSoftening, so the quasi-static force at a spherical tip
  /// pressed d deep is the Hertz force (within 1.5% for d >= 1 mm) and a
  /// vertex still returns to rest (slope 1.5 hertz sqrt(d0) at 0). With
  /// relaxation g > 0 a Maxwell arm of time constant tau makes a quick press
  /// feel (1 + g) S and relax to S: force -(1 + g) s(h) + g s(q) - b v.
  /// Every tissue maps to this one law, so parameters interpolate between
  /// vertices without the force changing form.
  Hertz = 3,
};

/// d0 of the Hertz law, m: below it the spring softens to a linear one.
inline constexpr double kHertzSoftening = 1e-5;

/// One vertex's parameters.
struct Material {
  LocalModelKind model = LocalModelKind::Linear;
  double mass = 1e-3;          ///< kg
  double damping = 1.0;        ///< N s/m
  double stiffness = 500.0;    ///< N/m (small-strain stiffness for Exponential, k for Viscoelastic)
  double alpha = 200.0;        ///< 1/m, Exponential stiffening rate
  double k2 = 500.0;           ///< N/m, Viscoelastic Maxwell-arm stiffness
  double tau = 0.5;            ///< s, Viscoelastic and Hertz relaxation time (> 0)
  double hertz = 0.0;          ///< N/m^1.5, Hertz coefficient 4/3 E/(1-nu^2) sqrt(R) (> 0 for Hertz)
  double relaxation = 0.0;     ///< dimensionless, Hertz: extra force fraction of a quick press (>= 0)

  friend bool operator==(const Material&, const Material&) = default;
};

/// Checks that m's parameters are usable: mass > 0, damping >= 0,
/// stiffness > 0, alpha >= 0, k2 >= 0, tau > 0, hertz >= 0 (> 0 for Hertz),
/// relaxation >= 0, all finite, and a known model.
/// Throws std::invalid_argument "<what>: <field> must be ..., got <value>"
/// (e.g. "material of vertex 3: mass must be positive and finite, got 0 kg").
void validate_material(const Material& m, const std::string& what);

/// m with its moduli multiplied by `scale` (> 0): stiffness, k2 and hertz
/// times scale, damping times sqrt(scale) (so the damping ratio is kept).
Material scaled(const Material& m, double scale);

/// scaled(m, scale) with its square root given, root = std::sqrt(scale)
/// (the same bits then): for a loop over vertices that keeps each vertex's
/// root, so that no square root lies on the path of every vertex's step.
inline Material scaled(const Material& m, double scale, double root) {
  Material out = m;
  out.stiffness *= scale;
  out.k2 *= scale;
  out.hertz *= scale;
  out.damping *= root;
  return out;
}

/// Structure-of-arrays material map, one entry per vertex.
struct MaterialArrays {
  std::vector<LocalModelKind> model;
  std::vector<double> mass;       ///< kg
  std::vector<double> damping;    ///< N s/m
  std::vector<double> stiffness;  ///< N/m
  std::vector<double> alpha;      ///< 1/m
  std::vector<double> k2;         ///< N/m
  std::vector<double> tau;        ///< s
  std::vector<double> hertz;      ///< N/m^1.5
  std::vector<double> relaxation; ///< dimensionless

  /// n vertices all of material m.
  static MaterialArrays uniform(std::size_t n, const Material& m);
  std::size_t size() const { return mass.size(); }
  Material at(Index i) const;
  void set(Index i, const Material& m);
  /// Checks that every array has expected_size entries and every entry passes
  /// validate_material; throws std::invalid_argument naming the array or the
  /// vertex, e.g. "materials: array 'damping' has 4 entries, expected 5".
  void validate(std::size_t expected_size) const;
};

}  // namespace palpa::deform
