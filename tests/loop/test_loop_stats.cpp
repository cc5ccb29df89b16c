// Duration histogram percentiles against a brute-force sort.

#include "haptics/loop_stats.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace palpa::haptics {
namespace {

TEST(DurationHistogram, QuantilesMatchSortedSamplesWithinOneBin) {
  DurationHistogram h;
  std::mt19937_64 rng(7);
  std::lognormal_distribution<double> dist(std::log(20'000.0), 0.8);  // ~20 us typical, ns
  std::vector<std::int64_t> v;
  for (int i = 0; i < 200'000; ++i) {
    const auto ns = static_cast<std::int64_t>(dist(rng));
    v.push_back(ns);
    h.record(ns);
  }
  std::sort(v.begin(), v.end());
  ASSERT_EQ(h.count(), v.size());
  EXPECT_EQ(h.max_ns(), v.back());
  for (double q : {0.5, 0.9, 0.99, 0.999}) {
    const std::int64_t exact = v[static_cast<std::size_t>(std::ceil(q * v.size())) - 1];
    const std::int64_t got = h.quantile_ns(q);
    EXPECT_GE(got, exact) << q;
    EXPECT_LE(got - exact, DurationHistogram::kBinNs) << q;
  }
  double sum = 0;
  for (auto x : v) sum += static_cast<double>(x);
  EXPECT_NEAR(h.mean_ns(), sum / v.size(), 1e-6 * sum / v.size());
}

TEST(DurationHistogram, OverflowAndNegativeValues) {
  DurationHistogram h;
  h.record(-5);                   // counts as 0
  h.record(50'000'000);           // 50 ms: beyond the bins
  EXPECT_EQ(h.count(), 2u);
  EXPECT_EQ(h.quantile_ns(0.5), DurationHistogram::kBinNs);
  EXPECT_EQ(h.quantile_ns(1.0), 50'000'000);
  h.reset();
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.quantile_ns(0.5), 0);
}

TEST(DurationHistogram, SummaryInMicroseconds) {
  DurationHistogram h;
  for (int i = 1; i <= 1000; ++i) h.record(i * 1000);  // 1 .. 1000 us
  const TimingSummary s = summarize(h);
  EXPECT_NEAR(s.p50_us, 500.0, 0.25);
  EXPECT_NEAR(s.p99_us, 990.0, 0.25);
  EXPECT_DOUBLE_EQ(s.max_us, 1000.0);
  EXPECT_NEAR(s.mean_us, 500.5, 1e-9);
}

}  // namespace
}  // namespace palpa::haptics
