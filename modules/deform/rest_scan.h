#pragma once
// The skip over vertices at rest in DeformableSurface::step_full: blocks of
// eight vertices whose flags and state are all zero are passed over with a
// few wide loads. Internal to the deform module (tested on its own); not
// part of its interface.

#include "deform/local_model.h"

#include <cstddef>
#include <cstdint>

namespace palpa::deform::internal {

/// Vertices per block of the scan.
inline constexpr std::size_t kRestBlock = 8;

/// Which loads the scan uses.
enum class RestScan : unsigned char {
  Portable = 0,  ///< 16-byte SSE2 loads (8-byte words where SSE2 is missing)
  Avx2 = 1,      ///< 32-byte AVX2 loads: half the loads per block
};

/// The widest scan this processor runs (Avx2 where it has AVX2).
RestScan best_rest_scan();

/// True when `scan` runs on this processor.
bool rest_scan_available(RestScan scan);

/// The first i' among begin, begin + 8, ... before `end` whose block
/// [i', i' + 8) is not at rest, or `end` when there is none. A block is at
/// rest when none of its eight flag bytes has a bit of `moving_flags` set
/// and every byte of its eight states is zero (so a -0.0 counts as not at
/// rest). `end - begin` must be a multiple of 8. With `prefetch`, the state
/// 256 vertices ahead is asked for (arrays larger than the caches). `scan`
/// must be available (rest_scan_available). Reads only; no allocation.
std::size_t skip_rest_blocks(RestScan scan, const std::uint8_t* flags, std::uint8_t moving_flags,
                             const VertexState* state, std::size_t begin, std::size_t end, bool prefetch);

}  // namespace palpa::deform::internal
