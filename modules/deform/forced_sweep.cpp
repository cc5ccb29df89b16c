// The full step's sweep over vertices in a field, and vertices at rest
// among them (see forced_sweep.h). Only x86-64 with AVX2 runs it;
// elsewhere step_full goes vertex by vertex. Vertices are handled in
// groups of four, or with AVX-512 in blocks of eight (those outside a field
// at rest), whose states (h, v, q) are transposed in registers: the
// arithmetic is the scalar step's, lane by lane, with no fused
// multiply-add (the module builds with -ffp-contract=off, and the
// intrinsics used here are separate multiplications and additions).

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

__attribute__((target("avx2"))) inline Coefficients coefficients(const LinearStep& s) {
  return {_mm256_set1_pd(s.inv_k), _mm256_set1_pd(s.p00), _mm256_set1_pd(s.p01), _mm256_set1_pd(s.p10),
          _mm256_set1_pd(s.p11)};
}

// Block i (with a vertex in a field) four by four: returns i + 8, or the
// first four refused.
__attribute__((target("avx2"))) inline std::size_t advance_fours(ForcedRun& r, std::size_t i, const Coefficients& k) {
  for (std::size_t g = i; g < i + 8; g += 4) {
    std::uint32_t f;
    std::memcpy(&f, r.flags + g, sizeof f);
    const unsigned lanes = (f & spread4(kForced)) == spread4(kForced) ? 0xfu : lane_bits(f, kForced);
    if (!advance_group(r, g, f, lanes, k)) return g;
  }
  return i + 8;
}

constexpr std::uint64_t kForcedWord = spread8(kForced);

__attribute__((target("avx2"))) inline std::size_t run_on(ForcedRun& r, std::size_t i, std::size_t end) {
  const Coefficients k = coefficients(r.step);
  for (; i < end; i += 8) {
    std::uint64_t f8;
    std::memcpy(&f8, r.flags + i, sizeof f8);
    if ((f8 & kForcedWord) == 0) break;  // no vertex in a field: the caller's skip
    const std::size_t next = advance_fours(r, i, k);
    if (next != i + 8) return next;
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

// ---------------------------------------------------------------------------
// Eight at a time (AVX-512 F, VL, BW, DQ and BMI2): a block with a vertex
// in a field, the others out of the active set and at rest, is one group of
// eight; any other block with a vertex in a field goes four by four as
// above (advance_group), so the two widths stop at the same places.
#define PALPA_AVX512 "avx2,bmi,bmi2,popcnt,avx512f,avx512vl,avx512bw,avx512dq"

// GCC 12's AVX-512 headers initialise their undefined lanes from themselves,
// which -Wmaybe-uninitialized reports wherever they are inlined (GCC 13's
// headers silence it themselves).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// The step's coefficients and the permutations of a block's states.
struct Coefficients8 {
  __m512d inv_k, p00, p01, p10, p11;
  __m512i h_ab, h_c, v_ab, v_c;  // gather h and v from the three loads
  __m512i a_hv, b_hv, c_hv;      // put them back
  __m512i heights;               // the stream's fourth floats of eight entries
  __m512i spread_lo, spread_hi;  // eight floats to the fourth float of each entry
};

__attribute__((target(PALPA_AVX512))) inline Coefficients8 coefficients8(const LinearStep& s) {
  Coefficients8 k;
  k.inv_k = _mm512_set1_pd(s.inv_k);
  k.p00 = _mm512_set1_pd(s.p00);
  k.p01 = _mm512_set1_pd(s.p01);
  k.p10 = _mm512_set1_pd(s.p10);
  k.p11 = _mm512_set1_pd(s.p11);
  // A block's 24 doubles: a = 0..7, b = 8..15, c = 16..23; vertex j's h, v,
  // q at 3j, 3j + 1, 3j + 2. An index of two-table permutations: 0..7 the
  // first table, 8..15 the second.
  k.h_ab = _mm512_setr_epi64(0, 3, 6, 9, 12, 15, 0, 0);  // h0..h5 from (a, b)
  k.h_c = _mm512_setr_epi64(0, 0, 0, 0, 0, 0, 2, 5);     // h6, h7 from c
  k.v_ab = _mm512_setr_epi64(1, 4, 7, 10, 13, 0, 0, 0);  // v0..v4 from (a, b)
  k.v_c = _mm512_setr_epi64(0, 0, 0, 0, 0, /* v5: */ 0, 3, 6);  // v5, v6, v7 from c
  // Back, from (h, v): a = h0 v0 q0 h1 v1 q1 h2 v2, b = q2 h3 v3 q3 h4 v4 q4 h5,
  // c = v5 q5 h6 v6 q6 h7 v7 q7 (the q lanes are never stored).
  k.a_hv = _mm512_setr_epi64(0, 8, 0, 1, 9, 0, 2, 10);
  k.b_hv = _mm512_setr_epi64(0, 3, 11, 0, 4, 12, 0, 5);
  k.c_hv = _mm512_setr_epi64(13, 0, 6, 14, 0, 7, 15, 0);
  k.heights = _mm512_setr_epi32(3, 7, 11, 15, 19, 23, 27, 31, 0, 0, 0, 0, 0, 0, 0, 0);
  k.spread_lo = _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3);
  k.spread_hi = _mm512_setr_epi32(0, 0, 0, 4, 0, 0, 0, 5, 0, 0, 0, 6, 0, 0, 0, 7);
  return k;
}

// Each vertex's h and v among a block's 24 doubles (bits 3j and 3j + 1 for
// vertex j), from one bit per vertex.
__attribute__((target(PALPA_AVX512))) inline std::uint32_t vertex_hv(unsigned vertices) {
  return _pdep_u32(vertices, 0x249249u) * 3u;
}

// The vertices of a block whose h, v and q are not all +0 or -0 (at_rest in
// surface.cpp), one bit per vertex.
__attribute__((target(PALPA_AVX512))) inline unsigned moving_vertices(__m512d a, __m512d b, __m512d c) {
  const __m512i a1 = _mm512_slli_epi64(_mm512_castpd_si512(a), 1);
  const __m512i b1 = _mm512_slli_epi64(_mm512_castpd_si512(b), 1);
  const __m512i c1 = _mm512_slli_epi64(_mm512_castpd_si512(c), 1);
  const std::uint32_t nonzero = static_cast<std::uint32_t>(_mm512_test_epi64_mask(a1, a1)) |
                                static_cast<std::uint32_t>(_mm512_test_epi64_mask(b1, b1)) << 8 |
                                static_cast<std::uint32_t>(_mm512_test_epi64_mask(c1, c1)) << 16;
  return _pext_u32(nonzero | nonzero >> 1 | nonzero >> 2, 0x249249u);
}

// Block i (f its flags), with the vertices in a field in `lanes` (one bit
// per vertex, not 0): what advance_group gives its two fours, in one group.
// The others must be out of the active set and at rest; returns false,
// touching nothing, when one is not (the four-by-four sweep takes the block
// then, and stops where it must).
__attribute__((target(PALPA_AVX512))) inline bool advance_block8(ForcedRun& r, std::size_t i, std::uint64_t f,
                                                                 unsigned lanes, const Coefficients8& k) {
  double* s = reinterpret_cast<double*>(r.state + i);
  const __m512d a = _mm512_loadu_pd(s), b = _mm512_loadu_pd(s + 8), c = _mm512_loadu_pd(s + 16);
  const bool whole = lanes == 0xffu;
  std::uint32_t store = 0x6db6dbu;  // the doubles that may be stored: h and v of the vertices in `lanes`
  if (!whole) {
    const unsigned others = ~lanes & 0xffu;
    if ((_pext_u64(f, spread8(kActive)) & others) != 0 || (moving_vertices(a, b, c) & others) != 0) return false;
    store = vertex_hv(lanes);
  }
  const __m512d h = _mm512_mask_permutexvar_pd(_mm512_permutex2var_pd(a, k.h_ab, b), 0xc0, k.h_c, c);
  const __m512d v = _mm512_mask_permutexvar_pd(_mm512_permutex2var_pd(a, k.v_ab, b), 0xe0, k.v_c, c);

  // LinearStep::apply, lane by lane, in its order of operations (the lanes
  // outside `lanes` are worked out too, and dropped).
  const __m512d hf = _mm512_mul_pd(_mm512_loadu_pd(r.force + i), k.inv_k);
  const __m512d dh = _mm512_sub_pd(h, hf);
  const __m512d h2 = _mm512_add_pd(_mm512_add_pd(hf, _mm512_mul_pd(k.p00, dh)), _mm512_mul_pd(k.p01, v));
  const __m512d v2 = _mm512_add_pd(_mm512_mul_pd(k.p10, dh), _mm512_mul_pd(k.p11, v));

  // Back in h v q order (the q lanes hold nothing: q is not stored), each h
  // and v of a vertex in `lanes` stored only where its bits change: a vertex
  // held at its equilibrium (v exactly 0, h exactly f / k) leaves its cache
  // lines clean.
  const __m512d a2 = _mm512_permutex2var_pd(h2, k.a_hv, v2);
  const __m512d b2 = _mm512_permutex2var_pd(h2, k.b_hv, v2);
  const __m512d c2 = _mm512_permutex2var_pd(h2, k.c_hv, v2);
  _mm512_mask_storeu_pd(s, _mm512_mask_cmpneq_epi64_mask(static_cast<__mmask8>(store), _mm512_castpd_si512(a2),
                                                         _mm512_castpd_si512(a)), a2);
  _mm512_mask_storeu_pd(s + 8, _mm512_mask_cmpneq_epi64_mask(static_cast<__mmask8>(store >> 8),
                                                             _mm512_castpd_si512(b2), _mm512_castpd_si512(b)), b2);
  _mm512_mask_storeu_pd(s + 16, _mm512_mask_cmpneq_epi64_mask(static_cast<__mmask8>(store >> 16),
                                                              _mm512_castpd_si512(c2), _mm512_castpd_si512(c)), c2);

  // The drawn height, as advance_group.
  const __m512d limit = _mm512_loadu_pd(r.limit + i);
  const __m512d neg_limit = _mm512_xor_pd(limit, _mm512_set1_pd(-0.0));
  __m512d drawn = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(h2, limit, _CMP_GT_OQ), h2, limit);
  drawn = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(h2, neg_limit, _CMP_LT_OQ), drawn, neg_limit);

  // The stream's heights, rewritten where they differ (NEQ_UQ, as _mm_cmpneq_ps).
  const __m256 d = _mm512_cvtpd_ps(drawn);
  float* out = r.stream + 4 * i;
  const __m512 old = _mm512_permutex2var_ps(_mm512_loadu_ps(out), k.heights, _mm512_loadu_ps(out + 16));
  const unsigned differs = _mm256_mask_cmp_ps_mask(static_cast<__mmask8>(lanes), _mm512_castps512_ps256(old), d,
                                                   _CMP_NEQ_UQ);
  if (differs != 0) {
    const __m512 wide = _mm512_castps256_ps512(d);
    _mm512_mask_storeu_ps(out, static_cast<__mmask16>(_pdep_u32(differs & 0xfu, 0x8888u)),
                          _mm512_permutexvar_ps(k.spread_lo, wide));
    _mm512_mask_storeu_ps(out + 16, static_cast<__mmask16>(_pdep_u32(differs >> 4, 0x8888u)),
                          _mm512_permutexvar_ps(k.spread_hi, wide));
  }

  // Flags and lists, as advance_group gives the two fours (in index order).
  if (!r.all_dirty) {
    const std::uint64_t dirty = _pdep_u64(differs, spread8(kDirty)) & ~f;
    if (dirty != 0) {
      f |= dirty;
      mark_block(r.dirty_blocks, static_cast<Index>(i));
    }
  }
  const std::uint64_t in_lanes = whole ? ~std::uint64_t{0} : _pdep_u64(lanes, spread8(1)) * 0xffu;
  const std::uint64_t fresh = spread8(kChanged) & ~f & in_lanes;
  const __m256i indices =
      _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(i)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  if (fresh == spread8(kChanged)) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(r.changed + r.changed_size), indices);
    r.changed_size += 8;
  } else if (fresh != 0) {
    const unsigned fresh_lanes = static_cast<unsigned>(_pext_u64(fresh, spread8(kChanged)));
    _mm256_mask_compressstoreu_epi32(r.changed + r.changed_size, static_cast<__mmask8>(fresh_lanes), indices);
    r.changed_size += static_cast<std::size_t>(std::popcount(fresh_lanes));
  }
  f |= fresh | (spread8(kActive) & in_lanes);
  std::memcpy(r.flags + i, &f, sizeof f);
  if (whole) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(r.active + r.active_size), indices);
    r.active_size += 8;
  } else {
    _mm256_mask_compressstoreu_epi32(r.active + r.active_size, static_cast<__mmask8>(lanes), indices);
    r.active_size += static_cast<std::size_t>(std::popcount(lanes));
  }
  return true;
}

__attribute__((target(PALPA_AVX512))) inline std::size_t run_on8(ForcedRun& r, std::size_t i, std::size_t end) {
  const Coefficients k = coefficients(r.step);
  const Coefficients8 k8 = coefficients8(r.step);
  for (; i < end; i += 8) {
    std::uint64_t f8;
    std::memcpy(&f8, r.flags + i, sizeof f8);
    const std::uint64_t forced = f8 & kForcedWord;
    if (forced == 0) break;  // no vertex in a field: the caller's skip
    const unsigned lanes = forced == kForcedWord ? 0xffu : static_cast<unsigned>(_pext_u64(forced, kForcedWord));
    if (advance_block8(r, i, f8, lanes, k8)) continue;
    const std::size_t next = advance_fours(r, i, k);
    if (next != i + 8) return next;
  }
  return i;
}

__attribute__((target(PALPA_AVX512))) std::size_t run_avx512(ForcedRun& caller, std::size_t i, std::size_t end) {
  ForcedRun r = caller;  // as run_avx2
  const std::size_t stop = run_on8(r, i, end);
  caller.active_size = r.active_size;
  caller.changed_size = r.changed_size;
  return stop;
}

#pragma GCC diagnostic pop

bool has_avx512() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
         __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("bmi2");
}

#endif

}  // namespace

bool forced_run_available(ForcedRunWidth width) {
#if defined(PALPA_FORCED_RUN_X86)
  if (!rest_scan_available(RestScan::Avx2)) return false;  // the same question, asked once there
  if (width == ForcedRunWidth::Four) return true;
  static const bool avx512 = has_avx512();
  return avx512;
#else
  (void)width;
  return false;
#endif
}

ForcedRunWidth best_forced_run() {
  return forced_run_available(ForcedRunWidth::Eight) ? ForcedRunWidth::Eight : ForcedRunWidth::Four;
}

std::size_t advance_forced_run(ForcedRunWidth width, ForcedRun& run, std::size_t begin, std::size_t end) {
#if defined(PALPA_FORCED_RUN_X86)
  return width == ForcedRunWidth::Eight ? run_avx512(run, begin, end) : run_avx2(run, begin, end);
#else
  (void)width;
  (void)run;
  (void)end;
  return begin;
#endif
}

}  // namespace palpa::deform::internal
