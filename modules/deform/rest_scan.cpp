// The rest-block skip of step_full (see rest_scan.h), in a portable form and
// an AVX2 one chosen when the processor has it. Both only read and compare
// bits, so which one runs never changes a result.

#include "deform/rest_scan.h"

#include "deform/vertex_flags.h"

#include <cstring>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define PALPA_REST_SCAN_X86 1
#endif

namespace palpa::deform::internal {

namespace {

static_assert(sizeof(VertexState) == 24, "a block's state is 192 bytes: 12 x 16 or 6 x 32");
constexpr std::size_t kAhead = 256;  // vertices (6 KB of state) the prefetch runs ahead


inline void prefetch_block(const VertexState* state, std::size_t i, std::size_t end) {
  if (i + kAhead + kRestBlock > end) return;
  const char* ahead = reinterpret_cast<const char*>(state + i + kAhead);
  __builtin_prefetch(ahead);
  __builtin_prefetch(ahead + 64);
  __builtin_prefetch(ahead + 128);
}

std::size_t skip_portable(const std::uint8_t* flags, std::uint8_t moving_flags, const VertexState* state,
                          std::size_t i, std::size_t end, bool prefetch) {
  const std::uint64_t mask = spread8(moving_flags);
  for (; i < end; i += kRestBlock) {
    if (prefetch) prefetch_block(state, i, end);
    std::uint64_t f;
    std::memcpy(&f, flags + i, sizeof f);
    if (f & mask) return i;
#if defined(__SSE2__)
    const auto* p = reinterpret_cast<const __m128i*>(state + i);
    __m128i acc = _mm_or_si128(_mm_loadu_si128(p + 0), _mm_loadu_si128(p + 1));
    acc = _mm_or_si128(acc, _mm_or_si128(_mm_loadu_si128(p + 2), _mm_loadu_si128(p + 3)));
    acc = _mm_or_si128(acc, _mm_or_si128(_mm_loadu_si128(p + 4), _mm_loadu_si128(p + 5)));
    acc = _mm_or_si128(acc, _mm_or_si128(_mm_loadu_si128(p + 6), _mm_loadu_si128(p + 7)));
    acc = _mm_or_si128(acc, _mm_or_si128(_mm_loadu_si128(p + 8), _mm_loadu_si128(p + 9)));
    acc = _mm_or_si128(acc, _mm_or_si128(_mm_loadu_si128(p + 10), _mm_loadu_si128(p + 11)));
    if (_mm_movemask_epi8(_mm_cmpeq_epi8(acc, _mm_setzero_si128())) != 0xffff) return i;
#else
    std::uint64_t words[3 * kRestBlock];
    std::memcpy(words, state + i, sizeof words);
    std::uint64_t acc = 0;
    for (std::uint64_t w : words) acc |= w;
    if (acc != 0) return i;
#endif
  }
  return end;
}

#if defined(PALPA_REST_SCAN_X86)
// The OR of the 192 bytes of state of the block at `state`.
__attribute__((target("avx2"))) inline __m256i or_block(const VertexState* state) {
  const auto* p = reinterpret_cast<const __m256i*>(state);
  __m256i acc = _mm256_or_si256(_mm256_loadu_si256(p + 0), _mm256_loadu_si256(p + 1));
  acc = _mm256_or_si256(acc, _mm256_or_si256(_mm256_loadu_si256(p + 2), _mm256_loadu_si256(p + 3)));
  return _mm256_or_si256(acc, _mm256_or_si256(_mm256_loadu_si256(p + 4), _mm256_loadu_si256(p + 5)));
}

__attribute__((target("avx2"))) std::size_t skip_avx2(const std::uint8_t* flags, std::uint8_t moving_flags,
                                                       const VertexState* state, std::size_t i, std::size_t end,
                                                       bool prefetch) {
  const std::uint64_t mask = spread8(moving_flags);
  // Two blocks per test; where the pair is not at rest, the first is tested
  // alone to say which.
  for (; i + 2 * kRestBlock <= end; i += 2 * kRestBlock) {
    if (prefetch) {
      prefetch_block(state, i, end);
      prefetch_block(state, i + kRestBlock, end);
    }
    std::uint64_t f[2];
    std::memcpy(f, flags + i, sizeof f);
    const __m256i acc = _mm256_or_si256(or_block(state + i), or_block(state + i + kRestBlock));
    if (((f[0] | f[1]) & mask) == 0 && _mm256_testz_si256(acc, acc)) continue;
    const __m256i first = or_block(state + i);
    if ((f[0] & mask) || !_mm256_testz_si256(first, first)) return i;
    return i + kRestBlock;
  }
  for (; i < end; i += kRestBlock) {
    std::uint64_t f;
    std::memcpy(&f, flags + i, sizeof f);
    const __m256i acc = or_block(state + i);
    if ((f & mask) || !_mm256_testz_si256(acc, acc)) return i;
  }
  return end;
}

bool has_avx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}
#endif

}  // namespace

bool rest_scan_available(RestScan scan) {
  switch (scan) {
    case RestScan::Portable:
      return true;
    case RestScan::Avx2:
#if defined(PALPA_REST_SCAN_X86)
      {
        static const bool avx2 = has_avx2();
        return avx2;
      }
#else
      return false;
#endif
  }
  return false;
}

RestScan best_rest_scan() { return rest_scan_available(RestScan::Avx2) ? RestScan::Avx2 : RestScan::Portable; }

std::size_t skip_rest_blocks(RestScan scan, const std::uint8_t* flags, std::uint8_t moving_flags,
                             const VertexState* state, std::size_t begin, std::size_t end, bool prefetch) {
#if defined(PALPA_REST_SCAN_X86)
  if (scan == RestScan::Avx2) return skip_avx2(flags, moving_flags, state, begin, end, prefetch);
#else
  (void)scan;
#endif
  return skip_portable(flags, moving_flags, state, begin, end, prefetch);
}

}  // namespace palpa::deform::internal
