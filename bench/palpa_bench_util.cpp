// Timing statistics, clock overhead and copy bandwidth for palpa-bench.

#include "palpa_bench_util.h"

#include "core/huge_pages.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>

namespace palpa::bench {

Latency latency_of(std::vector<double>& ns) {
  Latency l;
  l.samples = ns.size();
  if (ns.empty()) return l;
  std::sort(ns.begin(), ns.end());
  // Nearest rank: the ceil(p n)-th smallest sample (1-based).
  auto rank = [&](double p) {
    const auto r = static_cast<std::size_t>(std::ceil(p * static_cast<double>(ns.size())));
    return ns[std::clamp<std::size_t>(r, 1, ns.size()) - 1] * 1e-3;
  };
  l.p50_us = rank(0.50);
  l.p99_us = rank(0.99);
  l.p999_us = rank(0.999);
  l.max_us = ns.back() * 1e-3;
  double sum = 0;
  for (double x : ns) sum += x;
  l.mean_us = sum / static_cast<double>(ns.size()) * 1e-3;
  return l;
}

double median(std::vector<double>& v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

ClockOverhead measure_clock_overhead() {
  // Back-to-back readings, exactly as the timed regions take them.
  constexpr int kPairs = 200000;
  std::vector<double> d;
  d.reserve(kPairs);
  for (int i = 0; i < kPairs; ++i) {
    const auto a = Clock::now();
    const auto b = Clock::now();
    d.push_back(elapsed_ns(a, b));
  }
  std::sort(d.begin(), d.end());
  ClockOverhead c;
  c.min_ns = d.front();
  c.p50_ns = d[d.size() / 2];
  c.p99_ns = d[d.size() * 99 / 100];
  return c;
}

std::string huge_page_report() {
  const std::string setting = core::huge_page_setting();
  long rss_kb = -1, huge_kb = -1;
  {
    std::ifstream in("/proc/self/smaps_rollup");
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("Rss:", 0) == 0) rss_kb = std::atol(line.c_str() + 4);
      if (line.rfind("AnonHugePages:", 0) == 0) huge_kb = std::atol(line.c_str() + 14);
    }
  }
  char text[256];
  if (setting.empty() || rss_kb < 0 || huge_kb < 0) {
    std::snprintf(text, sizeof text, "transparent huge pages: not known here (no /sys/kernel/mm/transparent_hugepage "
                                     "or /proc/self/smaps_rollup)");
  } else {
    std::snprintf(text, sizeof text,
                  "transparent huge pages: system setting '%s'; this process holds %.0f MB in huge pages of %.0f MB "
                  "resident",
                  setting.c_str(), huge_kb / 1024.0, rss_kb / 1024.0);
  }
  return text;
}

double median_memcpy_seconds(std::size_t bytes, int min_reps, double min_seconds) {
  // Two buffers, touched first so that page faults are not timed.
  const std::size_t n = std::max<std::size_t>(bytes, 64);
  std::unique_ptr<unsigned char[]> src(new unsigned char[n]);
  std::unique_ptr<unsigned char[]> dst(new unsigned char[n]);
  std::memset(src.get(), 1, n);
  std::memset(dst.get(), 2, n);
  std::memcpy(dst.get(), src.get(), n);  // warm-up copy
  // Repeat until both the count and the time budget are met (capped).
  std::vector<double> s;
  double total = 0;
  while ((static_cast<int>(s.size()) < min_reps || total < min_seconds) && s.size() < 1000) {
    const auto a = Clock::now();
    std::memcpy(dst.get(), src.get(), n);
    const auto b = Clock::now();
    s.push_back(elapsed_ns(a, b) * 1e-9);
    total += s.back();
    src[s.size() % n] ^= dst[(s.size() * 7) % n];  // keep the copies observable
  }
  return median(s);
}

double Random::uniform() {
  // 53 random bits -> [0, 1).
  return static_cast<double>(engine_() >> 11) * 0x1.0p-53;
}

std::uint64_t Random::below(std::uint64_t n) {
  return n == 0 ? 0 : static_cast<std::uint64_t>(uniform() * static_cast<double>(n)) % n;
}

std::string short_count(double n) {
  char buf[32];
  if (n >= 1e9)
    std::snprintf(buf, sizeof buf, "%.3gG", n * 1e-9);
  else if (n >= 1e6)
    std::snprintf(buf, sizeof buf, "%.3gM", n * 1e-6);
  else if (n >= 1e3)
    std::snprintf(buf, sizeof buf, "%.3gk", n * 1e-3);
  else
    std::snprintf(buf, sizeof buf, "%.0f", n);
  return buf;
}

}  // namespace palpa::bench
