// The warm-up schedule of the haptic thread's spin (haptics::warm_during_spin)
// and the replica it holds for the tick, on a clock the test moves by hand:
// every time below is exact, so each check is a closed form of the schedule,
// not a measurement.

#include "haptics/spin_warm.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <vector>

namespace palpa {
namespace {

using haptics::kWarmPollNs;
using haptics::held_slack_ns;
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
  std::vector<std::int64_t> starts;  // when each warm-up let go of its replica started, ns
  std::vector<int> replicas;         // which replica it warmed
  std::int64_t held_start = -1;      // when the held warm-up started, ns (-1: none)
  int held = -1;                     // what warm_during_spin returned: the replica held for the tick
};

// A spin of `spin` ns before a tick at `next`, the thread waking at `start`;
// the replica published at time t is published_at(t); each warm-up takes
// `cost` ns.
Warmed run_spin(std::int64_t next, std::int64_t spin, std::int64_t start, std::int64_t cost,
        const std::function<int(std::int64_t)>& published_at, const std::function<bool()>& stop = [] { return false; }) {
  StepClock clock;
  clock.now = start;
  Warmed r;
  int holds = 0, held_replica = -1;
  r.held = warm_during_spin(
      clock, next, spin, [&] { return published_at(clock.now); },
      [&] {
        r.starts.push_back(clock.now);
        const int replica = published_at(clock.now);
        r.replicas.push_back(replica);
        clock.now += cost;
        return replica;
      },
      [&] {
        ++holds;
        r.held_start = clock.now;
        held_replica = published_at(clock.now);
        clock.now += cost;
        return held_replica;
      },
      stop);
  // At most one held warm-up, and what it returns is what it held; it
  // returns before the tick (the warm-ups here end before it).
  EXPECT_LE(holds, 1);
  EXPECT_EQ(r.held, holds == 1 ? held_replica : -1);
  EXPECT_LT(clock.now, next);
  return r;
}

constexpr std::int64_t kNext = 10'000'000;  // the tick, ns
constexpr std::int64_t kSpin = 400'000;     // 400 us: the workbench's spin at 1 kHz before round 15 (850 us since)
constexpr std::int64_t kDeadline = kNext - 50'000;  // the held warm-up's time for kSpin

TEST(SpinWarm, TheDeadlineIsAQuarterOfTheSpinAtMost50Us) {
  EXPECT_EQ(warm_deadline_ns(400'000), 50'000);
  EXPECT_EQ(warm_deadline_ns(200'000), 50'000);
  EXPECT_EQ(warm_deadline_ns(100'000), 25'000);
  EXPECT_EQ(warm_deadline_ns(40'000), 10'000);
  EXPECT_EQ(warm_deadline_ns(0), 0);
  // The held warm-up may start as long as one look, or half the deadline if
  // less, is left before the tick.
  EXPECT_EQ(held_slack_ns(850'000), 40'000);  // 1 kHz, the workbench's spin
  EXPECT_EQ(held_slack_ns(400'000), 40'000);
  EXPECT_EQ(held_slack_ns(150'000), 27'500);  // 4 kHz: a 37.5 us deadline
  EXPECT_EQ(held_slack_ns(40'000), 5'000);
  EXPECT_EQ(held_slack_ns(0), 0);
}

TEST(SpinWarm, OneWarmUpAtTheSpinsStartAndTheHeldOneAtTheDeadline) {
  const Warmed r = run_spin(kNext, kSpin, 0, 3'000, [](std::int64_t) { return 0; });
  ASSERT_EQ(r.starts.size(), 1u);
  EXPECT_EQ(r.starts[0], kNext - kSpin);
  EXPECT_EQ(r.replicas[0], 0);
  EXPECT_EQ(r.held_start, kDeadline);
  EXPECT_EQ(r.held, 0);
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
  EXPECT_EQ(r.held_start, kDeadline);
  EXPECT_EQ(r.held, 1);
}

TEST(SpinWarm, AReplicaPublishedAfterTheDeadlineWaitsForTheNextTick) {
  // Published 20 us after the deadline (30 us before the tick): no warm-up
  // starts for it, and the tick keeps the replica held at the deadline.
  const std::int64_t publish = kDeadline + 20'000;
  const Warmed r = run_spin(kNext, kSpin, 0, 3'000, [&](std::int64_t t) { return t >= publish ? 1 : 0; });
  ASSERT_EQ(r.starts.size(), 1u);
  EXPECT_EQ(r.held_start, kDeadline);
  EXPECT_EQ(r.held, 0);
  // Published just before the deadline: warmed at the last look before it,
  // and held.
  const std::int64_t early = kDeadline - 8'000;
  const Warmed s = run_spin(kNext, kSpin, 0, 3'000, [&](std::int64_t t) { return t >= early ? 1 : 0; });
  ASSERT_EQ(s.starts.size(), 2u);
  EXPECT_LT(s.starts[1], kDeadline);
  EXPECT_GE(s.starts[1], early);
  EXPECT_EQ(s.held_start, kDeadline);
  EXPECT_EQ(s.held, 1);
}

TEST(SpinWarm, AWakeAtTheDeadlineHoldsOneAfterItWarmsNothing) {
  // Woke exactly at the deadline: only the held warm-up, at once.
  const Warmed r = run_spin(kNext, kSpin, kDeadline, 3'000, [](std::int64_t) { return 0; });
  EXPECT_TRUE(r.starts.empty());
  EXPECT_EQ(r.held_start, kDeadline);
  EXPECT_EQ(r.held, 0);
  // Woke with one look or more left before the tick: still held, at once.
  const Warmed late = run_spin(kNext, kSpin, kDeadline + 10'000, 3'000, [](std::int64_t) { return 0; });
  EXPECT_EQ(late.held_start, kDeadline + 10'000);
  const Warmed latest = run_spin(kNext, kSpin, kNext - 10'000, 3'000, [](std::int64_t) { return 0; });
  EXPECT_EQ(latest.held_start, kNext - 10'000);
  EXPECT_EQ(latest.held, 0);
  // Woke later than that (a long sleep): no warm-up; the tick takes the
  // current replica itself.
  const Warmed later = run_spin(kNext, kSpin, kNext - 9'999, 3'000, [](std::int64_t) { return 0; });
  EXPECT_TRUE(later.starts.empty());
  EXPECT_EQ(later.held_start, -1);
  EXPECT_EQ(later.held, -1);
  // Woke in the middle of the spin: the first warm-up is at once.
  const Warmed s = run_spin(kNext, kSpin, kNext - 200'000, 3'000, [](std::int64_t) { return 0; });
  ASSERT_EQ(s.starts.size(), 1u);
  EXPECT_EQ(s.starts[0], kNext - 200'000);
  EXPECT_EQ(s.held_start, kDeadline);
}

TEST(SpinWarm, EveryPublishIsWarmedOnceWhilePublishesAreFarApart) {
  // A new replica every 100 us from the spin's start: 0, 100, 200, 300 us
  // into the spin; the deadline is at 350 us. Each is warmed once, at the
  // first look after it: looks are 10 us apart, counted from the end of a
  // 2 us warm-up (0; 12, 22, ..., 102; 114, ..., 204; 216, ..., 306); the
  // last is held at the deadline.
  const std::int64_t s0 = kNext - kSpin;
  const Warmed r = run_spin(kNext, kSpin, 0, 2'000, [&](std::int64_t t) { return t < s0 ? 0 : static_cast<int>((t - s0) / 100'000); });
  ASSERT_EQ(r.starts.size(), 4u);
  EXPECT_EQ(r.starts[0], s0);
  EXPECT_EQ(r.starts[1], s0 + 102'000);
  EXPECT_EQ(r.starts[2], s0 + 204'000);
  EXPECT_EQ(r.starts[3], s0 + 306'000);
  EXPECT_EQ(r.replicas, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(r.held_start, kDeadline);
  EXPECT_EQ(r.held, 3);
}

TEST(SpinWarm, StopEndsItWithNothingHeld) {
  const Warmed r = run_spin(kNext, kSpin, 0, 3'000, [](std::int64_t) { return 0; }, [] { return true; });
  EXPECT_TRUE(r.starts.empty());
  EXPECT_EQ(r.held, -1);
  // Stopped after the first warm-up: no second one, though another replica
  // came, and none held.
  int looks = 0;
  const Warmed s = run_spin(kNext, kSpin, 0, 3'000, [](std::int64_t t) { return t >= kNext - kSpin + 20'000 ? 1 : 0; },
                            [&] { return ++looks > 1; });
  ASSERT_EQ(s.starts.size(), 1u);
  EXPECT_EQ(s.starts[0], kNext - kSpin);
  EXPECT_EQ(s.held, -1);
  // Stopped at the deadline: nothing held.
  const Warmed d = run_spin(kNext, kSpin, kDeadline, 3'000, [](std::int64_t) { return 0; }, [] { return true; });
  EXPECT_EQ(d.held, -1);
  // Woke 5 us before the deadline: not stopped at that look (a warm-up,
  // ending 2 us before the deadline), stopped when the deadline came: the
  // held warm-up does not run.
  int calls = 0;
  const Warmed e =
      run_spin(kNext, kSpin, kDeadline - 5'000, 3'000, [](std::int64_t) { return 0; }, [&] { return ++calls > 1; });
  EXPECT_EQ(e.starts, (std::vector<std::int64_t>{kDeadline - 5'000}));
  EXPECT_EQ(e.held, -1);
  EXPECT_EQ(calls, 2);
}

TEST(SpinWarm, AWarmUpEndingWithALookLeftBeforeTheTickIsFollowedByTheHeldOne) {
  // Woke 5 us before the deadline (55 us before the tick); the warm-up there
  // takes 9 us and ends 4 us after the deadline: the held warm-up follows at
  // once. With 45 us it ends 40 us after the deadline, one look (10 us)
  // before the tick: still held. With 46 us (less than a look left): none.
  const Warmed r = run_spin(kNext, kSpin, kDeadline - 5'000, 9'000, [](std::int64_t) { return 0; });
  ASSERT_EQ(r.starts.size(), 1u);
  EXPECT_EQ(r.held_start, kDeadline + 4'000);
  // The first warm-up takes `first` ns, the held one 3 us; returns when the
  // held one started (-1: none).
  auto held_after = [](std::int64_t first) {
    StepClock clock;
    clock.now = kDeadline - 5'000;
    std::int64_t held_start = -1;
    const int held = warm_during_spin(
        clock, kNext, kSpin, [] { return 0; },
        [&] {
          clock.now += first;
          return 0;
        },
        [&] {
          held_start = clock.now;
          clock.now += 3'000;
          return 0;
        },
        [] { return false; });
    EXPECT_EQ(held, held_start >= 0 ? 0 : -1);
    return held_start;
  };
  EXPECT_EQ(held_after(45'000), kNext - 10'000);
  EXPECT_EQ(held_after(46'000), -1);
}

TEST(SpinWarm, AWarmUpThatRunsPastTheDeadlineIsTheLast) {
  // Each warm-up takes 200 us: the first (at the spin's start) ends at 200
  // us, the second starts at the next look (210 us) after replica 1 came
  // (at 100 us) and ends at 410 us, past the deadline (350 us) and the tick
  // (400 us): no third, none held, and it returns at once, without a last
  // look.
  const std::int64_t s0 = kNext - kSpin;
  StepClock clock;
  std::vector<std::int64_t> starts;
  int holds = 0;
  const int held = warm_during_spin(
      clock, kNext, kSpin, [&] { return clock.now >= s0 + 100'000 ? 1 : 0; },
      [&] {
        starts.push_back(clock.now);
        const int replica = clock.now >= s0 + 100'000 ? 1 : 0;
        clock.now += 200'000;
        return replica;
      },
      [&] { return ++holds; }, [] { return false; });
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[1], s0 + 210'000);
  EXPECT_EQ(clock.now, s0 + 410'000);
  EXPECT_EQ(holds, 0);
  EXPECT_EQ(held, -1);
}

// The touch just before the tick (haptics::touch_before_tick), on the same
// hand-moved clock: at kTouchLeadNs before the tick, unless the thread gets
// there later than kTouchLatestNs before it, or is stopping, or its spin is
// shorter than the lead.
struct Touched {
  int touches = 0;
  std::int64_t at = -1;  // when the touch ran, ns
  bool returned = false;
  std::int64_t end = 0;  // the clock when touch_before_tick returned, ns
};

Touched run_touch(std::int64_t next, std::int64_t spin, std::int64_t start, bool stopping = false) {
  StepClock clock;
  clock.now = start;
  Touched r;
  r.returned = haptics::touch_before_tick(
      clock, next, spin,
      [&] {
        ++r.touches;
        r.at = clock.now;
        clock.now += 3'000;  // a touch of 3 us
      },
      [&] { return stopping; });
  r.end = clock.now;
  return r;
}

TEST(SpinWarm, TheTouchRunsTenMicrosecondsBeforeTheTick) {
  using haptics::kTouchLatestNs;
  using haptics::kTouchLeadNs;
  EXPECT_EQ(kTouchLeadNs, 10'000);
  EXPECT_EQ(kTouchLatestNs, 5'000);
  // After the held warm-up (50 us before the tick): it waits for the lead.
  const Touched r = run_touch(kNext, kSpin, kDeadline + 3'000);
  EXPECT_TRUE(r.returned);
  EXPECT_EQ(r.touches, 1);
  EXPECT_EQ(r.at, kNext - kTouchLeadNs);
  EXPECT_LT(r.end, kNext);
  // Got there late, but with kTouchLatestNs or more left: at once.
  const Touched late = run_touch(kNext, kSpin, kNext - 7'000);
  EXPECT_EQ(late.at, kNext - 7'000);
  const Touched latest = run_touch(kNext, kSpin, kNext - kTouchLatestNs);
  EXPECT_EQ(latest.at, kNext - kTouchLatestNs);
  EXPECT_TRUE(latest.returned);
}

TEST(SpinWarm, NoTouchTooCloseToTheTickWhenStoppingOrWithAShortSpin) {
  // Less than kTouchLatestNs left: left out, and the clock not moved.
  const Touched r = run_touch(kNext, kSpin, kNext - haptics::kTouchLatestNs + 1);
  EXPECT_FALSE(r.returned);
  EXPECT_EQ(r.touches, 0);
  EXPECT_EQ(r.end, kNext - haptics::kTouchLatestNs + 1);
  // Stopping: no touch (after the wait for the lead).
  const Touched s = run_touch(kNext, kSpin, kDeadline, true);
  EXPECT_FALSE(s.returned);
  EXPECT_EQ(s.touches, 0);
  // A spin shorter than the lead: no wait, no touch (the thread would have
  // slept through the lead).
  const Touched shortspin = run_touch(kNext, haptics::kTouchLeadNs - 1, kNext - 50'000);
  EXPECT_FALSE(shortspin.returned);
  EXPECT_EQ(shortspin.touches, 0);
  EXPECT_EQ(shortspin.end, kNext - 50'000);
  // A spin of exactly the lead: touched.
  EXPECT_EQ(run_touch(kNext, haptics::kTouchLeadNs, kNext - 50'000).touches, 1);
}

}  // namespace
}  // namespace palpa
