// The warm-up schedule of the haptic thread's spin (haptics::warm_during_spin),
// on a clock the test moves by hand: every time below is exact, so each
// check is a closed form of the schedule, not a measurement.

#include "haptics/spin_warm.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <vector>

namespace palpa {
namespace {

using haptics::kWarmPollNs;
using haptics::warm_deadline_ns;
using haptics::warm_during_spin;

// A clock whose sleeps jump to their end.
struct StepClock {
  std::int64_t now = 0;
  std::int64_t now_ns() const { return now; }
  void sleep_until(std::int64_t ns, std::int64_t) {
    if (now < ns) now = ns;
  }
};

struct Warmed {
  std::vector<std::int64_t> starts;  // when each warm-up started, ns
  std::vector<int> replicas;         // which replica it warmed
};

// A spin of `spin` ns before a tick at `next`; the replica published at time
// t is published_at(t); each warm-up takes `cost` ns.
Warmed run_spin(std::int64_t next, std::int64_t spin, std::int64_t start, std::int64_t cost,
        const std::function<int(std::int64_t)>& published_at, const std::function<bool()>& stop = [] { return false; }) {
  StepClock clock;
  clock.now = start;
  Warmed r;
  bool stopped = false;
  warm_during_spin(
      clock, next, spin, [&] { return published_at(clock.now); },
      [&] {
        r.starts.push_back(clock.now);
        const int replica = published_at(clock.now);
        r.replicas.push_back(replica);
        clock.now += cost;
        return replica;
      },
      [&] { return stopped = stop(); });
  // Unless stopped, it returns once no look is left before the deadline,
  // never after the tick (the warm-ups here end before it).
  if (!stopped) {
    EXPECT_GE(clock.now + kWarmPollNs, next - warm_deadline_ns(spin));
  }
  EXPECT_LT(clock.now, next);
  return r;
}

constexpr std::int64_t kNext = 10'000'000;  // the tick, ns
constexpr std::int64_t kSpin = 400'000;     // 400 us: the workbench's spin at 1 kHz

TEST(SpinWarm, TheDeadlineIsAQuarterOfTheSpinAtMost50Us) {
  EXPECT_EQ(warm_deadline_ns(400'000), 50'000);
  EXPECT_EQ(warm_deadline_ns(200'000), 50'000);
  EXPECT_EQ(warm_deadline_ns(100'000), 25'000);
  EXPECT_EQ(warm_deadline_ns(40'000), 10'000);
  EXPECT_EQ(warm_deadline_ns(0), 0);
}

TEST(SpinWarm, OneWarmUpAtTheSpinsStartWhenNothingIsPublished) {
  const Warmed r = run_spin(kNext, kSpin, 0, 3'000, [](std::int64_t) { return 0; });
  ASSERT_EQ(r.starts.size(), 1u);
  EXPECT_EQ(r.starts[0], kNext - kSpin);
  EXPECT_EQ(r.replicas[0], 0);
}

TEST(SpinWarm, AReplicaPublishedDuringTheSpinIsWarmedAtTheNextLook) {
  // Replica 1 from 150 us into the spin. Looks are kWarmPollNs apart,
  // counted from the end of the warm-up before: 0 (warm, 3 us), 13, 23, ...
  // The first look at or after 150 us is at 153 us.
  const std::int64_t publish = kNext - kSpin + 150'000;
  const Warmed r = run_spin(kNext, kSpin, 0, 3'000, [&](std::int64_t t) { return t >= publish ? 1 : 0; });
  ASSERT_EQ(r.starts.size(), 2u);
  EXPECT_EQ(r.starts[0], kNext - kSpin);
  EXPECT_EQ(r.starts[1], kNext - kSpin + 153'000);
  EXPECT_EQ(r.replicas[1], 1);
}

TEST(SpinWarm, NoWarmUpStartsAfterTheDeadline) {
  // Published 20 us after the deadline (50 us before the tick): not warmed.
  const std::int64_t publish = kNext - warm_deadline_ns(kSpin) + 20'000;
  const Warmed r = run_spin(kNext, kSpin, 0, 3'000, [&](std::int64_t t) { return t >= publish ? 1 : 0; });
  ASSERT_EQ(r.starts.size(), 1u);
  // Published just before the deadline: warmed at the last look before it.
  const std::int64_t early = kNext - warm_deadline_ns(kSpin) - 8'000;
  const Warmed s = run_spin(kNext, kSpin, 0, 3'000, [&](std::int64_t t) { return t >= early ? 1 : 0; });
  ASSERT_EQ(s.starts.size(), 2u);
  EXPECT_LT(s.starts[1], kNext - warm_deadline_ns(kSpin));
  EXPECT_GE(s.starts[1], early);
}

TEST(SpinWarm, AWakeAfterTheDeadlineWarmsNothing) {
  // The thread woke late, past the deadline (a long sleep): no warm-up.
  const Warmed r = run_spin(kNext, kSpin, kNext - warm_deadline_ns(kSpin), 3'000, [](std::int64_t) { return 0; });
  EXPECT_TRUE(r.starts.empty());
  // Woke in the middle of the spin: the first warm-up is at once.
  const Warmed s = run_spin(kNext, kSpin, kNext - 200'000, 3'000, [](std::int64_t) { return 0; });
  ASSERT_EQ(s.starts.size(), 1u);
  EXPECT_EQ(s.starts[0], kNext - 200'000);
}

TEST(SpinWarm, EveryPublishIsWarmedOnceWhilePublishesAreFarApart) {
  // A new replica every 100 us from the spin's start: 0, 100, 200, 300 us
  // into the spin; the deadline is at 350 us. Each is warmed once, at the
  // first look after it: looks are 10 us apart, counted from the end of a
  // 2 us warm-up (0; 12, 22, ..., 102; 114, ..., 204; 216, ..., 306).
  const std::int64_t s0 = kNext - kSpin;
  const Warmed r = run_spin(kNext, kSpin, 0, 2'000, [&](std::int64_t t) { return t < s0 ? 0 : static_cast<int>((t - s0) / 100'000); });
  ASSERT_EQ(r.starts.size(), 4u);
  EXPECT_EQ(r.starts[0], s0);
  EXPECT_EQ(r.starts[1], s0 + 102'000);
  EXPECT_EQ(r.starts[2], s0 + 204'000);
  EXPECT_EQ(r.starts[3], s0 + 306'000);
  EXPECT_EQ(r.replicas, (std::vector<int>{0, 1, 2, 3}));
}

TEST(SpinWarm, StopEndsItBeforeAnyWarmUp) {
  const Warmed r = run_spin(kNext, kSpin, 0, 3'000, [](std::int64_t) { return 0; }, [] { return true; });
  EXPECT_TRUE(r.starts.empty());
  // Stopped after the first warm-up: no second one, though another replica came.
  int looks = 0;
  const Warmed s = run_spin(kNext, kSpin, 0, 3'000, [](std::int64_t t) { return t >= kNext - kSpin + 20'000 ? 1 : 0; },
                            [&] { return ++looks > 1; });
  ASSERT_EQ(s.starts.size(), 1u);
  EXPECT_EQ(s.starts[0], kNext - kSpin);
}

TEST(SpinWarm, AWarmUpThatRunsPastTheDeadlineIsTheLast) {
  // Each warm-up takes 200 us: the first (at the spin's start) ends at 200
  // us, the second starts at the next look (210 us) after replica 1 came
  // (at 100 us) and ends at 410 us, past the deadline (350 us) and the tick
  // (400 us): no third, and it returns at once, without a last look.
  const std::int64_t s0 = kNext - kSpin;
  StepClock clock;
  std::vector<std::int64_t> starts;
  warm_during_spin(
      clock, kNext, kSpin, [&] { return clock.now >= s0 + 100'000 ? 1 : 0; },
      [&] {
        starts.push_back(clock.now);
        const int replica = clock.now >= s0 + 100'000 ? 1 : 0;
        clock.now += 200'000;
        return replica;
      },
      [] { return false; });
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[1], s0 + 210'000);
  EXPECT_EQ(clock.now, s0 + 410'000);
}

}  // namespace
}  // namespace palpa
