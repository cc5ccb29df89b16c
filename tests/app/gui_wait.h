#pragma once
// Waiting in the GUI tests: Qt's event loop runs (timers, queued signals,
// the frame timer) while a condition is polled. The tests wait for
// conditions with generous timeouts and never assert wall-time figures.

#include <QElapsedTimer>
#include <QTest>

#include <functional>

namespace palpa::app::gui_test {

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
