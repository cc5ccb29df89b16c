// The Diagnostics dock's panel.

#include "app/gui/diagnostics_panel.h"

#include "haptics/cpu_plan.h"

#include <QFormLayout>
#include <QLabel>
#include <QStringList>

#include <string>

namespace palpa::app {

DiagnosticsPanel::DiagnosticsPanel(QWidget* parent) : QWidget(parent) {
  setObjectName("diagnosticsPanel");
  auto* form = new QFormLayout(this);
  const auto label = [&](const char* name, const char* text, const char* row, const char* tip) {
    auto* l = new QLabel(text);
    l->setObjectName(name);
    l->setToolTip(tip);
    form->addRow(row, l);
    return l;
  };
  haptic_ = label("hapticRateReadout", "0 Hz", "Haptic rate", "Ticks per second the haptic loop achieved (nominal 1 kHz)");
  p99_ = label("tickP99Readout", "0 us", "Tick p99", "99th percentile of the work per haptic tick, microseconds");
  misses_ = label("missesReadout", "0", "Missed deadlines", "Ticks that ended after their deadline, since the loop started");
  miss_fraction_ = label("missFractionReadout", "-", "Missed (last second)",
                         "Share of the ticks of the last whole second that missed their deadline");
  frame_ = label("frameRateReadout", "0 fps", "Frame rate", "Frames the viewport drew per second (an idle view draws none)");
  renders_ = label("rendersReadout", "0", "Frames drawn", "Frames the viewport drew since the window opened");
  const int cpu = haptics::reserved_haptic_cpu();
  label("hapticCpuReadout", cpu >= 0 ? ("CPU " + std::to_string(cpu) + " (kept for it)").c_str() : "any (none kept)",
        "Haptic thread CPU",
        "The CPU the haptic thread has to itself; every other thread, the software renderer's included, runs on the "
        "others (PALPA_HAPTIC_CPU=off or a CPU number in the environment changes it)");
  memory_monitor_ = label("memoryMonitorReadout", "none", "Memory monitor", "");
  set_memory_monitors(haptics::running_memory_monitors());
}

void DiagnosticsPanel::set_memory_monitors(const std::vector<haptics::MemoryMonitor>& monitors) {
  memory_monitored_ = !monitors.empty();
  if (monitors.empty()) {
    memory_monitor_->setText("none");
    memory_monitor_->setToolTip(
        "No DAMON monitor samples this machine's memory (on a virtual machine its sampling stalled the haptic "
        "thread for milliseconds)");
    return;
  }
  QStringList names;
  for (const auto& m : monitors) names << QString("kdamond.%1").arg(m.index);
  memory_monitor_->setText("DAMON: " + names.join(", "));
  memory_monitor_->setToolTip(QString::fromStdString(haptics::memory_monitor_notice(monitors)));
}

void DiagnosticsPanel::restart() {
  have_window_ = false;
  bad_seconds_ = 0;
  set_warning({});
}

void DiagnosticsPanel::feed(const DiagnosticsSample& s) {
  haptic_->setText(QString::number(s.haptic_rate_hz, 'f', 0) + " Hz");
  p99_->setText(QString::number(s.tick_p99_us, 'f', 1) + " us");
  misses_->setText(QString::number(s.deadline_misses));
  frame_->setText(QString::number(s.frame_rate, 'f', 1) + " fps");
  renders_->setText(QString::number(s.renders));
  // Counters that went back: a new loop.
  if (have_window_ && (s.ticks < window_ticks_ || s.deadline_misses < window_misses_ || s.time < window_start_))
    restart();
  if (!have_window_) {
    have_window_ = true;
    window_start_ = s.time;
    window_ticks_ = s.ticks;
    window_misses_ = s.deadline_misses;
    return;
  }
  if (s.time - window_start_ < 1.0) return;
  // A whole second (or more) since the window started: judge it.
  const std::uint64_t ticks = s.ticks - window_ticks_;
  const std::uint64_t misses = s.deadline_misses - window_misses_;
  const double fraction = ticks > 0 ? static_cast<double>(misses) / static_cast<double>(ticks) : 0.0;
  miss_fraction_->setText(QString::number(100.0 * fraction, 'f', 2) + " %");
  bad_seconds_ = fraction > kMissFraction ? bad_seconds_ + 1 : 0;
  window_start_ = s.time;
  window_ticks_ = s.ticks;
  window_misses_ = s.deadline_misses;
  if (bad_seconds_ >= kBadSeconds)
    set_warning(QString("The haptic loop is missing deadlines (%1 % of ticks in the last second): the feel may be "
                        "rough. Close other programs, use fewer probes or a smaller mesh.%2")
                    .arg(100.0 * fraction, 0, 'f', 1)
                    .arg(memory_monitored_ ? " DAMON is sampling this machine's memory, which can stall the haptic "
                                             "thread: see Diagnostics > Memory monitor."
                                           : ""));
  else if (bad_seconds_ == 0)
    set_warning({});
}

void DiagnosticsPanel::set_warning(const QString& text) {
  if (text == warning_) return;
  warning_ = text;
  emit warningChanged(text);
}

}  // namespace palpa::app
