#pragma once
// Timing statistics of the haptic loop: fixed-size histograms that the haptic
// thread updates without allocation or locks and that any other thread reads
// to get percentiles, plus the summary the GUI and the benchmark print.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

namespace palpa::haptics {

/// Histogram of durations with 250 ns bins up to 16.384 ms (and an overflow
/// bin). One writer (record) and any number of readers; readers see counts
/// that are at most a few updates behind.
class DurationHistogram {
 public:
  static constexpr std::int64_t kBinNs = 250;
  static constexpr std::size_t kBins = 65536;

  DurationHistogram();

  /// Writer: adds one duration (ns; negative values count as 0).
  void record(std::int64_t ns) noexcept;
  /// Clears everything (only while the writer is idle).
  void reset() noexcept;

  std::uint64_t count() const noexcept { return count_.load(std::memory_order_relaxed); }
  /// Largest recorded duration, ns.
  std::int64_t max_ns() const noexcept { return max_.load(std::memory_order_relaxed); }
  /// Mean, ns (0 when empty).
  double mean_ns() const noexcept;
  /// The q-quantile (0 <= q <= 1), ns: the upper edge of the bin holding it
  /// (so never below the true value, at most 250 ns above; the max for the
  /// overflow bin). 0 when empty.
  std::int64_t quantile_ns(double q) const noexcept;

 private:
  std::unique_ptr<std::atomic<std::uint32_t>[]> bins_;
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::uint64_t> overflow_{0};
  std::atomic<std::int64_t> max_{0};
  std::atomic<std::int64_t> sum_{0};
};

/// Percentiles of one timing quantity, microseconds.
struct TimingSummary {
  double p50_us = 0, p90_us = 0, p99_us = 0, p999_us = 0, max_us = 0, mean_us = 0;
  std::uint64_t count = 0;
};

TimingSummary summarize(const DurationHistogram& h);

/// What the GUI and the benchmark read about the loop.
struct LoopStatistics {
  double nominal_rate_hz = 0;      ///< configured tick rate
  double achieved_rate_hz = 0;     ///< ticks / elapsed since start
  double elapsed_s = 0;
  std::uint64_t ticks = 0;
  std::uint64_t deadline_misses = 0;  ///< ticks that ended after their deadline (scheduled start + period)
  std::uint64_t skipped_periods = 0;  ///< periods with no tick at all because an earlier one overran
  std::uint64_t watchdog_trips = 0;   ///< ticks that started more than the watchdog limit after the previous
  std::uint64_t model_late_ticks = 0; ///< ticks that saw a deformation model older than its timeout
  std::uint64_t record_drops = 0;     ///< recorder items lost because the queue was full
  TimingSummary tick_duration;        ///< work per tick
  TimingSummary period_jitter;        ///< |actual period - nominal period|
  TimingSummary start_latency;        ///< actual start - scheduled start
  double deform_nominal_hz = 0;
  double deform_achieved_hz = 0;
  std::uint64_t deform_steps = 0;
  std::uint64_t deform_overruns = 0;  ///< deformation periods skipped because a step overran
  TimingSummary deform_step;          ///< time of one deformation step (both replicas), us
  bool realtime = false;              ///< the haptic thread got real-time priority
  /// Whether it got it and, if not, why and what to do; with real-time
  /// priority asked for, also what on the machine is known to stall the
  /// haptic thread (memory_monitor_notice), after "; ".
  std::string realtime_notice;
};

}  // namespace palpa::haptics
