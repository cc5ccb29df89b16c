#pragma once
// A hand-driven LoopClock for threaded loop tests: time moves only when the
// test advances it, so a HapticLoop makes exactly one tick per period the
// test adds, and a test issues its commands and device positions by tick,
// not by wall time. The waits that real time still bounds (the loop thread
// must react) use a generous timeout and fail the test instead of hanging;
// nothing is asserted about how long anything takes.

#include "haptics/loop.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>

namespace palpa::test {

class ManualClock final : public haptics::LoopClock {
 public:
  /// Starts at `start_ns` (1 s: the model's first tick then has a positive time).
  explicit ManualClock(std::int64_t start_ns = 1'000'000'000) : now_(start_ns) {}

  std::int64_t now_ns() override {
    std::lock_guard<std::mutex> lock(mutex_);
    return now_;
  }
  double now_s() { return static_cast<double>(now_ns()) * 1e-9; }

  /// Blocks until the test has advanced time to `ns` or beyond, or
  /// interrupt() was called (then returns at once, now and on every later
  /// call, until reset()).
  void sleep_until(std::int64_t ns, std::int64_t) override {
    std::unique_lock<std::mutex> lock(mutex_);
    // The loop's thread is done with its tick: wake await()ers.
    changed_.notify_all();
    changed_.wait(lock, [&] { return now_ >= ns || interrupted_; });
  }
  void interrupt() override {
    std::lock_guard<std::mutex> lock(mutex_);
    interrupted_ = true;
    changed_.notify_all();
  }
  /// Clears an interrupt (before a stopped loop is started again).
  void reset() {
    std::lock_guard<std::mutex> lock(mutex_);
    interrupted_ = false;
  }

  void advance(std::int64_t ns) {
    std::lock_guard<std::mutex> lock(mutex_);
    now_ += ns;
    changed_.notify_all();
  }

  /// Waits (real time, at most `timeout`) until `done()`, re-checking it
  /// each time a thread goes to sleep on this clock (a loop that finished
  /// its tick) and every 100 us (other threads' progress). Sleeping rather
  /// than spinning leaves the CPU to the loop's threads on a loaded machine.
  template <class Pred>
  bool await(Pred done, std::chrono::steady_clock::duration timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    std::unique_lock<std::mutex> lock(mutex_);
    while (!done()) {
      if (std::chrono::steady_clock::now() > end) return done();
      changed_.wait_for(lock, std::chrono::microseconds(100));
    }
    return true;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::int64_t now_;
  bool interrupted_ = false;
};

/// Real-time bound on one wait for the loop's threads: far beyond anything a
/// loaded machine needs, only there so that a broken loop fails the test.
inline constexpr std::chrono::seconds kLoopWaitTimeout{10};

/// Waits (real time, at most `timeout`) until `done()`; true when it held.
template <class Pred>
bool wait_until(Pred done, std::chrono::steady_clock::duration timeout = kLoopWaitTimeout) {
  // Short naps, no spinning: on a loaded machine a spinning waiter takes
  // the CPU time the loop's threads need.
  const auto end = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (done()) return true;
    if (std::chrono::steady_clock::now() > end) return done();
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
}

/// The loop's tick period in ns, as HapticLoop computes it.
inline std::int64_t period_ns(const haptics::HapticLoop& loop) {
  return static_cast<std::int64_t>(std::llround(1e9 / loop.config().core.rate_hz));
}

/// Runs a started `loop` whose clock is `clock` exactly `n` ticks: before
/// each, `before(tick)` (the number of the tick about to run) may set the
/// devices and issue commands; then time advances one period and the helper
/// waits until that tick is made and every deformation step it asked for
/// too. Between ticks the loop is quiescent (the haptic thread sleeps, the
/// deformation thread has nothing to do), so each tick sees the model the
/// previous one asked for, exactly as Session::step does. Adds a test
/// failure and returns false when the loop does not tick within
/// kLoopWaitTimeout (or ticks more than once).
inline bool run_ticks(haptics::HapticLoop& loop, ManualClock& clock, std::uint64_t n,
                      const std::function<void(std::uint64_t)>& before = {}) {
  const std::int64_t period = period_ns(loop);
  for (std::uint64_t i = 0; i < n; ++i) {
    const std::uint64_t tick = loop.ticks();
    if (before) before(tick);
    clock.advance(period);
    if (!clock.await([&] { return loop.ticks() > tick && loop.deform_idle(); }, kLoopWaitTimeout)) {
      ADD_FAILURE() << "the loop did not make tick " << tick << " (and its deformation step) within "
                    << kLoopWaitTimeout.count() << " s of real time";
      return false;
    }
    if (loop.ticks() != tick + 1) {
      ADD_FAILURE() << "one period made " << loop.ticks() - tick << " ticks";
      return false;
    }
  }
  return true;
}

}  // namespace palpa::test
