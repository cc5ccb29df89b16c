#pragma once
// The session file (docs/RECORDING.md): what identifies it, the errors its
// readers and writers throw, and the records that are not the loop's own
// (events). One SQLite database per session, in WAL mode, with
// PRAGMA application_id = kApplicationId and PRAGMA user_version =
// kSchemaVersion.

#include "haptics/loop.h"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

namespace palpa::record {

/// PRAGMA application_id of every Palpa session file: "Palp" in ASCII.
inline constexpr std::int32_t kApplicationId = 0x50616C70;
/// PRAGMA user_version: the schema this build writes and reads.
inline constexpr int kSchemaVersion = 1;

/// Limits a reader enforces before it allocates (docs/RECORDING.md,
/// "Reading"): the largest session file, bytes (64 GiB, about 90 hours of
/// live ticks at 1 kHz with 3 probes), and the largest recorded mesh, the
/// same as the mesh loader's (mesh::LoadOptions).
inline constexpr std::uint64_t kMaxSessionBytes = std::uint64_t(64) << 30;
inline constexpr std::uint64_t kMaxSessionVertices = 20'000'000;
inline constexpr std::uint64_t kMaxSessionTriangles = 40'000'000;

/// A session file that cannot be opened, read or written: what() is
/// "<file>: <fault>", e.g. "s.palpa: not a Palpa session (application_id
/// 0x00000000, expected 0x50616c70)".
class RecordError : public std::runtime_error {
 public:
  RecordError(const std::filesystem::path& file, const std::string& fault)
      : std::runtime_error(file.string() + ": " + fault), file_(file), fault_(fault) {}
  const std::filesystem::path& file() const { return file_; }
  const std::string& fault() const { return fault_; }

 private:
  std::filesystem::path file_;
  std::string fault_;
};

/// A BLOB that does not decode (the session file adds its name and row).
struct DecodeError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// What the status row says.
enum class SessionStatus : std::uint8_t {
  Recording = 0,    ///< a live writer holds it
  Finished = 1,     ///< the recorder finished it
  Interrupted = 2,  ///< the writer died (kill, crash, power): what was committed is there
};
std::string_view status_name(SessionStatus s);

/// Where a snapshot is.
struct SnapshotInfo {
  std::uint64_t tick = 0;  ///< ticks made when it was taken (a replay restored from it goes on at this tick)
  double time = 0;         ///< s, the time of its last tick
};

/// Kinds of events.
enum class EventKind : std::uint8_t {
  Mark = 0,      ///< the trainee reports a finding: point (organ frame, m), value = diameter (m), text = consistency
  Fault = 1,     ///< a latched safety fault of `probe`
  Warning = 2,   ///< a loop warning (LoopWarning bits in value)
  Reaction = 3,  ///< a guarding reaction of the tissue field
  Note = 4,      ///< free text
  Unmark = 5,    ///< the trainee deletes a mark: point and value are the withdrawn Mark's (m), text says which
};
std::string_view event_kind_name(EventKind k);

/// One event: plain data (goes through a lock-free queue).
struct EventRecord {
  std::uint64_t tick = 0;
  double time = 0;                 ///< s
  EventKind kind = EventKind::Note;
  std::int32_t probe = -1;         ///< -1: not a probe's
  haptics::Triple point{};         ///< m, organ frame (Mark)
  double value = 0;
  char text[112] = {};             ///< NUL-terminated, truncated

  static EventRecord make(EventKind kind, std::uint64_t tick, double time, std::string_view text = {}) {
    EventRecord e;
    e.kind = kind;
    e.tick = tick;
    e.time = time;
    const std::size_t n = std::min(text.size(), sizeof(e.text) - 1);
    if (n > 0) std::memcpy(e.text, text.data(), n);  // an empty view may hold nullptr
    return e;
  }
};

}  // namespace palpa::record
