// The rest-block skip of step_full (deform/rest_scan.h): every scan this
// processor runs must stop at exactly the first block that a byte-by-byte
// test finds not at rest.

#include "deform/rest_scan.h"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

using palpa::deform::VertexState;
using namespace palpa::deform::internal;

namespace {

constexpr std::uint8_t kMoving = 0x03;

// Brute force: the first block from `begin` with a flag byte holding a bit
// of kMoving or a state byte that is not zero.
std::size_t first_moving_block(const std::vector<std::uint8_t>& flags, const std::vector<VertexState>& state,
                               std::size_t begin, std::size_t end) {
  for (std::size_t b = begin; b < end; b += kRestBlock) {
    for (std::size_t i = b; i < b + kRestBlock; ++i) {
      if (flags[i] & kMoving) return b;
      unsigned char bytes[sizeof(VertexState)];
      std::memcpy(bytes, &state[i], sizeof bytes);
      for (unsigned char c : bytes)
        if (c != 0) return b;
    }
  }
  return end;
}

std::vector<RestScan> scans_here() {
  std::vector<RestScan> scans{RestScan::Portable};
  if (rest_scan_available(RestScan::Avx2)) scans.push_back(RestScan::Avx2);
  return scans;
}

}  // namespace

TEST(RestScan, BestScanRunsHere) {
  EXPECT_TRUE(rest_scan_available(RestScan::Portable));
  EXPECT_TRUE(rest_scan_available(best_rest_scan()));
  if (!rest_scan_available(RestScan::Avx2))
    std::printf("note: this processor has no AVX2, so only the portable scan is tested\n");
}

// One set byte anywhere (each byte of each vertex's state, a -0.0, each
// flag bit): every scan stops at its block, from every start before it, and
// passes it from a start after it.
TEST(RestScan, StopsAtTheBlockOfEverySingleSetByte) {
  constexpr std::size_t n = 64;  // 8 blocks
  for (RestScan scan : scans_here()) {
    for (bool prefetch : {false, true}) {
      for (std::size_t v = 0; v < n; ++v) {
        for (std::size_t byte = 0; byte < sizeof(VertexState) + 8; ++byte) {
          std::vector<std::uint8_t> flags(n, 0);
          std::vector<VertexState> state(n);
          if (byte < sizeof(VertexState)) {
            reinterpret_cast<unsigned char*>(&state[v])[byte] = 0x80;  // 0x80 in byte 7: a -0.0
          } else {
            flags[v] = static_cast<std::uint8_t>(1u << (byte - sizeof(VertexState)));
          }
          const std::size_t block = v - v % kRestBlock;
          for (std::size_t begin = 0; begin < n; begin += kRestBlock) {
            const std::size_t want = first_moving_block(flags, state, begin, n);
            ASSERT_EQ(skip_rest_blocks(scan, flags.data(), kMoving, state.data(), begin, n, prefetch), want)
                << "scan " << int(scan) << ", vertex " << v << ", byte " << byte << ", from " << begin;
            if (begin <= block && want != n) {
              ASSERT_EQ(want, block);
            }
          }
        }
      }
    }
  }
}

// Random sparse moving vertices over arrays of the sizes step_full sees
// (odd numbers of blocks and pairs of blocks): the scans walk from one
// moving block to the next exactly as the brute force does.
TEST(RestScan, WalksFromMovingBlockToMovingBlockAsBruteForce) {
  std::mt19937 rng(7);
  for (RestScan scan : scans_here()) {
    for (std::size_t blocks : {std::size_t{1}, std::size_t{2}, std::size_t{3}, std::size_t{37}, std::size_t{1000}}) {
      const std::size_t n = blocks * kRestBlock;
      std::vector<std::uint8_t> flags(n, 0);
      std::vector<VertexState> state(n);
      std::uniform_int_distribution<std::size_t> pick(0, n - 1);
      for (int k = 0; k < static_cast<int>(blocks / 4 + 1); ++k) {
        const std::size_t v = pick(rng);
        switch (k % 4) {
          case 0: state[v].h = -1e-9; break;
          case 1: state[v].q = 1e-300; break;
          case 2: flags[v] = 0x01; break;
          default: flags[v] = 0x1c; break;  // bits outside kMoving: at rest
        }
      }
      for (bool prefetch : {false, true}) {
        std::size_t i = 0;
        while (true) {
          const std::size_t want = first_moving_block(flags, state, i, n);
          const std::size_t got = skip_rest_blocks(scan, flags.data(), kMoving, state.data(), i, n, prefetch);
          ASSERT_EQ(got, want) << "scan " << int(scan) << ", " << n << " vertices, from " << i;
          if (got == n) break;
          i = got + kRestBlock;
        }
      }
    }
  }
}
