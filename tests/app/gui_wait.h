#pragma once
// Waiting in the GUI tests: Qt's event loop runs (timers, queued signals,
// the frame timer) while a condition is polled. The tests wait for
// conditions with generous timeouts and never assert wall-time figures.

#include <QElapsedTimer>
#include <QTest>

#include <functional>

namespace palpa::app::gui_test {

/// True in the sanitizer builds, which run the real-time loop many times
/// slower than its deadlines (ThreadSanitizer always, AddressSanitizer under
/// load): the safety chain then holds forces at zero (kSafetyLoopLate), as
/// it must. Tests that drive a scripted device in wall time accept that
/// there, and only there.
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSlowBuild = true;
#else
inline constexpr bool kSlowBuild = false;
#endif

/// Runs the event loop in steps of `poll_ms` (ms) until `done()` holds
/// (true) or `timeout_ms` (ms) have passed (false).
inline bool wait_until(const std::function<bool()>& done, int timeout_ms, int poll_ms = 20) {
  QElapsedTimer t;
  t.start();
  while (!done()) {
    if (t.elapsed() > timeout_ms) return false;
    QTest::qWait(poll_ms);
  }
  return true;
}

}  // namespace palpa::app::gui_test
