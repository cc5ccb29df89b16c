#pragma once
// The safety filter applied to every force after it is computed and before it
// reaches a device: finite check, clamp to the device's maximum force (scale
// the vector, keep its direction), a limit on the force change per tick, a
// ramp-in after enabling, zero force while anything is wrong (loop or model
// late, stale or invalid input, device not ready, clutch, a probe that jumped)
// and a latched fault on a device error or unplug that only an explicit
// enable() clears. Real-time safe: no allocation, lock, I/O or exception.

#include "core/types.h"

#include <cstdint>
#include <string>

namespace palpa::haptics {

/// Limits for one device (device frame, SI).
struct SafetyLimits {
  double max_force = 0;         ///< N: never exceeded (usually the device's spec)
  double max_force_rate = 2000; ///< N/s: largest change of the force vector per second
  double ramp_time = 0.5;       ///< s: after enabling, forces are scaled from 0 to 1 over this time
  double max_jump = 0.05;       ///< m (world): a probe moving farther than this within one tick is a glitch

  /// Throws std::invalid_argument naming `who` and the bad field, e.g.
  /// "safety limits of falcon: max_force must be a positive finite number, got -1".
  void validate(const std::string& who) const;
};

/// Why a force was changed or withheld; several bits may be set at once.
enum SafetyFlag : std::uint32_t {
  kSafetyDisabled = 1u << 0,       ///< not enabled (never enabled, disabled, or a fault latched)
  kSafetyFaultLatched = 1u << 1,   ///< a fault is latched: enable() needed
  kSafetyDeviceFault = 1u << 2,    ///< the device reports an error or was unplugged (latches)
  kSafetyNonFiniteForce = 1u << 3, ///< the model produced a non-finite force (latches)
  kSafetyNotReady = 1u << 4,       ///< device homing / not ready / no reading yet
  kSafetyStale = 1u << 5,          ///< device input too old
  kSafetyBadInput = 1u << 6,       ///< non-finite or absurd position
  kSafetyLoopLate = 1u << 7,       ///< watchdog: the loop itself was late by more than a few periods
  kSafetyModelLate = 1u << 8,      ///< watchdog: the deformation model is late
  kSafetyClutch = 1u << 9,         ///< clutch engaged
  kSafetyJump = 1u << 10,          ///< the probe jumped farther than max_jump in one tick
  kSafetyClamped = 1u << 11,       ///< force scaled down to max_force
  kSafetyRateLimited = 1u << 12,   ///< force change limited
  kSafetyRamping = 1u << 13,       ///< ramp-in in progress
};

/// Conditions that hold the force at zero without latching (ramp-in again after).
inline constexpr std::uint32_t kSafetyHoldMask = kSafetyNotReady | kSafetyStale | kSafetyBadInput |
                                                 kSafetyLoopLate | kSafetyModelLate | kSafetyClutch | kSafetyJump;

/// Which latched fault (kept until enable()).
enum class SafetyFault : std::uint8_t {
  None = 0,
  Device = 1,          ///< device error or unplug
  NonFiniteForce = 2,  ///< the model produced NaN or infinity
};

/// A short English description of a fault (static storage).
const char* to_string(SafetyFault f);

class SafetyFilter {
 public:
  SafetyFilter() = default;
  /// `limits` must be valid (see SafetyLimits::validate); `period` is the
  /// tick period in s (sets the per-tick change limit).
  SafetyFilter(const SafetyLimits& limits, double period);

  /// Filters `force` (N, device frame) computed for the tick at time `t`
  /// (s); `conditions` are the SafetyFlag bits the caller detected
  /// (kSafetyDeviceFault, kSafetyNotReady, kSafetyStale, kSafetyBadInput,
  /// kSafetyLoopLate, kSafetyModelLate, kSafetyClutch, kSafetyJump). Returns
  /// the force to send: always finite, |f| <= max_force. `flags` receives
  /// every reason that applied.
  Vec3 apply(const Vec3& force, std::uint32_t conditions, double t, std::uint32_t& flags) noexcept;

  /// Enables output with a ramp-in starting at time `t` (s); clears a latched fault.
  void enable(double t) noexcept;
  /// Disables output (zero force from the next apply()).
  void disable() noexcept;

  bool enabled() const { return enabled_; }
  SafetyFault fault() const { return fault_; }
  /// The last force returned by apply(), N.
  const Vec3& last() const { return last_; }
  const SafetyLimits& limits() const { return limits_; }
  /// Largest change of the force vector per tick, N.
  double max_step() const { return max_step_; }

 private:
  SafetyLimits limits_{};
  double max_step_ = 0;
  bool enabled_ = false;
  bool holding_ = false;     // a hold condition was active at the previous tick
  double ramp_start_ = 0;    // s
  SafetyFault fault_ = SafetyFault::None;
  Vec3 last_ = Vec3::Zero();
};

}  // namespace palpa::haptics
