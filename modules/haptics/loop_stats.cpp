#include "haptics/loop_stats.h"

#include <algorithm>
#include <cmath>

namespace palpa::haptics {

DurationHistogram::DurationHistogram() : bins_(new std::atomic<std::uint32_t>[kBins]) { reset(); }

void DurationHistogram::reset() noexcept {
  for (std::size_t i = 0; i < kBins; ++i) bins_[i].store(0, std::memory_order_relaxed);
  count_.store(0, std::memory_order_relaxed);
  overflow_.store(0, std::memory_order_relaxed);
  max_.store(0, std::memory_order_relaxed);
  sum_.store(0, std::memory_order_relaxed);
}

// Single writer: plain load + store on relaxed atomics (no read-modify-write).
void DurationHistogram::record(std::int64_t ns) noexcept {
  if (ns < 0) ns = 0;
  const std::uint64_t bin = static_cast<std::uint64_t>(ns / kBinNs);
  if (bin < kBins) {
    auto& b = bins_[bin];
    b.store(b.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  } else {
    overflow_.store(overflow_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }
  if (ns > max_.load(std::memory_order_relaxed)) max_.store(ns, std::memory_order_relaxed);
  sum_.store(sum_.load(std::memory_order_relaxed) + ns, std::memory_order_relaxed);
  count_.store(count_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
}

double DurationHistogram::mean_ns() const noexcept {
  const std::uint64_t n = count();
  return n ? static_cast<double>(sum_.load(std::memory_order_relaxed)) / static_cast<double>(n) : 0.0;
}

// Walks the bins until the cumulative count reaches ceil(q * total).
std::int64_t DurationHistogram::quantile_ns(double q) const noexcept {
  std::uint64_t total = overflow_.load(std::memory_order_relaxed);
  for (std::size_t i = 0; i < kBins; ++i) total += bins_[i].load(std::memory_order_relaxed);
  if (total == 0) return 0;
  q = std::clamp(q, 0.0, 1.0);
  const auto rank = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(total))));
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i < kBins; ++i) {
    seen += bins_[i].load(std::memory_order_relaxed);
    if (seen >= rank) return std::min<std::int64_t>(static_cast<std::int64_t>(i + 1) * kBinNs, max_ns());
  }
  return max_ns();
}

TimingSummary summarize(const DurationHistogram& h) {
  TimingSummary s;
  s.count = h.count();
  s.p50_us = h.quantile_ns(0.5) * 1e-3;
  s.p90_us = h.quantile_ns(0.9) * 1e-3;
  s.p99_us = h.quantile_ns(0.99) * 1e-3;
  s.p999_us = h.quantile_ns(0.999) * 1e-3;
  s.max_us = h.max_ns() * 1e-3;
  s.mean_us = h.mean_ns() * 1e-3;
  return s;
}

}  // namespace palpa::haptics
