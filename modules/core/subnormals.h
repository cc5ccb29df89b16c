#pragma once
// A scope in which this thread's SSE and AVX arithmetic takes subnormal
// results and operands as zero (MXCSR's flush-to-zero and
// denormals-are-zero bits); the caller's mode comes back when it ends.
//
// Quantities that decay geometrically towards zero pass through the
// subnormal range (below 2.2e-308), where an x86 processor takes a
// microcode assist, some hundred cycles, on every operation. Some stay
// there: a velocity filtered as v += a (0 - v) stops decreasing once
// a v rounds to zero, and then costs an assist at every use for as long as
// the input stays still. Values that small are zero to any physics here.
//
// Used around the deformation step and the haptic tick, each as a whole, so
// that every run of them (live, replayed, stepped full or active) takes the
// same values as zero and gives the same bits. Costs a few cycles to set and
// restore; never allocates or throws, so the haptic thread may use it.
// Elsewhere than x86-64 it does nothing.

#if defined(__x86_64__)
#include <xmmintrin.h>
#endif

namespace palpa {

class SubnormalsAsZero {
 public:
#if defined(__x86_64__)
  SubnormalsAsZero() noexcept : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | kFlushToZero | kDenormalsAreZero); }
  ~SubnormalsAsZero() { _mm_setcsr(saved_); }
#else
  SubnormalsAsZero() noexcept = default;
#endif
  SubnormalsAsZero(const SubnormalsAsZero&) = delete;
  SubnormalsAsZero& operator=(const SubnormalsAsZero&) = delete;

 private:
#if defined(__x86_64__)
  static constexpr unsigned kFlushToZero = 1u << 15;
  static constexpr unsigned kDenormalsAreZero = 1u << 6;
  unsigned saved_;
#endif
};

}  // namespace palpa
