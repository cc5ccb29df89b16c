#pragma once
// The warm-up a haptic thread runs while it spins towards its next tick
// (LoopConfig::warm_before_tick). One schedule for HapticLoop and for
// palpa-bench's threaded run, so that the benchmark's haptic side waits and
// warms exactly as the loop does.

#include <algorithm>
#include <cstdint>

namespace palpa::haptics {

/// Time between two looks at the current model replica during the spin, ns.
inline constexpr std::int64_t kWarmPollNs = 10'000;

/// How long before the tick the last warm-up may start, ns: a quarter of
/// the spin `spin_ns` (ns), at most 50 us, so a warm-up (about one tick's
/// time) never makes the tick late.
constexpr std::int64_t warm_deadline_ns(std::int64_t spin_ns) { return std::min<std::int64_t>(spin_ns / 4, 50'000); }

/// Spends the start of the spin before a tick due at `next_ns` warming the
/// tick's data: from next_ns - spin_ns, every kWarmPollNs, it calls warm()
/// whenever published() (the replica the deformation thread made current)
/// differs from the one warmed last, until next_ns -
/// warm_deadline_ns(spin_ns) or until stop(). warm() warms and returns the
/// replica it warmed (which may be newer than the one published() named).
/// Returns as soon as no look is left before that deadline (at once after a
/// warm-up that ended within kWarmPollNs of it or past it): the caller then
/// sleeps or spins to the tick itself. `clock` has LoopClock's now_ns() and
/// sleep_until(ns, spin_ns), on the scale of next_ns (ns). No allocation.
template <class Clock, class Published, class Warm, class Stop>
void warm_during_spin(Clock& clock, std::int64_t next_ns, std::int64_t spin_ns, Published&& published, Warm&& warm,
                      Stop&& stop) {
  const std::int64_t last_start = next_ns - warm_deadline_ns(spin_ns);
  std::int64_t at = next_ns - spin_ns;
  int warmed = -1;
  for (;;) {
    clock.sleep_until(at, kWarmPollNs);  // the monotonic clock spins a wait this short
    if (stop() || clock.now_ns() >= last_start) return;
    if (published() != warmed) warmed = warm();
    at = clock.now_ns() + kWarmPollNs;
    if (at >= last_start) return;  // the next look would come too late: no sleep for it
  }
}

}  // namespace palpa::haptics
