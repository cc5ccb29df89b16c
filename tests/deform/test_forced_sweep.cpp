// The full step's sweep over vertices in a field (deform/forced_sweep.h),
// at each width the processor runs, against a vertex-by-vertex reference written
// here from what the header promises: the Linear step in its order of
// operations, the drawn height clamped to the limit, the stream's height
// rewritten (and marked dirty) only where it differs, the changed and
// active lists in index order, vertices at rest outside every field left
// as they are, and a stop at the first block with no vertex in
// a field or at the first four with a vertex outside every field that is
// active or moving. Inputs are chosen to reach every branch: -0 and NaN in
// the state and the stream, zero and infinite limits, stream heights equal
// to the new ones, dirty and changed marks on some vertices of a four, and
// vertices at rest, active or moving beside vertices in a field.

#include "deform/forced_sweep.h"
#include "deform/vertex_flags.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

using palpa::Index;
using palpa::deform::LinearStep;
using palpa::deform::VertexState;
using namespace palpa::deform::internal;

namespace {

struct Arrays {
  std::vector<VertexState> state;
  std::vector<double> force, limit;
  std::vector<std::uint8_t> flags;
  std::vector<float> stream;
  std::vector<std::uint64_t> dirty_blocks;
  std::vector<Index> active, changed;
  std::size_t active_size = 0, changed_size = 0;
};

bool at_rest(const VertexState& s) {
  std::uint64_t w[3];
  std::memcpy(w, &s, sizeof w);
  return ((w[0] | w[1] | w[2]) << 1) == 0;
}

// Vertex by vertex, from `begin`: blocks of eight with a vertex in a field,
// four by four while the vertices outside every field are inactive and at rest.
std::size_t reference(Arrays& a, const LinearStep& step, bool all_dirty, std::size_t begin, std::size_t end) {
  for (std::size_t i = begin; i < end; i += 8) {
    bool any = false;
    for (std::size_t j = i; j < i + 8; ++j) any = any || (a.flags[j] & kForced);
    if (!any) return i;
    for (std::size_t g = i; g < i + 8; g += 4) {
      for (std::size_t j = g; j < g + 4; ++j) {
        if (!(a.flags[j] & kForced) && ((a.flags[j] & kActive) || !at_rest(a.state[j]))) return g;
      }
      for (std::size_t j = g; j < g + 4; ++j) {
        std::uint8_t f = a.flags[j];
        if (!(f & kForced)) continue;
        VertexState& s = a.state[j];
        step.apply(s, a.force[j]);
        const double h = s.h, lim = a.limit[j];
        const double drawn = h < -lim ? -lim : (h > lim ? lim : h);
        float& p = a.stream[4 * j + 3];
        if (p != static_cast<float>(drawn)) {
          p = static_cast<float>(drawn);
          if (!all_dirty && !(f & kDirty)) {
            f |= kDirty;
            mark_block(a.dirty_blocks.data(), static_cast<Index>(j));
          }
        }
        if (!(f & kChanged)) {
          f |= kChanged;
          a.changed[a.changed_size++] = static_cast<Index>(j);
        }
        a.flags[j] = static_cast<std::uint8_t>(f | kActive);
        a.active[a.active_size++] = static_cast<Index>(j);
      }
    }
  }
  return end;
}

template <class T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

// A random surface's arrays: `count` vertices, most in a field; about one
// in `rest_every` outside every field and at rest, and about one in
// `odd_every` outside every field and active or moving (the run stops
// there); about one block in `gap_every` with no vertex in a field.
Arrays random_arrays(std::mt19937_64& rng, std::size_t count, int rest_every, int odd_every, int gap_every,
                     const LinearStep& step) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> pick(0, 15);
  auto one_in = [&rng](int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng) == 0; };
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  auto value = [&](double scale) {
    switch (pick(rng)) {
      case 0: return 0.0;
      case 1: return -0.0;
      case 2: return pick(rng) == 0 ? nan : 0.0;
      default: return scale * u(rng);
    }
  };
  auto signed_zero = [&] { return pick(rng) < 8 ? 0.0 : -0.0; };
  Arrays a;
  a.state.resize(count);
  a.force.resize(count);
  a.limit.resize(count);
  a.flags.resize(count);
  a.stream.resize(4 * count);
  a.dirty_blocks.assign(count / 4096 + 1, 0);
  a.active.assign(count, 0);
  a.changed.assign(count, 0);
  for (std::size_t i = 0; i < count; ++i) {
    a.state[i] = {value(0.004), value(0.5), value(1.0)};
    a.force[i] = value(2.0);
    const int l = pick(rng);
    a.limit[i] = l == 0 ? 0.0 : (l == 1 ? inf : 0.001 + 0.003 * std::abs(u(rng)));
    std::uint8_t f = kForced | kActive;
    if (pick(rng) < 4) f |= kDirty;
    if (pick(rng) < 6) f |= kChanged;
    if (one_in(rest_every)) {
      f &= static_cast<std::uint8_t>(~(kForced | kActive));
      a.state[i] = {signed_zero(), signed_zero(), signed_zero()};
    } else if (one_in(odd_every)) {
      // Outside every field, and active (it left a field) or moving.
      // (An active one at rest leaves the active set in this step.)
      f &= static_cast<std::uint8_t>(~kForced);
      if (pick(rng) < 8) {
        // Inactive, and moving in h, v or q alone (the others zero).
        f &= static_cast<std::uint8_t>(~kActive);
        a.state[i] = {signed_zero(), signed_zero(), signed_zero()};
        const int which = pick(rng) % 3;
        (which == 0 ? a.state[i].h : (which == 1 ? a.state[i].v : a.state[i].q)) = 0.25;
      } else if (pick(rng) < 8) {
        a.state[i] = {signed_zero(), signed_zero(), signed_zero()};
      }
    }
    a.flags[i] = f;
  }
  for (std::size_t b = 0; b < count; b += 8) {
    if (!one_in(gap_every)) continue;
    for (std::size_t j = b; j < b + 8; ++j) {
      a.flags[j] &= static_cast<std::uint8_t>(~(kForced | kActive));
      a.state[j] = {};
    }
  }
  // Stream heights: some already what the step will write (no rewrite, no
  // mark), some off, some -0 where the step writes +0; the corrections
  // before them are left as they are.
  for (std::size_t i = 0; i < count; ++i) {
    VertexState s = a.state[i];
    step.apply(s, a.force[i]);
    const double lim = a.limit[i];
    const float drawn = static_cast<float>(s.h < -lim ? -lim : (s.h > lim ? lim : s.h));
    for (int k = 0; k < 3; ++k) a.stream[4 * i + k] = static_cast<float>(value(0.3));
    float& p = a.stream[4 * i + 3];
    const int how = pick(rng);
    p = how < 5 ? drawn + 0.25f : (how == 5 && drawn == 0.0f ? -drawn : drawn);
  }
  return a;
}

// The widths this processor runs; the test says which it cannot.
std::string width_name(ForcedRunWidth w) { return w == ForcedRunWidth::Eight ? "eight-wide" : "four-wide"; }

class ForcedSweep : public ::testing::TestWithParam<ForcedRunWidth> {
 protected:
  void SetUp() override {
    if (!forced_run_available(GetParam())) {
      GTEST_SKIP() << "this processor cannot run the " << width_name(GetParam())
                   << " sweep (four-wide needs AVX2; eight-wide also AVX-512 F, VL, BW, DQ and BMI2), so "
                      "step_full never takes it here (the Surface tests cover the path it takes)";
    }
  }
};

INSTANTIATE_TEST_SUITE_P(Widths, ForcedSweep, ::testing::Values(ForcedRunWidth::Four, ForcedRunWidth::Eight),
                         [](const ::testing::TestParamInfo<ForcedRunWidth>& info) {
                           return info.param == ForcedRunWidth::Eight ? std::string("Eight") : std::string("Four");
                         });

TEST_P(ForcedSweep, EqualsTheVertexByVertexSweepBitForBit) {
  LinearStep step;
  step.p00 = 0.93;
  step.p01 = 1.7e-3;
  step.p10 = -41.0;
  step.p11 = 0.81;
  step.inv_k = 1.0 / 350.0;
  std::mt19937_64 rng(20261207);
  int stops_at_gap = 0, stops_in_block = 0, partial_changes = 0, partial_fields = 0, whole_blocks = 0,
      whole_blocks_partly_changed = 0, blocks_beside_rest = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const std::size_t count = 8 * static_cast<std::size_t>(1 + trial % 700);
    Arrays ours = random_arrays(rng, count, 3 + trial % 9, 20 + 400 * (trial % 4), 4 + trial % 60, step);
    for (std::size_t g = 0; g < count; g += 4) {
      int marked = 0, forced = 0;
      for (std::size_t k = g; k < g + 4; ++k) {
        marked += (ours.flags[k] & kChanged) != 0;
        forced += (ours.flags[k] & kForced) != 0;
      }
      partial_changes += marked > 0 && marked < 4;
      partial_fields += forced > 0 && forced < 4;
    }
    for (std::size_t b = 0; b < count; b += 8) {
      int marked = 0, forced = 0;
      for (std::size_t k = b; k < b + 8; ++k) {
        marked += (ours.flags[k] & kChanged) != 0;
        forced += (ours.flags[k] & kForced) != 0;
      }
      whole_blocks += forced == 8;
      whole_blocks_partly_changed += forced == 8 && marked > 0 && marked < 8;
      bool others_rest = true;
      for (std::size_t k = b; k < b + 8; ++k) {
        if (!(ours.flags[k] & kForced) && ((ours.flags[k] & kActive) || !at_rest(ours.state[k]))) others_rest = false;
      }
      blocks_beside_rest += forced > 0 && forced < 8 && others_rest;
    }
    const bool all_dirty = trial % 5 == 4;
    ours.active_size = trial % 3;  // lists already holding earlier vertices
    ours.changed_size = trial % 2;
    Arrays ref = ours;
    const std::size_t begin = 8 * static_cast<std::size_t>(trial % 3 == 0 ? 0 : trial % (count / 8));
    ForcedRun run{ours.state.data(),  ours.force.data(),  ours.limit.data(),   ours.flags.data(),
                  ours.stream.data(), ours.dirty_blocks.data(), all_dirty,   ours.active.data(),
                  ours.active_size,   ours.changed.data(),      ours.changed_size, step};
    const std::size_t stop = advance_forced_run(GetParam(), run, begin, count);
    const std::size_t ref_stop = reference(ref, step, all_dirty, begin, count);
    const std::string where = "trial " + std::to_string(trial) + " (" + std::to_string(count) + " vertices from " +
                              std::to_string(begin) + ")";
    ASSERT_EQ(stop, ref_stop) << where;
    stops_at_gap += stop < count && stop % 8 == 0;
    stops_in_block += stop % 8 == 4;
    ASSERT_TRUE(same_bytes(ours.state, ref.state)) << where;
    ASSERT_TRUE(same_bytes(ours.stream, ref.stream)) << where;
    ASSERT_TRUE(same_bytes(ours.flags, ref.flags)) << where;
    ASSERT_TRUE(same_bytes(ours.dirty_blocks, ref.dirty_blocks)) << where;
    ASSERT_EQ(run.active_size, ref.active_size) << where;
    ASSERT_EQ(run.changed_size, ref.changed_size) << where;
    ASSERT_TRUE(same_bytes(ours.active, ref.active)) << where;
    ASSERT_TRUE(same_bytes(ours.changed, ref.changed)) << where;
  }
  EXPECT_GT(stops_at_gap, 50) << "runs should stop at blocks with no vertex in a field, or moving outside one";
  EXPECT_GT(stops_in_block, 20) << "runs should stop at the second four of a block";
  EXPECT_GT(partial_changes, 1000) << "fours with some vertices already changed should be common";
  EXPECT_GT(partial_fields, 1000) << "fours with vertices at rest beside vertices in a field should be common";
  EXPECT_GT(whole_blocks, 1000) << "blocks wholly in a field (the eight-wide group) should be common";
  EXPECT_GT(whole_blocks_partly_changed, 500) << "whole blocks with some vertices already changed should be common";
  EXPECT_GT(blocks_beside_rest, 1000) << "blocks with vertices at rest beside vertices in a field (the eight-wide "
                                         "group too) should be common";
}

// A run that starts on four with an active vertex outside every field, or
// on a block with no vertex in a field, does nothing.
TEST_P(ForcedSweep, StopsAtOnceWhereItCannotGo) {
  std::mt19937_64 rng(7);
  const LinearStep step{};
  for (const bool gap : {false, true}) {
    Arrays a = random_arrays(rng, 64, 1000000, 1000000, 1000000, step);
    for (std::size_t j = 8; j < 16; ++j) {
      if (gap || j == 10) a.flags[j] &= static_cast<std::uint8_t>(~kForced);
    }
    const Arrays before = a;
    ForcedRun run{a.state.data(),  a.force.data(), a.limit.data(), a.flags.data(), a.stream.data(),
                  a.dirty_blocks.data(), false, a.active.data(), 0, a.changed.data(), 0, step};
    EXPECT_EQ(advance_forced_run(GetParam(), run, 8, 64), 8u) << (gap ? "no vertex in a field" : "an active vertex");
    EXPECT_EQ(run.active_size, 0u);
    EXPECT_EQ(run.changed_size, 0u);
    EXPECT_TRUE(same_bytes(a.state, before.state));
    EXPECT_TRUE(same_bytes(a.flags, before.flags));
    EXPECT_TRUE(same_bytes(a.stream, before.stream));
  }
}

}  // namespace
