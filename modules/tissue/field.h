#pragma once
// Time variation of the tissue (pulse, breathing, modulus keyframes and
// guarding reactions) and the TissueField: everything the haptic tick and the
// deformation step read about the tissue beyond the per-vertex materials, as
// preallocated plain data. Every value is a deterministic function of the
// session time (s) and of the recorded state, so a replay is exact.

#include "core/types.h"
#include "mesh/surface_mesh.h"
#include "tissue/lesion.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace palpa::tissue {

inline constexpr std::size_t kMaxLesions = 32;
inline constexpr std::size_t kMaxPulses = 4;
inline constexpr std::size_t kMaxDynamicRegions = 4;
inline constexpr std::size_t kMaxKeyframes = 16;

/// Cardiac pressure waveform over one beat, phase in [0, 1): a systolic peak
/// (value 1 at phase 0.15) and a smaller dicrotic wave (about 0.35 at phase
/// 0.45) over a diastolic decay; dimensionless in [0, 1], 0 at phase 0, C1
/// and periodic.
double cardiac_wave(double phase);
/// Breathing waveform over one breath, phase in [0, 1): 0 at end
/// expiration, 1 at end inspiration (phase 0.4), a slower exhalation;
/// dimensionless in [0, 1], C1 and periodic.
double breathing_wave(double phase);

/// A pulsing vessel under the surface.
struct Pulse {
  std::string name;
  std::vector<Vec3> path;   ///< polyline, organ frame, m (>= 2 points)
  double radius = 0.01;     ///< the surface within this distance of the path moves, m
  double rate_bpm = 70;     ///< beats per minute
  double amplitude = 0.001; ///< outward displacement at the path at the systolic peak, m
  friend bool operator==(const Pulse&, const Pulse&) = default;
};

/// Breathing motion of the whole organ: at phase value b in [0, 1]
/// (breathing_wave) a point x of the organ frame is drawn and felt at
/// centre + (I + b scale axis axis^T)(x - centre) + b translation.
struct Breathing {
  bool enabled = false;
  double rate_bpm = 15;                     ///< breaths per minute
  Vec3 translation = Vec3(0, 0, 0.01);      ///< excursion at end inspiration, m
  Vec3 axis = Vec3::UnitZ();                ///< unit axis of the scale
  Vec3 centre = Vec3::Zero();               ///< fixed point of the scale, m
  double scale = 0.0;                       ///< fractional stretch along axis at end inspiration
  friend bool operator==(const Breathing&, const Breathing&) = default;
};

/// From `time` on a region's modulus is multiplied by `scale` (reached
/// linearly over `ramp` seconds after `time`).
struct Keyframe {
  double time = 0;   ///< s
  double scale = 1;  ///< dimensionless, > 0
  double ramp = 0;   ///< s, >= 0
  friend bool operator==(const Keyframe&, const Keyframe&) = default;
};

/// A reaction: when the normal force a probe applies inside the region
/// exceeds `threshold`, the region's modulus is multiplied by `factor` for
/// `duration` seconds, then returns linearly over `release` seconds.
struct Guarding {
  bool enabled = false;
  double threshold = 5.0;  ///< N
  double factor = 2.0;     ///< dimensionless, > 0
  double duration = 3.0;   ///< s
  double release = 1.0;    ///< s
  friend bool operator==(const Guarding&, const Guarding&) = default;
};

/// A region (by name, see regions.h) whose felt modulus changes with time.
struct DynamicRegion {
  std::string region;
  std::vector<Keyframe> keyframes;  ///< sorted by time
  Guarding guarding;
  friend bool operator==(const DynamicRegion&, const DynamicRegion&) = default;
};

/// The reaction state of a session (part of the engine state; plain data).
struct ReactionState {
  /// Per dynamic region: session time the guarding was last triggered, s (< 0: never).
  std::array<double, kMaxDynamicRegions> triggered_at{-1, -1, -1, -1};
};

/// The tissue beyond the per-vertex materials, prepared for the haptic tick
/// and the deformation step (build it once per model; read by both threads).
struct TissueField {
  double tip_radius = 0.008;  ///< m

  std::uint32_t lesion_count = 0;
  std::array<LesionData, kMaxLesions> lesions{};

  struct PulseData {
    double rate_hz = 0;     ///< beats per second
    double amplitude = 0;   ///< m
  };
  std::uint32_t pulse_count = 0;
  std::array<PulseData, kMaxPulses> pulses{};
  /// Per pulse, per vertex: falloff weight in [0, 1] (empty when no pulse).
  std::array<std::vector<float>, kMaxPulses> pulse_weight;
  /// Every vertex some pulse moves (weight > 0), sorted.
  std::vector<Index> pulse_vertices;

  Breathing breathing;

  struct DynamicData {
    std::uint32_t keyframe_count = 0;
    std::array<Keyframe, kMaxKeyframes> keyframes{};
    Guarding guarding;
  };
  std::uint32_t dynamic_count = 0;
  std::array<DynamicData, kMaxDynamicRegions> dynamic{};
  /// Per dynamic region, per vertex: membership weight in [0, 1].
  std::array<std::vector<float>, kMaxDynamicRegions> dynamic_weight;

  bool empty() const { return lesion_count == 0 && pulse_count == 0 && !breathing.enabled && dynamic_count == 0; }

  /// Outward displacement of pulse p's vessel at time t, m (amplitude * cardiac_wave).
  double pulse_value(std::size_t p, double t) const;
  /// Rest-height offset of vertex i at time t: sum over pulses of weight * value, m.
  double rest_offset(Index i, double t) const;
  /// Modulus multiplier of dynamic region r at time t (keyframes times the
  /// guarding reaction in `reactions`), dimensionless.
  double dynamic_factor(std::size_t r, double t, const ReactionState& reactions) const;
  /// Breathing phase value b(t) in [0, 1] (0 when breathing is off).
  double breathing_value(double t) const;
  /// Organ frame -> world at time t (breathing), and its inverse.
  Vec3 to_world(const Vec3& x, double t) const;
  Vec3 to_organ(const Vec3& world, double t) const;
  /// to_world as a 4x4 affine matrix (for drawing the organ where it is).
  Eigen::Matrix4d organ_to_world(double t) const;
  /// Velocity (m/s, world frame) of the organ point that is at `world` at time t.
  Vec3 organ_velocity(const Vec3& world, double t) const;
};

/// Builds the field of a model: lesions (at most kMaxLesions), pulses (at
/// most kMaxPulses; each vertex within a vessel's radius of its path gets
/// weight lesion_falloff(distance / radius)), breathing, and dynamic regions
/// (at most kMaxDynamicRegions, keyframes at most kMaxKeyframes each) with
/// their per-vertex weights (tissue::region_weights of their regions, one
/// array per dynamic region). Throws std::invalid_argument naming what is
/// out of range ("lesion 'a': semi-axis must be positive and finite, got 0 m",
/// "33 lesions: at most 32").
TissueField make_field(const mesh::SurfaceMesh& mesh, double tip_radius, const std::vector<Lesion>& lesions,
                       const std::vector<Pulse>& pulses, const Breathing& breathing,
                       const std::vector<DynamicRegion>& dynamic, std::vector<std::vector<float>> dynamic_weights);

/// Distance (m) from p to the polyline (>= 1 point).
double polyline_distance(const std::vector<Vec3>& path, const Vec3& p);

}  // namespace palpa::tissue
