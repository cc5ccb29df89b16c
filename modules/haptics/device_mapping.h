#pragma once
// Device-to-world mapping for one device: a signed axis permutation, a scale
// and an offset, plus a clutch that lets the user move the device without
// moving the probe (the offset is re-anchored on release). Plain data so it
// can travel through the loop's command queue and the session record.

#include "core/types.h"

#include <array>
#include <string>
#include <string_view>

namespace palpa::haptics {

/// Which device axis, with which sign, gives each world axis.
struct AxisMap {
  std::array<int, 3> axis{0, 1, 2};          ///< world axis i takes device axis axis[i] (0 = x, 1 = y, 2 = z)
  std::array<double, 3> sign{1.0, 1.0, 1.0}; ///< +1 or -1 per world axis

  /// Parses "x,y,z", "x,-z,y", "-y,x,z" ... (each device axis exactly once).
  /// Throws std::invalid_argument: "axis order 'x,x,z': axis x is used twice".
  static AxisMap parse(std::string_view text);
  std::string to_string() const;

  /// World components from device components (a rotation, so lengths are kept).
  Vec3 to_world(const Vec3& d) const {
    return {sign[0] * d[axis[0]], sign[1] * d[axis[1]], sign[2] * d[axis[2]]};
  }
  /// Device components from world components (the inverse of to_world).
  Vec3 to_device(const Vec3& w) const {
    Vec3 d;
    for (int i = 0; i < 3; ++i) d[axis[i]] = sign[i] * w[i];
    return d;
  }
};

/// How one device's readings become a probe position, and forces go back.
struct DeviceMapping {
  double scale = 1.0;                        ///< world metres per device metre (> 0)
  std::array<double, 3> offset{0, 0, 0};     ///< m: world position of the device origin
  AxisMap axes;
  double force_scale = 1.0;                  ///< device newtons per world newton (>= 0)
  int clutch_button = -1;                    ///< device button that engages the clutch while held; -1: none

  /// Throws std::invalid_argument naming `who` and the bad field, e.g.
  /// "mapping of falcon: scale must be a positive finite number, got nan".
  void validate(const std::string& who) const;

  /// World position (m) of a device position (m), without the clutch.
  Vec3 to_world(const Vec3& device) const {
    return Vec3(offset[0], offset[1], offset[2]) + scale * axes.to_world(device);
  }
  /// Device force (N) for a world force (N).
  Vec3 force_to_device(const Vec3& world) const { return force_scale * axes.to_device(world); }
  /// World force (N) for a device force (N); zero when force_scale is 0.
  Vec3 force_to_world(const Vec3& device) const {
    return force_scale > 0 ? Vec3(axes.to_world(device) / force_scale) : Vec3::Zero();
  }
};

/// A mapping with its clutch state. While the clutch is engaged the probe
/// stays where it was; on release the offset is moved so that the probe
/// continues from that point (no jump). Real-time safe.
class ClutchedMapping {
 public:
  ClutchedMapping() = default;
  explicit ClutchedMapping(const DeviceMapping& m) : mapping_(m) {}

  /// The probe's world position for `device` (m); `clutch` true while the
  /// user holds the clutch. Non-finite device positions give non-finite
  /// results and leave the clutch anchor untouched.
  Vec3 update(const Vec3& device, bool clutch) noexcept;

  bool engaged() const { return engaged_; }
  /// The mapping in force now (its offset includes every clutch re-anchoring).
  const DeviceMapping& mapping() const { return mapping_; }
  /// Replaces the mapping (the clutch is released).
  void set_mapping(const DeviceMapping& m) noexcept {
    mapping_ = m;
    engaged_ = false;
  }

 private:
  DeviceMapping mapping_;
  bool engaged_ = false;
  Vec3 held_ = Vec3::Zero();  // world position kept while engaged, m
};

}  // namespace palpa::haptics
