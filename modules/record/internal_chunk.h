#pragma once
// Internal: the column chunks of ticks (one tick_chunks row per chunk, one
// probe_chunks row per probe of it), shared by the writer and the reader.

#include "haptics/loop.h"

#include <array>
#include <cstdint>
#include <vector>

namespace palpa::record::internal {

struct ProbeColumns {
  std::vector<std::uint64_t> sequence;
  std::vector<double> sample_time, position, orientation;  // 1, 3, 4 per tick
  std::vector<std::uint32_t> buttons, status;
  std::vector<std::uint8_t> read_ok;
  std::vector<double> force_device;                        // 3 per tick
  std::vector<std::uint32_t> flags;
  std::vector<double> world, force_world, contact_point;   // 3 per tick (results)
  std::vector<double> depth;                               // 1 per tick (results)
  std::vector<std::uint8_t> state;  // in_contact | enabled << 1 | clutched << 2 | fault << 3 (results)

  void clear();
  void resize(std::size_t n, bool results);
};

/// Packs `in_contact`, `enabled`, `clutched` and `fault` into one byte, and back.
std::uint8_t pack_state(const haptics::ProbeTickResult& r);
void unpack_state(std::uint8_t s, haptics::ProbeTickResult& r);

struct TickChunk {
  std::uint64_t first_tick = 0;
  std::uint32_t probes = 0;         // highest probe_count of its ticks
  bool results = false;
  std::vector<double> time, model_time;
  std::vector<std::uint64_t> model_generation;
  std::vector<std::uint8_t> probe_count;
  std::array<ProbeColumns, haptics::kMaxProbes> probe;

  std::size_t size() const { return time.size(); }
  void clear();
  /// Appends a tick (and its results when `results` is non-null).
  void append(const haptics::TickRecord& t, const haptics::ProbeTickResult* results);
};

}  // namespace palpa::record::internal
