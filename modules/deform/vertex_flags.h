#pragma once
// The per-vertex flag bits of DeformableSurface, the word that tests eight
// vertices' flags at once, and the block bitmap of dirty stream entries,
// shared by surface.cpp and the full step's sweeps over vertices in a field
// (forced_sweep.h) and at rest (rest_scan.h). Internal to the deform module;
// not part of its interface.

#include "core/types.h"

#include <cstdint>

namespace palpa::deform::internal {

inline constexpr std::uint8_t kActive = 1u << 0;   // in the active set
inline constexpr std::uint8_t kForced = 1u << 1;   // in a contact's or a drive's field
inline constexpr std::uint8_t kVisited = 1u << 2;  // met by the field build under way
inline constexpr std::uint8_t kDirty = 1u << 3;    // stream entry changed since the last take_dirty_ranges
inline constexpr std::uint8_t kChanged = 1u << 4;  // remembered for level_with (DeformableSurface::kChangedFlag)
inline constexpr std::uint8_t kFresh = 1u << 5;    // in a field of the build under way (apply_fields only)

/// `bits` in each byte of a word: the flags of eight vertices read as one
/// little-endian word (byte k is vertex i + k) tested for them at once.
inline constexpr std::uint64_t spread8(std::uint8_t bits) { return 0x0101010101010101ull * bits; }

/// Notes that vertex i holds a dirty mark: bit (i / 64) % 64 of word i / 4096
/// of the block bitmap take_dirty_ranges walks (one bit per 64 vertices).
inline void mark_block(std::uint64_t* blocks, Index i) { blocks[i >> 12] |= std::uint64_t{1} << ((i >> 6) & 63); }

}  // namespace palpa::deform::internal
