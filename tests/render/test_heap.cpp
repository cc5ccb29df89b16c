// keep_freed_heap (render/heap.h): memory freed at the top of the heap stays
// in the process, and blocks of a few MiB (a video frame) come from the
// heap. glibc's mallinfo2().keepcost is the releasable space at the heap's
// top; after frees at the top glibc trims it back to its trim threshold,
// which by default is 128 KiB and never above 64 MiB (twice the largest
// mmap threshold it adopts on its own, 32 MiB). mallinfo2().hblks counts the
// blocks mapped on their own.

#include "render/heap.h"

#include <gtest/gtest.h>
#include <malloc.h>

#include <cstdlib>
#include <vector>

namespace palpa::render {
namespace {

TEST(Heap, FreedMemoryStaysInTheProcess) {
  ASSERT_TRUE(keep_freed_heap());
  // About 103 MiB in blocks of 96 KiB: below the 128 KiB at which glibc
  // maps a block on its own, so they come from the heap (and are never
  // touched, so no page is faulted in).
  constexpr std::size_t kBlock = std::size_t{96} << 10;
  constexpr std::size_t kCount = 1100;
  std::vector<void*> blocks;
  blocks.reserve(kCount);
  for (std::size_t i = 0; i < kCount; ++i) {
    blocks.push_back(std::malloc(kBlock));
    ASSERT_NE(blocks.back(), nullptr);
  }
  for (auto it = blocks.rbegin(); it != blocks.rend(); ++it) std::free(*it);
  const struct mallinfo2 info = mallinfo2();
  EXPECT_GE(info.keepcost, std::size_t{80} << 20)
      << "the heap's top was given back: " << (info.keepcost >> 10) << " KiB kept of " << ((kBlock * kCount) >> 10)
      << " KiB freed";
}

TEST(Heap, AVideoFrameComesFromTheHeap) {
  ASSERT_TRUE(keep_freed_heap());
  // 1280 x 720 RGBA, 3.5 MiB: above glibc's default mmap threshold
  // (128 KiB), which setting the trim threshold alone would have fixed.
  const std::size_t mapped = mallinfo2().hblks;
  void* frame = std::malloc(std::size_t{1280} * 720 * 4);
  ASSERT_NE(frame, nullptr);
  const std::size_t mapped_with_frame = mallinfo2().hblks;
  std::free(frame);
  EXPECT_EQ(mapped_with_frame, mapped) << "the frame was mapped on its own (and would be unmapped on free)";
}

}  // namespace
}  // namespace palpa::render
