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

/// How long before the tick the last warm-up starts, ns: a quarter of the
/// spin `spin_ns` (ns), at most 50 us, so a warm-up (about one tick's time,
/// a few microseconds) ends before the tick.
constexpr std::int64_t warm_deadline_ns(std::int64_t spin_ns) { return std::min<std::int64_t>(spin_ns / 4, 50'000); }

/// How late after that deadline the held warm-up may still start, ns: as
/// long as one look (kWarmPollNs), or half the deadline if less, is left
/// before the tick (40 us late at 1 kHz with the workbench's spin). A
/// virtual machine's host takes the CPU for 20 to 50 us about once a
/// millisecond; with only one look's slack, one tick in twenty lost its held
/// warm-up to such a pause on the 2-core VM, and those ticks took 2.7 times
/// as long at p50 (docs/PERFORMANCE.md, round 15).
constexpr std::int64_t held_slack_ns(std::int64_t spin_ns) {
  return warm_deadline_ns(spin_ns) - std::min<std::int64_t>(kWarmPollNs, warm_deadline_ns(spin_ns) / 2);
}

/// Spends the spin before a tick due at `next_ns` warming the tick's data.
///
/// From next_ns - spin_ns, every kWarmPollNs, it calls warm() whenever
/// published() (the replica the deformation thread made current) differs
/// from the one warmed last, until next_ns - warm_deadline_ns(spin_ns) (the
/// deadline) or until stop(). warm() warms and returns the replica it warmed
/// (which may be newer than the one published() named) and lets it go.
///
/// Then, at the deadline, the held warm-up: hold() takes the current
/// replica, warms it and keeps it taken; the tick is to read that replica
/// (even if another is published before the tick), so it finds every line it
/// needs in this CPU's caches, warmed at most warm_deadline_ns before. Its
/// index is returned. No held warm-up (-1 returned) after stop(), nor when
/// the thread reached the deadline later than held_slack_ns after it (a late
/// wake, or a warm-up that overran): the tick then takes the current replica
/// itself.
///
/// It returns as soon as there is nothing left to do before the tick: the
/// caller then sleeps or spins to the tick. `clock` has LoopClock's now_ns()
/// and sleep_until(ns, spin_ns), on the scale of next_ns (ns). No allocation.
template <class Clock, class Published, class Warm, class Hold, class Stop>
int warm_during_spin(Clock& clock, std::int64_t next_ns, std::int64_t spin_ns, Published&& published, Warm&& warm,
                     Hold&& hold, Stop&& stop) {
  const std::int64_t last_start = next_ns - warm_deadline_ns(spin_ns);
  std::int64_t at = next_ns - spin_ns;
  int warmed = -1;
  while (at < last_start) {
    clock.sleep_until(at, kWarmPollNs);  // the monotonic clock spins a wait this short
    if (stop()) return -1;
    if (clock.now_ns() >= last_start) break;
    if (published() != warmed) warmed = warm();
    at = clock.now_ns() + kWarmPollNs;
  }
  clock.sleep_until(last_start, kWarmPollNs);
  if (stop() || clock.now_ns() > last_start + held_slack_ns(spin_ns)) return -1;
  return hold();
}

/// How long before the tick the last touch of its data starts, ns
/// (touch_before_tick).
inline constexpr std::int64_t kTouchLeadNs = 10'000;
/// The latest a touch may start, ns before the tick: a touch (a warm-up and
/// the devices' reads, a few microseconds) that cannot start earlier would
/// delay the tick, so it is left out.
inline constexpr std::int64_t kTouchLatestNs = 5'000;

/// Touches the tick's data once more just before the tick at `next_ns`:
/// waits until next_ns - kTouchLeadNs and calls touch() there, unless stop()
/// or fewer than kTouchLatestNs are left before the tick. Returns whether
/// touch() ran. Nothing runs with a spin `spin_ns` shorter than kTouchLeadNs
/// (the thread would sleep through it).
///
/// Why: on a virtual machine a spinning CPU still loses its caches, more the
/// longer it waits (the host runs on it). The held warm-up of
/// warm_during_spin starts up to 50 us before the tick, and in the running
/// loop the tick's p99 was twice its cost right after a warm-up; the
/// devices' reads, which no warm-up ran, took up to 3 us of it
/// (docs/PERFORMANCE.md, round 33). `clock` as for warm_during_spin. No
/// allocation.
template <class Clock, class Touch, class Stop>
bool touch_before_tick(Clock& clock, std::int64_t next_ns, std::int64_t spin_ns, Touch&& touch, Stop&& stop) {
  if (spin_ns < kTouchLeadNs) return false;
  clock.sleep_until(next_ns - kTouchLeadNs, kWarmPollNs);
  if (stop() || clock.now_ns() > next_ns - kTouchLatestNs) return false;
  touch();
  return true;
}

}  // namespace palpa::haptics
