#pragma once
// Reading a session file (docs/RECORDING.md): open and check it, then load
// its parts. Opening checks, in order, and throws RecordError naming the
// file and the first fault found:
//   "no such file", "not a regular file", "empty file (not a Palpa session)",
//   "truncated (N bytes; an SQLite header alone is 100)",
//   "not a Palpa session (not an SQLite database)",
//   "truncated (N bytes, its header says M)",
//   "not a Palpa session (application_id 0x..., expected 0x50616c70)",
//   "session format version V is newer than this build reads (1)",
//   "damaged: table 'T' is missing", "damaged (<SQLite's message>)".
// Every later read that meets a damaged page or BLOB throws
// RecordError("damaged (...)") too; nothing reads out of bounds.
//
// A file whose status row says "recording" while its writer process is
// gone is interrupted: open() reports it so and, when the file is writable
// and `mark` is true, writes "interrupted" into the status row. A file this
// process is recording (recording_in_this_process) reads as Recording and
// is never marked.

#include "haptics/loop.h"
#include "haptics/loop_replay.h"
#include "haptics/session.h"
#include "mesh/surface_mesh.h"
#include "record/format.h"
#include "record/recorder.h"
#include "record/state_io.h"

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace palpa::record {

/// Everything but the records.
struct SessionHeader {
  SessionInfo info;
  std::string build;         ///< the recording build (PALPA_BUILD_ID)
  std::string layout;        ///< its layout_tag()
  std::string created_utc;
  std::string ended_utc;     ///< empty while recording or when interrupted
  std::string mesh_sha256;   ///< of the positions and triangles BLOBs (decoded bytes)
  std::string scenario_sha256;
  std::string device_setup;  ///< JSON text (for people)
  haptics::CoreConfig config;
  deform::SurfaceOptions options;
  std::vector<haptics::ProbeSetup> setups;
  SessionStatus status = SessionStatus::Recording;
  std::uint64_t ticks = 0;       ///< ticks in the file
  std::uint64_t dropped = 0;     ///< records the writer could not take
  std::uint64_t commits = 0;
  int writer_pid = 0;
};

/// Ticks [first, first + ticks.size()) with, per tick, every probe's results
/// when the file has them.
struct TickSpan {
  std::vector<haptics::TickRecord> ticks;
  std::vector<std::array<haptics::ProbeTickResult, haptics::kMaxProbes>> results;  ///< empty: none stored
};

/// Where the bytes of a session file go.
struct StorageFigures {
  std::int64_t file_bytes = 0;      ///< the file and its WAL
  std::int64_t tick_bytes = 0;      ///< the tick and probe chunk rows' BLOBs
  std::int64_t mesh_bytes = 0;      ///< the mesh BLOBs and the initial materials
  std::int64_t snapshot_bytes = 0;  ///< the snapshots' BLOBs
};

class SessionFile {
 public:
  /// Opens and checks `file` (see above). Throws RecordError.
  static SessionFile open(const std::filesystem::path& file, bool mark = true);
  ~SessionFile();
  SessionFile(SessionFile&&) noexcept;
  SessionFile& operator=(SessionFile&&) noexcept;

  const std::filesystem::path& file() const;
  const SessionHeader& header() const;
  /// True when this build's layout matches the recording's (commands and
  /// snapshots readable; a replay can be bit-identical).
  bool same_layout() const;

  /// The prepared mesh, finalised (normals and adjacency rebuilt).
  std::shared_ptr<mesh::SurfaceMesh> mesh() const;
  deform::MaterialArrays initial_materials() const;
  /// Ticks [from, to) that the file holds (clipped to what is there).
  TickSpan ticks(std::uint64_t from = 0, std::uint64_t to = ~std::uint64_t{0}) const;
  /// Every command in order; SetMaterialMap maps and SetTissue tissues are kept in `keep`.
  /// Throws RecordError when the layout differs.
  std::vector<haptics::CommandRecord> commands(std::vector<std::shared_ptr<const deform::MaterialArrays>>& keep) const;
  /// Deformation steps asked for by ticks [from, to): generation, asking
  /// tick, time and dt (their contacts are not stored: a replay re-makes
  /// them from the ticks).
  std::vector<haptics::DeformRecord> deforms(std::uint64_t from = 0, std::uint64_t to = ~std::uint64_t{0}) const;
  std::vector<EventRecord> events() const;
  std::vector<SnapshotInfo> snapshots() const;
  /// The snapshot taken at `tick` (one of snapshots()). Throws RecordError.
  DecodedState snapshot(std::uint64_t tick, const haptics::SessionModel& model) const;

  /// Row counts of the tables (for the crash test): ticks chunks, probe chunks,
  /// commands, deforms, events, snapshots.
  std::array<std::int64_t, 6> row_counts() const;
  StorageFigures storage() const;

 private:
  SessionFile();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Adds seek snapshots to a recorded session file after the fact: a
/// workbench recording, whose running loop is snapshot only where the
/// recording starts, gets them from a replay of itself. Each add() is a
/// transaction of its own, so a process killed meanwhile leaves the file as
/// it was plus the snapshots added before; nothing else in the file
/// changes. Throws RecordError naming the file (not a session file, recorded
/// by a build of another layout, still being recorded, read-only).
class SnapshotAppender {
 public:
  explicit SnapshotAppender(const std::filesystem::path& file);
  ~SnapshotAppender();
  SnapshotAppender(const SnapshotAppender&) = delete;
  SnapshotAppender& operator=(const SnapshotAppender&) = delete;

  /// Stores `s`, with a replay's `pending` deformation steps (see
  /// encode_state), as the snapshot at tick s.tick (replacing one there).
  void add(const haptics::SessionState& s, const std::deque<haptics::DeformRequest>& pending = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpa::record
