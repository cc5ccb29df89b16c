#pragma once
// The engineering figures of the running haptic loop and the window (the
// Diagnostics dock, hidden by default): haptic rate, tick p99, missed
// deadlines, frame rate, renders. It also watches the misses: when more
// than 1 % of the ticks miss their deadline in each of 3 consecutive
// seconds it raises a warning with advice (warningChanged; the window shows
// it in the status bar), and clears it after a good second. Fed figures
// directly (feed()), it needs no timing of its own. It also says whether a
// DAMON monitor samples the machine's memory (the "Memory monitor" row),
// which on the CI VM stalled the haptic thread for milliseconds.

#include "haptics/cpu_plan.h"

#include <QString>
#include <QWidget>

#include <cstdint>
#include <vector>

class QLabel;

namespace palpa::app {

/// The loop's cumulative counters at one moment, and the window's rates.
struct DiagnosticsSample {
  double time = 0;                  ///< s, any monotonic clock (the loop's)
  std::uint64_t ticks = 0;          ///< since the loop started
  std::uint64_t deadline_misses = 0;
  double haptic_rate_hz = 0;
  double tick_p99_us = 0;
  double frame_rate = 0;            ///< frames drawn per second
  std::uint64_t renders = 0;        ///< frames drawn since the window opened
};

class DiagnosticsPanel : public QWidget {
  Q_OBJECT
 public:
  static constexpr double kMissFraction = 0.01;  ///< a bad second misses more than this
  static constexpr int kBadSeconds = 3;          ///< consecutive bad seconds that raise the warning

  explicit DiagnosticsPanel(QWidget* parent = nullptr);
  /// New figures (a few times a second, or as a test likes).
  void feed(const DiagnosticsSample& s);
  /// A new loop: its counters start again.
  void restart();
  /// The warning shown now (empty: none).
  QString warning() const { return warning_; }
  int bad_seconds() const { return bad_seconds_; }
  /// The DAMON monitors running on the machine (the constructor reads them:
  /// haptics::running_memory_monitors): shown in the "Memory monitor" row,
  /// with haptics::memory_monitor_notice as its tooltip, and named in the
  /// missed-deadline warning (docs/PERFORMANCE.md, round 18).
  void set_memory_monitors(const std::vector<haptics::MemoryMonitor>& monitors);

 signals:
  void warningChanged(const QString& text);

 private:
  void set_warning(const QString& text);

  QLabel* haptic_ = nullptr;
  QLabel* p99_ = nullptr;
  QLabel* misses_ = nullptr;
  QLabel* miss_fraction_ = nullptr;
  QLabel* frame_ = nullptr;
  QLabel* renders_ = nullptr;
  QLabel* memory_monitor_ = nullptr;
  bool memory_monitored_ = false;
  bool have_window_ = false;
  double window_start_ = 0;
  std::uint64_t window_ticks_ = 0, window_misses_ = 0;
  int bad_seconds_ = 0;
  QString warning_;
};

}  // namespace palpa::app
