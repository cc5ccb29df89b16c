#pragma once
// The session recorder: one SQLite file per session (docs/RECORDING.md).
//
// Producers (the haptic thread, or a headless job stepping a Session) hand
// records to lock-free SPSC queues (push_*: no allocation, no lock, no I/O;
// a full queue drops the record and counts it). A writer thread drains the
// queues, packs ticks into column chunks (one row per chunk of up to
// chunk_ticks ticks per probe), writes commands, deformation steps, events
// and snapshots, and commits at most commit_interval_s apart. The status row
// says "recording" with the writer's pid until finish() makes it
// "finished"; a file left "recording" by a dead writer opens as
// interrupted, with everything committed before the end.
//
// The file is self-contained: the prepared mesh (positions and triangles),
// the initial materials, the probe setups and configuration, the scenario's
// JSON text and the build are in it.

#include "haptics/loop.h"
#include "haptics/session.h"
#include "mesh/surface_mesh.h"
#include "record/format.h"

#include <atomic>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace palpa::record {

/// What a session file says about its session besides the records.
struct SessionInfo {
  std::string trainee;
  std::string organ;              ///< a name for people ("default organ", a file name)
  std::string scenario_file;      ///< as given (empty: none)
  std::string scenario_json;      ///< the scenario's JSON text (empty: none)
  double force_limit = 0;         ///< N, the task's (0: none)
  std::string note;
};

struct RecorderOptions {
  /// Items per queue, allocated up front (a tick with its results is 3 kB, so
  /// the default 4096, 4 s at 1 kHz, takes 12 MB; deformation steps, 0.7 kB,
  /// the same count; commands a sixteenth; events 1024).
  std::size_t queue_capacity = 1u << 12;
  std::size_t chunk_ticks = 256;          ///< ticks per column chunk (1 .. 65536)
  double commit_interval_s = 0.25;        ///< s of wall time between commits, at most
  double snapshot_interval_s = 5.0;       ///< s of session time between snapshots (record_step)
  bool block_when_full = false;           ///< producer waits for room instead of dropping (headless jobs only)
  bool store_results = true;              ///< keep each tick's results (world position, force, contact)
};

/// The state of a Recorder's file (any thread).
struct RecorderStats {
  std::uint64_t ticks_committed = 0;
  std::uint64_t commits = 0;
  std::uint64_t dropped = 0;   ///< records the queues could not take
  std::uint64_t bytes = 0;     ///< of the file and its WAL, at the last commit
};

/// Whether a Recorder of this process is writing `file` now (the same file
/// by device and inode, whatever the path). A session file's status row
/// names its writer's process id; for this process's own id only this tells
/// a live recording from one a crashed earlier process with the same id left
/// behind (process ids repeat, in containers most of all).
bool recording_in_this_process(const std::filesystem::path& file);

class Recorder {
 public:
  /// Creates `file` (never over an existing file: RecordError "<file>:
  /// exists; a recorder never overwrites a session"), writes the schema,
  /// meta, mesh and initial materials, and starts the writer thread.
  /// `model` and `setups` are the session's. Throws RecordError.
  Recorder(const std::filesystem::path& file, const haptics::SessionModel& model,
           const deform::MaterialArrays& initial_materials, const std::vector<haptics::ProbeSetup>& setups,
           const SessionInfo& info, RecorderOptions options = {});
  /// Finishes (see finish()) unless done; never throws.
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Producer side: one thread; no allocation, no lock, no I/O (unless
  // block_when_full, which yields until the writer makes room). False: dropped.
  bool push_tick(const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> results = {}) noexcept;
  bool push_command(const haptics::CommandRecord& c) noexcept;
  bool push_deform(const haptics::DeformRecord& d) noexcept;
  bool push_event(const EventRecord& e) noexcept;

  /// Queues a snapshot of the engine state taken after tick `s.tick - 1`
  /// (any non-real-time thread; serialised on the caller's thread).
  void snapshot(const haptics::SessionState& s);
  /// True (once per interval) when a snapshot is due at session time t (s).
  bool snapshot_due(double t) noexcept;

  /// The writer also drains `loop`'s record queues (the loop must be built
  /// with LoopConfig::record_capacity > 0 and outlive the recorder or a
  /// detach()). Ticks from the loop carry no results; the records the
  /// loop's queues dropped (LoopStatistics::record_drops) count as dropped.
  void attach(haptics::HapticLoop& loop);
  void detach();

  /// Drains every queue, commits, marks the session finished, checkpoints
  /// the WAL into the file and stops the writer. Throws RecordError when
  /// the writer failed (disk full...); the file then holds what was committed.
  void finish();

  RecorderStats stats() const;
  const std::filesystem::path& file() const;
  const RecorderOptions& options() const;

 private:
  friend bool record_step(Recorder&, haptics::Session&, double, std::span<const haptics::ProbeTickInput>,
                          std::span<haptics::ProbeTickResult>);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Steps `session` once at time t (s) (the haptic tick of every probe, then
/// the deformation step when due) and records the tick with its results,
/// the deformation step, a fault event when a probe's safety fault latches,
/// a reaction event when the tick triggers a guarding reaction, and a
/// snapshot every snapshot_interval_s of session time. Returns what Session::step returns. The same records a live loop
/// makes, so LoopReplay re-runs them.
bool record_step(Recorder& r, haptics::Session& session, double t, std::span<const haptics::ProbeTickInput> inputs,
                 std::span<haptics::ProbeTickResult> results);
/// Applies a command to `session` at the next tick and records it.
void record_apply(Recorder& r, haptics::Session& session, const haptics::LoopCommand& command, double t);

}  // namespace palpa::record
