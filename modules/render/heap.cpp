// See heap.h.

#include "render/heap.h"

#include <malloc.h>

#include <climits>

namespace palpa::render {

bool keep_freed_heap() {
  static_assert(kHeapBlockBytes <= INT_MAX && kKeptHeapBytes <= INT_MAX, "mallopt takes an int");
  const bool heap_blocks = mallopt(M_MMAP_THRESHOLD, static_cast<int>(kHeapBlockBytes)) == 1;
  const bool kept_top = mallopt(M_TRIM_THRESHOLD, static_cast<int>(kKeptHeapBytes)) == 1;
  return heap_blocks && kept_top;
}

}  // namespace palpa::render
