// See heap.h.

#include "render/heap.h"

#include <malloc.h>

#include <climits>

namespace palpa::render {

bool keep_freed_heap(std::size_t kept) {
  // mallopt takes an int: clamp rather than wrap.
  const int trim = kept > static_cast<std::size_t>(INT_MAX) ? INT_MAX : static_cast<int>(kept);
  const bool heap_blocks = mallopt(M_MMAP_THRESHOLD, static_cast<int>(kHeapBlockBytes)) == 1;
  const bool kept_top = mallopt(M_TRIM_THRESHOLD, trim) == 1;
  return heap_blocks && kept_top;
}

}  // namespace palpa::render
