// Time variation of the tissue: waveforms, keyframes, guarding, breathing,
// and the TissueField the tick and the deformation step read.

#include "tissue/field.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace palpa::tissue {

namespace {

// (1 - x^2)^3 on |x| < 1, else 0: a C2 bump.
double bump(double x) {
  if (!(std::abs(x) < 1.0)) return 0.0;
  const double u = 1.0 - x * x;
  return u * u * u;
}

// A bump centred at c with different widths on each side (C1 at c).
double skewed(double phase, double c, double left, double right) {
  return phase < c ? bump((c - phase) / left) : bump((phase - c) / right);
}

double fraction(double x) { return x - std::floor(x); }

[[noreturn]] void refuse(const std::string& what) { throw std::invalid_argument(what); }

void check_positive(const std::string& what, const char* field, double v, const char* unit) {
  if (!(v > 0) || !std::isfinite(v)) {
    std::ostringstream m;
    m << what << ": " << field << " must be positive and finite, got " << v << unit;
    refuse(m.str());
  }
}

void check_non_negative(const std::string& what, const char* field, double v, const char* unit) {
  if (!(v >= 0) || !std::isfinite(v)) {
    std::ostringstream m;
    m << what << ": " << field << " must be non-negative and finite, got " << v << unit;
    refuse(m.str());
  }
}

}  // namespace

double cardiac_wave(double phase) {
  const double p = fraction(phase);
  // Systolic upstroke to 1 at 0.15 and its decay; dicrotic wave at 0.45.
  return skewed(p, 0.15, 0.12, 0.35) + 0.35 * skewed(p, 0.45, 0.10, 0.25);
}

double breathing_wave(double phase) {
  const double p = fraction(phase);
  constexpr double kIn = 0.4;  // inspiration takes 40% of the breath
  if (p < kIn) return 0.5 * (1.0 - std::cos(std::numbers::pi * p / kIn));
  return 0.5 * (1.0 + std::cos(std::numbers::pi * (p - kIn) / (1.0 - kIn)));
}

double TissueField::pulse_value(std::size_t p, double t) const {
  if (p >= pulse_count) return 0.0;
  return pulses[p].amplitude * cardiac_wave(t * pulses[p].rate_hz);
}

double TissueField::rest_offset(Index i, double t) const {
  double sum = 0.0;
  for (std::size_t p = 0; p < pulse_count; ++p) {
    const auto& w = pulse_weight[p];
    if (i < w.size() && w[i] != 0.0f) sum += w[i] * pulse_value(p, t);
  }
  return sum;
}

double TissueField::dynamic_factor(std::size_t r, double t, const ReactionState& reactions) const {
  if (r >= dynamic_count) return 1.0;
  const DynamicData& d = dynamic[r];
  // Keyframes: each moves the factor from the value before it to its scale over its ramp.
  double factor = 1.0;
  for (std::uint32_t k = 0; k < d.keyframe_count; ++k) {
    const Keyframe& kf = d.keyframes[k];
    if (t < kf.time) break;
    if (kf.ramp > 0 && t < kf.time + kf.ramp) {
      factor += (kf.scale - factor) * (t - kf.time) / kf.ramp;
      break;
    }
    factor = kf.scale;
  }
  // Guarding: factor for `duration` after the trigger, then back over `release`.
  const double at = reactions.triggered_at[r];
  if (d.guarding.enabled && at >= 0 && t >= at) {
    const double e = t - at;
    const Guarding& g = d.guarding;
    if (e < g.duration) factor *= g.factor;
    else if (g.release > 0 && e < g.duration + g.release) factor *= g.factor + (1.0 - g.factor) * (e - g.duration) / g.release;
  }
  return factor;
}

double TissueField::breathing_value(double t) const {
  return breathing.enabled ? breathing_wave(t * breathing.rate_bpm / 60.0) : 0.0;
}

Vec3 TissueField::to_world(const Vec3& x, double t) const {
  if (!breathing.enabled) return x;
  const double b = breathing_value(t);
  const Vec3 rel = x - breathing.centre;
  return breathing.centre + rel + (b * breathing.scale * breathing.axis.dot(rel)) * breathing.axis + b * breathing.translation;
}

Vec3 TissueField::to_organ(const Vec3& world, double t) const {
  if (!breathing.enabled) return world;
  const double b = breathing_value(t);
  const Vec3 y = world - b * breathing.translation - breathing.centre;
  const double stretch = b * breathing.scale;
  const double along = breathing.axis.dot(y);
  return breathing.centre + y - (along * stretch / (1.0 + stretch)) * breathing.axis;
}

Eigen::Matrix4d TissueField::organ_to_world(double t) const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (!breathing.enabled) return m;
  const double b = breathing_value(t);
  const Eigen::Matrix3d a = Eigen::Matrix3d::Identity() + b * breathing.scale * breathing.axis * breathing.axis.transpose();
  m.topLeftCorner<3, 3>() = a;
  m.topRightCorner<3, 1>() = breathing.centre - a * breathing.centre + b * breathing.translation;
  return m;
}

Vec3 TissueField::organ_velocity(const Vec3& world, double t) const {
  if (!breathing.enabled) return Vec3::Zero();
  // d/dt of to_world at the organ point under `world`; db/dt by a central difference.
  const double h = 1e-4;
  const double db = (breathing_value(t + h) - breathing_value(t - h)) / (2 * h);
  const Vec3 rel = to_organ(world, t) - breathing.centre;
  return db * (breathing.scale * breathing.axis.dot(rel) * breathing.axis + breathing.translation);
}

double polyline_distance(const std::vector<Vec3>& path, const Vec3& p) {
  if (path.empty()) return std::numeric_limits<double>::infinity();
  double best = (p - path.front()).norm();
  for (std::size_t k = 1; k < path.size(); ++k) {
    const Vec3 a = path[k - 1], ab = path[k] - a;
    const double len2 = ab.squaredNorm();
    const double u = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, (p - (a + u * ab)).norm());
  }
  return best;
}

TissueField make_field(const mesh::SurfaceMesh& mesh, double tip_radius, const std::vector<Lesion>& lesions,
                       const std::vector<Pulse>& pulses, const Breathing& breathing,
                       const std::vector<DynamicRegion>& dynamic, std::vector<std::vector<float>> dynamic_weights) {
  check_positive("probe", "tip radius", tip_radius, " m");
  TissueField f;
  f.tip_radius = tip_radius;
  const std::size_t n = mesh.vertex_count();

  if (lesions.size() > kMaxLesions)
    refuse(std::to_string(lesions.size()) + " lesions: at most " + std::to_string(kMaxLesions));
  for (const Lesion& l : lesions) {
    validate_lesion(l, "lesion '" + l.name + "'");
    f.lesions[f.lesion_count++] = lesion_data(l);
  }

  if (pulses.size() > kMaxPulses)
    refuse(std::to_string(pulses.size()) + " pulses: at most " + std::to_string(kMaxPulses));
  std::vector<std::uint8_t> moved(n, 0);
  for (const Pulse& p : pulses) {
    const std::string what = "pulse '" + p.name + "'";
    if (p.path.size() < 2) refuse(what + ": the path needs at least 2 points, got " + std::to_string(p.path.size()));
    for (const Vec3& q : p.path)
      if (!q.allFinite()) refuse(what + ": a path point is not finite");
    check_positive(what, "radius", p.radius, " m");
    check_positive(what, "rate", p.rate_bpm, " beats/min");
    check_non_negative(what, "amplitude", p.amplitude, " m");
    const std::size_t k = f.pulse_count++;
    f.pulses[k] = {p.rate_bpm / 60.0, p.amplitude};
    auto& w = f.pulse_weight[k];
    w.assign(n, 0.0f);
    for (std::size_t i = 0; i < n; ++i) {
      const double s = polyline_distance(p.path, mesh.positions[i]) / p.radius;
      const double v = lesion_falloff(s);
      if (v > 0) {
        w[i] = static_cast<float>(v);
        moved[i] = 1;
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (moved[i]) f.pulse_vertices.push_back(static_cast<Index>(i));

  if (breathing.enabled) {
    check_positive("breathing", "rate", breathing.rate_bpm, " breaths/min");
    if (!breathing.translation.allFinite() || !breathing.centre.allFinite() || !std::isfinite(breathing.scale))
      refuse("breathing: translation, centre and scale must be finite");
    if (!(breathing.scale > -0.5 && breathing.scale < 0.5))
      refuse("breathing: scale must be in (-0.5, 0.5), got " + std::to_string(breathing.scale));
    const double len = breathing.axis.norm();
    if (!(len > 0) || !std::isfinite(len)) refuse("breathing: the axis must be a non-zero finite vector");
  }
  f.breathing = breathing;
  if (breathing.enabled) f.breathing.axis = breathing.axis.normalized();

  if (dynamic.size() > kMaxDynamicRegions)
    refuse(std::to_string(dynamic.size()) + " dynamic regions: at most " + std::to_string(kMaxDynamicRegions));
  if (dynamic_weights.size() != dynamic.size())
    refuse("dynamic regions: " + std::to_string(dynamic_weights.size()) + " weight arrays for " +
           std::to_string(dynamic.size()) + " regions");
  for (std::size_t r = 0; r < dynamic.size(); ++r) {
    const DynamicRegion& d = dynamic[r];
    const std::string what = "dynamic region '" + d.region + "'";
    if (d.keyframes.size() > kMaxKeyframes)
      refuse(what + ": " + std::to_string(d.keyframes.size()) + " keyframes, at most " + std::to_string(kMaxKeyframes));
    if (dynamic_weights[r].size() != n)
      refuse(what + ": " + std::to_string(dynamic_weights[r].size()) + " weights for " + std::to_string(n) + " vertices");
    auto& dd = f.dynamic[f.dynamic_count++];
    double last = -std::numeric_limits<double>::infinity();
    for (const Keyframe& k : d.keyframes) {
      check_non_negative(what, "keyframe time", k.time, " s");
      check_positive(what, "keyframe scale", k.scale, "");
      check_non_negative(what, "keyframe ramp", k.ramp, " s");
      if (k.time < last) refuse(what + ": keyframes must be sorted by time");
      last = k.time;
      dd.keyframes[dd.keyframe_count++] = k;
    }
    if (d.guarding.enabled) {
      check_positive(what, "guarding threshold", d.guarding.threshold, " N");
      check_positive(what, "guarding factor", d.guarding.factor, "");
      check_non_negative(what, "guarding duration", d.guarding.duration, " s");
      check_non_negative(what, "guarding release", d.guarding.release, " s");
    }
    dd.guarding = d.guarding;
    f.dynamic_weight[r] = std::move(dynamic_weights[r]);
  }
  return f;
}

}  // namespace palpa::tissue
