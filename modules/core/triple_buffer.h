#pragma once
// A lock-free, wait-free triple buffer: one writer publishes whole values,
// one reader always gets the most recent complete value. Neither side ever
// waits for the other, so the haptic thread can publish its state every tick
// for the render thread (and a device I/O thread can hand samples to the
// haptic thread) without locks. SOFA's LCPForceFeedback keeps three buffers
// for the same reason.

#include <atomic>
#include <cstdint>
#include <type_traits>

namespace palpa {

template <class T>
class TripleBuffer {
  static_assert(std::is_trivially_copyable_v<T>, "TripleBuffer holds plain data");

 public:
  TripleBuffer() = default;
  explicit TripleBuffer(const T& initial) {
    for (auto& b : buffers_) b.value = initial;
  }
  TripleBuffer(const TripleBuffer&) = delete;
  TripleBuffer& operator=(const TripleBuffer&) = delete;

  // ---- writer side (one thread) ----

  /// The buffer the writer fills next; its content is an older value.
  T& write_buffer() { return buffers_[back_].value; }

  /// Makes the write buffer the latest value and takes a free buffer back.
  void publish() {
    const std::uint8_t old = shared_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
    back_ = old & kIndexMask;
  }

  /// write_buffer() = value; publish().
  void write(const T& value) {
    write_buffer() = value;
    publish();
  }

  // ---- reader side (one thread) ----

  /// Takes the latest published value if there is one newer than the last
  /// taken; returns true when it did.
  bool update() {
    if ((shared_.load(std::memory_order_relaxed) & kFresh) == 0) return false;
    const std::uint8_t old = shared_.exchange(front_, std::memory_order_acq_rel);
    front_ = old & kIndexMask;
    return true;
  }

  /// The value taken by the last update() (the initial value before any).
  const T& read() const { return buffers_[front_].value; }

  /// update(); read().
  const T& latest() {
    update();
    return read();
  }

 private:
  static constexpr std::uint8_t kIndexMask = 0x3;
  static constexpr std::uint8_t kFresh = 0x4;

  // Each buffer on its own cache lines so writer and reader do not share them.
  struct alignas(64) Slot {
    T value{};
  };
  Slot buffers_[3];
  alignas(64) std::atomic<std::uint8_t> shared_{1};
  alignas(64) std::uint8_t back_ = 0;   // owned by the writer
  alignas(64) std::uint8_t front_ = 2;  // owned by the reader
};

}  // namespace palpa
