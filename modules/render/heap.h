#pragma once
// The C library's heap in a process that renders with Mesa's software
// renderer (llvmpipe): blocks that are freed and allocated again every
// frame stay in the process instead of going back to the system.

#include <cstddef>

namespace palpa::render {

/// Memory the C library keeps at the top of its heap before it gives any
/// back to the system (bytes): 256 MiB.
inline constexpr std::size_t kKeptHeapBytes = std::size_t{256} << 20;
/// Blocks below this size come from the heap rather than from a mapping of
/// their own (bytes): 32 MiB, the most glibc allows and the most its own
/// adaptive threshold reaches.
inline constexpr std::size_t kHeapBlockBytes = std::size_t{32} << 20;

/// Sets glibc's trim threshold (M_TRIM_THRESHOLD) to kKeptHeapBytes and its
/// mmap threshold (M_MMAP_THRESHOLD) to kHeapBlockBytes, so that memory
/// freed at the top of the heap stays in the process up to 256 MiB and
/// blocks below 32 MiB are taken from the heap.
///
/// llvmpipe allocates and frees its buffers for every frame. With glibc's
/// default trim threshold the heap shrank after each frame and the next
/// frame faulted every page in again: a 100k-triangle frame then took about
/// 50 ms instead of 20 on the 2-core development VM, depending on what the
/// process had allocated before (docs/PERFORMANCE.md, round 9). Setting the
/// trim threshold alone turns glibc's adaptive mmap threshold off, which
/// left it at 128 KiB and so mapped and unmapped every frame buffer of the
/// video encoder (palpa-replay's encoding went from 2.8 to 6.6 ms a frame):
/// hence both settings.
///
/// Call once, early in main, in a program that renders. Returns false where
/// the C library refused either setting.
bool keep_freed_heap();

}  // namespace palpa::render
