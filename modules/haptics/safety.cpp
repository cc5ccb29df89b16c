#include "haptics/safety.h"

#include "haptics/force.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace palpa::haptics {

namespace {

std::string number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

const char* to_string(SafetyFault f) {
  switch (f) {
    case SafetyFault::None: return "no fault";
    case SafetyFault::Device: return "device error or unplugged";
    case SafetyFault::NonFiniteForce: return "the model produced a non-finite force";
  }
  return "unknown fault";
}

// Every limit finite and positive (ramp_time may be 0).
void SafetyLimits::validate(const std::string& who) const {
  const std::string p = "safety limits of " + who + ": ";
  if (!(std::isfinite(max_force) && max_force > 0))
    throw std::invalid_argument(p + "max_force must be a positive finite number, got " + number(max_force));
  if (!(std::isfinite(max_force_rate) && max_force_rate > 0))
    throw std::invalid_argument(p + "max_force_rate must be a positive finite number, got " +
                                number(max_force_rate));
  if (!(std::isfinite(ramp_time) && ramp_time >= 0))
    throw std::invalid_argument(p + "ramp_time must be a finite number >= 0, got " + number(ramp_time));
  if (!(std::isfinite(max_jump) && max_jump > 0))
    throw std::invalid_argument(p + "max_jump must be a positive finite number, got " + number(max_jump));
}

SafetyFilter::SafetyFilter(const SafetyLimits& limits, double period)
    : limits_(limits), max_step_(limits.max_force_rate * period) {}

void SafetyFilter::enable(double t) noexcept {
  enabled_ = true;
  fault_ = SafetyFault::None;
  ramp_start_ = t;
  holding_ = false;
}

void SafetyFilter::disable() noexcept { enabled_ = false; }

Vec3 SafetyFilter::apply(const Vec3& force, std::uint32_t conditions, double t, std::uint32_t& flags) noexcept {
  flags = conditions & (kSafetyHoldMask | kSafetyDeviceFault);

  // Latching faults: a device error, or a model force that is not finite.
  if (conditions & kSafetyDeviceFault) {
    fault_ = SafetyFault::Device;
    enabled_ = false;
  } else if (enabled_ && !(conditions & kSafetyHoldMask) && !force.allFinite()) {
    fault_ = SafetyFault::NonFiniteForce;
    enabled_ = false;
    flags |= kSafetyNonFiniteForce;
  }
  if (fault_ != SafetyFault::None) flags |= kSafetyFaultLatched;

  // Disabled or held: zero at once (a stop is never rate limited). Leaving a
  // hold restarts the ramp-in.
  if (!enabled_ || (conditions & kSafetyHoldMask)) {
    if (!enabled_) flags |= kSafetyDisabled;
    if (enabled_) holding_ = true;
    last_ = Vec3::Zero();
    return last_;
  }
  if (holding_) {
    holding_ = false;
    ramp_start_ = t;
  }

  // Clamp to the device's maximum force, keeping the direction.
  bool clamped = false;
  Vec3 f = clamp_force(force, limits_.max_force, &clamped);
  if (clamped) flags |= kSafetyClamped;

  // Ramp-in: scale linearly from 0 to 1 over ramp_time after (re-)enabling.
  if (limits_.ramp_time > 0) {
    const double s = (t - ramp_start_) / limits_.ramp_time;
    if (!(s >= 1.0)) {  // also catches a NaN time
      f *= std::clamp(std::isfinite(s) ? s : 0.0, 0.0, 1.0);
      flags |= kSafetyRamping;
    }
  }

  // Limit the change of the force vector per tick.
  const Vec3 step = f - last_;
  const double n = step.norm();
  if (n > max_step_) {
    f = last_ + step * ((max_step_ / n) * (1.0 - 1e-12));
    flags |= kSafetyRateLimited;
  }

  // Final guard: finite and within the limit whatever happened above.
  if (!f.allFinite()) f = Vec3::Zero();
  f = clamp_force(f, limits_.max_force);
  last_ = f;
  return f;
}

}  // namespace palpa::haptics
