// The full step's four-wide sweep over vertices in a field, and vertices
// at rest among them (see forced_sweep.h). Only x86-64 with AVX2 runs it;
// elsewhere step_full goes vertex by vertex. Vertices are handled in
// groups of four, whose states (h, v, q) are transposed in registers: the
// arithmetic is the scalar step's, lane by lane, with no fused
// multiply-add (the module builds with -ffp-contract=off and AVX2 alone
// does not enable FMA).

#include "deform/forced_sweep.h"

#include "deform/rest_scan.h"
#include "deform/vertex_flags.h"

#include <bit>
#include <cstring>

#if defined(__x86_64__)
#include <immintrin.h>
#define PALPA_FORCED_RUN_X86 1
#endif

namespace palpa::deform::internal {

namespace {

static_assert(sizeof(VertexState) == 3 * sizeof(double), "a group's states are three 32-byte loads");

#if defined(PALPA_FORCED_RUN_X86)

constexpr std::uint32_t spread4(std::uint8_t bits) { return 0x01010101u * bits; }

// Byte k all ones where bit k of the index is set.
constexpr std::uint32_t kLaneBytes[16] = {
    0x00000000u, 0x000000ffu, 0x0000ff00u, 0x0000ffffu, 0x00ff0000u, 0x00ff00ffu, 0x00ffff00u, 0x00ffffffu,
    0xff000000u, 0xff0000ffu, 0xff00ff00u, 0xff00ffffu, 0xffff0000u, 0xffff00ffu, 0xffffff00u, 0xffffffffu};

// The four lanes' flag bit `flag`, as bits 0 to 3: each byte's bit moved
// to bit 0, then gathered into the top byte by one multiplication (no
// carries: the sums are at most 15).
constexpr unsigned lane_bits(std::uint32_t f, std::uint8_t flag) {
  const unsigned shift = static_cast<unsigned>(std::countr_zero(flag));
  return (((f >> shift) & 0x01010101u) * 0x01020408u) >> 24;
}
static_assert(lane_bits(0x02000002u, 0x02) == 0b1001u && lane_bits(0x00000202u, 0x02) == 0b0011u);
static_assert(lane_bits(0xfefefefeu, 0x01) == 0u && lane_bits(0x01010101u, 0x01) == 0b1111u);

// The coefficients of the step, one per lane.
struct Coefficients {
  __m256d inv_k, p00, p01, p10, p11;
};

// The states of vertices g .. g + 3: a = h0 v0 q0 h1, b = v1 q1 h2 v2,
// c = q2 h3 v3 q3 as loaded, and h, v, q lane by lane.
struct Group {
  __m256d a, b, c, y, z, h, v, q;
};

__attribute__((target("avx2"))) inline Group load_group(const double* s) {
  Group g;
  g.a = _mm256_loadu_pd(s);
  g.b = _mm256_loadu_pd(s + 4);
  g.c = _mm256_loadu_pd(s + 8);
  const __m256d x = _mm256_blend_pd(g.a, g.b, 0b1100);  // h0 v0 h2 v2
  g.y = _mm256_permute2f128_pd(g.a, g.c, 0x21);         // q0 h1 q2 h3
  g.z = _mm256_permute2f128_pd(g.b, g.c, 0x30);         // v1 q1 v3 q3
  g.h = _mm256_shuffle_pd(x, g.y, 0b1010);              // h0 h1 h2 h3
  g.v = _mm256_shuffle_pd(x, g.z, 0b0101);              // v0 v1 v2 v3
  g.q = _mm256_shuffle_pd(g.y, g.z, 0b1010);            // q0 q1 q2 q3
  return g;
}

// Lanes whose h, v and q are all +0 or -0 (at_rest in surface.cpp), as bits 0 to 3.
__attribute__((target("avx2"))) inline unsigned rest_lanes(const Group& g) {
  const __m256i bits = _mm256_or_si256(_mm256_castpd_si256(g.h),
                                       _mm256_or_si256(_mm256_castpd_si256(g.v), _mm256_castpd_si256(g.q)));
  const __m256i zero = _mm256_cmpeq_epi64(_mm256_slli_epi64(bits, 1), _mm256_setzero_si256());
  return static_cast<unsigned>(_mm256_movemask_pd(_mm256_castsi256_pd(zero)));
}

// Vertices g .. g + 3 (g a multiple of 4). The lanes in `lanes` are in a
// field and get the vertex-by-vertex sweep's update; the others must be
// out of the active set and at rest, and are not touched (the sweep passes
// over them too). Returns false, touching nothing, when another lane is not
// so (active, or moving outside a field): the caller's sweep takes the
// group then.
__attribute__((target("avx2"))) inline bool advance_group(ForcedRun& r, std::size_t g, std::uint32_t f,
                                                          unsigned lanes, const Coefficients& k) {
  double* s = reinterpret_cast<double*>(r.state + g);
  const Group in = load_group(s);
  const bool whole = lanes == 0xfu;
  if (!whole) {
    const unsigned others = ~lanes & 0xfu;
    if ((lane_bits(f, kActive) & others) != 0 || (rest_lanes(in) & others) != others) return false;
    if (lanes == 0) return true;
  }

  // LinearStep::apply, lane by lane, in its order of operations.
  const __m256d hf = _mm256_mul_pd(_mm256_loadu_pd(r.force + g), k.inv_k);
  const __m256d dh = _mm256_sub_pd(in.h, hf);
  const __m256d h2 = _mm256_add_pd(_mm256_add_pd(hf, _mm256_mul_pd(k.p00, dh)), _mm256_mul_pd(k.p01, in.v));
  const __m256d v2 = _mm256_add_pd(_mm256_mul_pd(k.p10, dh), _mm256_mul_pd(k.p11, in.v));

  // Back to h v q order, q untouched; lanes outside `lanes` keep their bits.
  const __m256d x2 = _mm256_unpacklo_pd(h2, v2);          // h0 v0 h2 v2
  const __m256d y2 = _mm256_shuffle_pd(in.y, h2, 0b1010);  // q0 h1 q2 h3
  const __m256d z2 = _mm256_shuffle_pd(v2, in.z, 0b1111);  // v1 q1 v3 q3
  __m256d a2 = _mm256_permute2f128_pd(x2, y2, 0x20);
  __m256d b2 = _mm256_permute2f128_pd(z2, x2, 0x30);
  __m256d c2 = _mm256_permute2f128_pd(y2, z2, 0x31);
  if (!whole) {
    const __m256i lane_bit = _mm256_setr_epi64x(1, 2, 4, 8);
    const __m256d m = _mm256_castsi256_pd(
        _mm256_cmpeq_epi64(_mm256_and_si256(_mm256_set1_epi64x(lanes), lane_bit), lane_bit));
    a2 = _mm256_blendv_pd(in.a, a2, _mm256_permute4x64_pd(m, _MM_SHUFFLE(1, 0, 0, 0)));
    b2 = _mm256_blendv_pd(in.b, b2, _mm256_permute4x64_pd(m, _MM_SHUFFLE(2, 2, 1, 1)));
    c2 = _mm256_blendv_pd(in.c, c2, _mm256_permute4x64_pd(m, _MM_SHUFFLE(3, 3, 3, 2)));
  }
  _mm256_storeu_pd(s, a2);
  _mm256_storeu_pd(s + 4, b2);
  _mm256_storeu_pd(s + 8, c2);

  // The drawn height: h < -limit ? -limit : (h > limit ? limit : h).
  const __m256d limit = _mm256_loadu_pd(r.limit + g);
  const __m256d neg_limit = _mm256_xor_pd(limit, _mm256_set1_pd(-0.0));
  __m256d drawn = _mm256_blendv_pd(h2, limit, _mm256_cmp_pd(h2, limit, _CMP_GT_OQ));
  drawn = _mm256_blendv_pd(drawn, neg_limit, _mm256_cmp_pd(h2, neg_limit, _CMP_LT_OQ));

  // The stream's heights (the fourth float of each entry), rewritten where
  // they differ (!=, so a NaN always differs and -0 equals +0, as the
  // vertex-by-vertex sweep compares).
  const __m128 d = _mm256_cvtpd_ps(drawn);
  float* out = r.stream + 4 * g + 3;
  const __m128 old = _mm_setr_ps(out[0], out[4], out[8], out[12]);
  const unsigned differs = static_cast<unsigned>(_mm_movemask_ps(_mm_cmpneq_ps(old, d))) & lanes;
  if (differs != 0) {
    alignas(16) float h[4];
    _mm_store_ps(h, d);
    for (unsigned lane = 0; lane < 4; ++lane) {
      if (differs & (1u << lane)) out[4 * lane] = h[lane];
    }
  }

  // Flags: a dirty mark for each height rewritten (one block bit for the
  // four, which share a 64-vertex block), a changed mark and a place in the
  // changed list for each vertex not yet remembered (in index order), and
  // the lanes in a field stay active.
  const Index i = static_cast<Index>(g);
  if (!r.all_dirty) {
    const std::uint32_t dirty = kLaneBytes[differs] & spread4(kDirty) & ~f;
    if (dirty != 0) {
      f |= dirty;
      mark_block(r.dirty_blocks, i);
    }
  }
  const std::uint32_t fresh = spread4(kChanged) & ~f & kLaneBytes[lanes];
  const __m128i indices = _mm_add_epi32(_mm_set1_epi32(static_cast<int>(i)), _mm_setr_epi32(0, 1, 2, 3));
  if (fresh == spread4(kChanged)) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(r.changed + r.changed_size), indices);
    r.changed_size += 4;
  } else if (fresh != 0) {
    for (Index lane = 0; lane < 4; ++lane) {
      if (fresh & (std::uint32_t{kChanged} << (8 * lane))) r.changed[r.changed_size++] = i + lane;
    }
  }
  f |= fresh | (spread4(kActive) & kLaneBytes[lanes]);
  std::memcpy(r.flags + g, &f, sizeof f);
  if (whole) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(r.active + r.active_size), indices);
    r.active_size += 4;
  } else {
    for (Index lane = 0; lane < 4; ++lane) {
      if (lanes & (1u << lane)) r.active[r.active_size++] = i + lane;
    }
  }
  return true;
}

__attribute__((target("avx2"))) inline std::size_t run_on(ForcedRun& r, std::size_t i, std::size_t end) {
  const Coefficients k{_mm256_set1_pd(r.step.inv_k), _mm256_set1_pd(r.step.p00), _mm256_set1_pd(r.step.p01),
                       _mm256_set1_pd(r.step.p10), _mm256_set1_pd(r.step.p11)};
  constexpr std::uint64_t kForcedWord = 0x0101010101010101ull * kForced;
  for (; i < end; i += 8) {
    std::uint64_t f8;
    std::memcpy(&f8, r.flags + i, sizeof f8);
    if ((f8 & kForcedWord) == 0) break;  // no vertex in a field: the caller's skip
    for (std::size_t g = i; g < i + 8; g += 4) {
      std::uint32_t f;
      std::memcpy(&f, r.flags + g, sizeof f);
      const unsigned lanes = (f & spread4(kForced)) == spread4(kForced) ? 0xfu : lane_bits(f, kForced);
      if (!advance_group(r, g, f, lanes, k)) return g;
    }
  }
  return i;
}

__attribute__((target("avx2"))) std::size_t run_avx2(ForcedRun& caller, std::size_t i, std::size_t end) {
  // A copy the compiler can keep in registers: the flag stores are byte
  // stores, which might alias the caller's struct.
  ForcedRun r = caller;
  const std::size_t stop = run_on(r, i, end);
  caller.active_size = r.active_size;
  caller.changed_size = r.changed_size;
  return stop;
}

#endif

}  // namespace

bool forced_run_available() {
#if defined(PALPA_FORCED_RUN_X86)
  return rest_scan_available(RestScan::Avx2);  // the same question, asked once there
#else
  return false;
#endif
}

std::size_t advance_forced_run(ForcedRun& run, std::size_t begin, std::size_t end) {
#if defined(PALPA_FORCED_RUN_X86)
  return run_avx2(run, begin, end);
#else
  (void)run;
  (void)end;
  return begin;
#endif
}

}  // namespace palpa::deform::internal
