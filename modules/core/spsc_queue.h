#pragma once
// A bounded lock-free single-producer single-consumer queue of plain values.
// The haptic thread pushes every tick's samples and forces for the session
// recorder; when the consumer falls behind, push() fails (the caller counts
// the drop) instead of blocking or allocating.

#include <atomic>
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <type_traits>

namespace palpa {

template <class T>
class SpscQueue {
  // Plain values: nothing to free, so no owned heap memory (copies do not allocate).
  static_assert(std::is_trivially_destructible_v<T> && std::is_copy_assignable_v<T>,
                "SpscQueue holds plain data");

 public:
  /// Room for at least `capacity` items (rounded up to a power of two, >= 2).
  /// Allocates here, never afterwards. Throws std::invalid_argument for 0 or
  /// absurd capacities.
  explicit SpscQueue(std::size_t capacity) {
    if (capacity == 0 || capacity > (std::size_t{1} << 30))
      throw std::invalid_argument("SpscQueue: capacity must be in 1 .. 2^30");
    std::size_t n = 2;
    while (n < capacity) n <<= 1;
    mask_ = n - 1;
    items_ = std::make_unique<T[]>(n);
  }
  SpscQueue(const SpscQueue&) = delete;
  SpscQueue& operator=(const SpscQueue&) = delete;

  std::size_t capacity() const { return mask_ + 1; }

  /// Producer: appends `item`; false (nothing written) when full.
  bool push(const T& item) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ > mask_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ > mask_) return false;
    }
    items_[head & mask_] = item;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  /// Consumer: removes the oldest item into `item`; false when empty.
  bool pop(T& item) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail == head_cache_) return false;
    }
    item = items_[tail & mask_];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Approximate number of queued items (exact when both sides are idle).
  std::size_t size() const noexcept {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }

 private:
  std::unique_ptr<T[]> items_;
  std::size_t mask_ = 0;
  // Producer and consumer indices on separate cache lines; each side caches
  // the other's index to touch the shared line only when needed.
  alignas(64) std::atomic<std::size_t> head_{0};
  std::size_t tail_cache_ = 0;  // producer's copy of tail_
  alignas(64) std::atomic<std::size_t> tail_{0};
  std::size_t head_cache_ = 0;  // consumer's copy of head_
};

}  // namespace palpa
