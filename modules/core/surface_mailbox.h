#pragma once
// The surface mailbox: the (nx, ny, nz, h) stream (4 float32 per vertex:
// normal correction, and height in m) handed from the deformation thread to
// the view with bounded memory, whatever the view does.
//
// One mirror of the stream plus one changed bit and one version counter per
// block of kBlock vertices; nothing grows. The writer copies the entries it
// changed into the mirror (the only copy between the threads) and marks
// their blocks; the reader takes the blocks marked since its last read and
// reads them straight from the mirror. Neither ever waits for the other: a
// slow frame cannot delay the deformation thread. A block the writer
// rewrote while the reader was reading it (its version moved, a seqlock) is
// marked again, so the next read delivers it whole: after the writer stops,
// one more read leaves the reader with exactly the writer's stream.
//
// One writer thread and one reader thread. No allocation after construction.

#include "core/types.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <memory>
#include <span>
#include <vector>

namespace palpa::core {

class SurfaceMailbox {
 public:
  /// Vertices per block (a block is the unit of change tracking).
  static constexpr Index kBlock = 64;

  /// A mailbox for `vertices` vertices, all marked changed, values zero.
  explicit SurfaceMailbox(std::size_t vertices)
      : vertices_(vertices),
        blocks_((vertices + kBlock - 1) / kBlock),
        mirror_(new float[4 * vertices]()),
        versions_(new std::atomic<std::uint32_t>[blocks_]),
        changed_(new std::atomic<std::uint64_t>[(blocks_ + 63) / 64]) {
    for (std::size_t b = 0; b < blocks_; ++b) versions_[b].store(0, std::memory_order_relaxed);
    for (std::size_t w = 0; w < words(); ++w) changed_[w].store(~std::uint64_t{0}, std::memory_order_relaxed);
    ranges_.reserve(blocks_);
    read_blocks_.reserve(blocks_);
    read_versions_.reserve(blocks_);
  }

  std::size_t vertex_count() const { return vertices_; }
  /// Bytes held (constant for the mailbox's life).
  std::size_t bytes() const {
    return 16 * vertices_ + 4 * blocks_ + 8 * words() + (sizeof(IndexRange) + 8) * blocks_;
  }

  // ---- writer ----
  /// Copies the entries in `ranges` of `stream` (4 floats per vertex, the
  /// whole surface) into the mirror and marks their blocks. Ranges past the
  /// end are cut. Never waits, never allocates.
  void publish(std::span<const float> stream, std::span<const IndexRange> ranges) noexcept {
    for (const IndexRange& r : ranges) {
      const Index end = static_cast<Index>(std::min<std::size_t>(r.end, vertices_));
      for (Index b = r.begin; b < end;) {
        const Index block = b / kBlock;
        const Index stop = std::min<Index>(end, (block + 1) * kBlock);
        versions_[block].fetch_add(1, std::memory_order_acq_rel);  // odd: being written
        std::atomic_thread_fence(std::memory_order_release);
        // Relaxed atomic stores (plain moves on x86): the reader may be
        // reading the same floats; a torn block is caught by its version.
        float* dst = mirror_.get();
        const float* src = stream.data();
        for (std::size_t k = 4 * std::size_t{b}, e = 4 * std::size_t{stop}; k < e; ++k)
          std::atomic_ref<float>(dst[k]).store(src[k], std::memory_order_relaxed);
        versions_[block].fetch_add(1, std::memory_order_release);  // even again
        changed_[block / 64].fetch_or(std::uint64_t{1} << (block % 64), std::memory_order_release);
        b = stop;
      }
    }
  }
  /// publish() of the whole stream.
  void publish_all(std::span<const float> stream) noexcept {
    const IndexRange all{0, static_cast<Index>(vertices_)};
    publish(stream, std::span<const IndexRange>(&all, 1));
  }

  // ---- reader ----
  /// The ranges of the blocks changed since the last read (sorted,
  /// disjoint, contiguous blocks merged); copy their values out with
  /// read_into() before end_read(). The first read returns everything.
  std::span<const IndexRange> begin_read() noexcept {
    ranges_.clear();
    read_blocks_.clear();
    read_versions_.clear();
    for (std::size_t w = 0; w < words(); ++w) {
      std::uint64_t bits = changed_[w].exchange(0, std::memory_order_acquire);
      while (bits) {
        const int k = __builtin_ctzll(bits);
        bits &= bits - 1;
        const Index block = static_cast<Index>(w * 64 + static_cast<std::size_t>(k));
        if (block >= blocks_) continue;
        read_blocks_.push_back(block);
        read_versions_.push_back(versions_[block].load(std::memory_order_acquire));
        const Index begin = block * kBlock;
        const Index end = static_cast<Index>(std::min<std::size_t>(vertices_, std::size_t{begin} + kBlock));
        if (!ranges_.empty() && ranges_.back().end == begin)
          ranges_.back().end = end;
        else
          ranges_.push_back({begin, end});
      }
    }
    return ranges_;
  }
  /// Copies the mirror's entries in `ranges` (4 floats per vertex) into the
  /// same places of `dst` (the whole surface, 4 floats per vertex) with
  /// relaxed atomic loads, so a read racing a write is no data race (the
  /// versions checked by end_read() send a torn block again). Ranges past
  /// either end are cut. Never allocates.
  void read_into(std::span<float> dst, std::span<const IndexRange> ranges) const noexcept {
    float* mirror = mirror_.get();
    const std::size_t limit = std::min(dst.size(), 4 * vertices_);
    for (const IndexRange& r : ranges) {
      const std::size_t e = std::min<std::size_t>(4 * std::size_t{r.end}, limit);
      for (std::size_t k = 4 * std::size_t{r.begin}; k < e; ++k)
        dst[k] = std::atomic_ref<float>(mirror[k]).load(std::memory_order_relaxed);
    }
  }
  /// Ends a read: blocks the writer touched since begin_read() are marked
  /// again, so the next read delivers them whole.
  void end_read() noexcept {
    std::atomic_thread_fence(std::memory_order_acquire);
    for (std::size_t k = 0; k < read_blocks_.size(); ++k) {
      const Index block = read_blocks_[k];
      const std::uint32_t v = versions_[block].load(std::memory_order_acquire);
      if (v != read_versions_[k] || (v & 1u))
        changed_[block / 64].fetch_or(std::uint64_t{1} << (block % 64), std::memory_order_release);
    }
    read_blocks_.clear();
    read_versions_.clear();
  }
  /// Marks every block changed (a new view needs everything).
  void mark_all() noexcept {
    for (std::size_t w = 0; w < words(); ++w) changed_[w].store(~std::uint64_t{0}, std::memory_order_release);
  }

 private:
  std::size_t words() const { return (blocks_ + 63) / 64; }

  std::size_t vertices_, blocks_;
  std::unique_ptr<float[]> mirror_;
  std::unique_ptr<std::atomic<std::uint32_t>[]> versions_;
  std::unique_ptr<std::atomic<std::uint64_t>[]> changed_;
  // Reader side.
  std::vector<IndexRange> ranges_;
  std::vector<Index> read_blocks_;
  std::vector<std::uint32_t> read_versions_;
};

}  // namespace palpa::core
