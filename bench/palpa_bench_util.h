#pragma once
// Timing statistics, clock overhead and copy bandwidth for palpa-bench.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace palpa::bench {

using Clock = std::chrono::steady_clock;

/// Nanoseconds between two steady_clock readings.
inline double elapsed_ns(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::nano>(b - a).count();
}

/// Latency statistics of a sample, microseconds. Percentiles use the
/// nearest-rank rule: the p-th percentile is the ceil(p n)-th smallest sample.
struct Latency {
  std::size_t samples = 0;
  double p50_us = 0;
  double p99_us = 0;
  double p999_us = 0;
  double max_us = 0;
  double mean_us = 0;
};

/// Statistics of durations given in nanoseconds (sorts `ns` in place).
Latency latency_of(std::vector<double>& ns);

/// Cost of one steady_clock::now() as seen by a timed region: the duration
/// between two back-to-back readings, over many pairs (ns).
struct ClockOverhead {
  double min_ns = 0;
  double p50_ns = 0;
  double p99_ns = 0;
};
ClockOverhead measure_clock_overhead();

/// Median seconds of memcpy(dst, src, bytes) over repetitions (at least
/// min_reps and about min_seconds in total); buffers are touched beforehand.
double median_memcpy_seconds(std::size_t bytes, int min_reps, double min_seconds);

/// One line on the transparent huge pages (core/huge_pages.h): the
/// system's setting and how much of this process's resident memory is in
/// huge pages now (from /proc/self/smaps_rollup; MB), for the figures'
/// context. Says so where the system does not tell.
std::string huge_page_report();

/// Median of a sample (sorts in place); 0 for an empty one.
double median(std::vector<double>& v);

/// Deterministic uniform numbers from a seeded std::mt19937_64 (whose output
/// sequence the standard fixes), independent of the library's distributions.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  /// Uniform in [0, 1).
  double uniform();
  /// Uniform integer in [0, n).
  std::uint64_t below(std::uint64_t n);

 private:
  std::mt19937_64 engine_;
};

/// "1.23M"-style count for tables (k, M, G suffixes).
std::string short_count(double n);

}  // namespace palpa::bench
