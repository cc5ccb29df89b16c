#pragma once
// The workbench's replay of a session file, without Qt: the file opened with
// its model rebuilt (app/replay/session_job.h), a LoopReplay that re-runs
// the recorded ticks and commands, and seeking. A seek to tick T restores
// the latest state at or before T (the file's snapshots, the checkpoints
// this player kept while it played, or where it is now when T lies ahead)
// and re-simulates forward to T, as palpa-replay does. The state shown at
// tick T is the one the recorded tick T saw: its results, and the surface
// of the deformation step it used.

#include "app/replay/session_job.h"
#include "haptics/loop_replay.h"

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace palpa::app {

class SessionPlayer {
 public:
  /// Opens `file` (load_session) and shows its first tick. Throws what
  /// load_session throws (record::RecordError naming the file and the
  /// fault), or std::runtime_error "<file>: holds no ticks".
  explicit SessionPlayer(const std::string& file);
  ~SessionPlayer();
  SessionPlayer(const SessionPlayer&) = delete;
  SessionPlayer& operator=(const SessionPlayer&) = delete;

  const LoadedSession& session() const { return *session_; }
  const std::string& file() const { return file_; }
  /// The ticks of the file: [first_tick(), end_tick()).
  std::uint64_t first_tick() const { return first_; }
  std::uint64_t end_tick() const { return end_; }
  /// The recording's tick rate, Hz.
  double rate() const { return rate_; }
  /// s from the first tick to the last (ticks - 1 over the rate).
  double duration() const;

  /// Shows tick first_tick() + round(seconds x rate) (clamped to the file).
  void seek(double seconds);
  /// Shows tick `tick` (clamped to the file's ticks).
  void seek_tick(std::uint64_t tick);
  /// Moves forward by `seconds` of session time (at most to the last tick);
  /// returns false when already at the end.
  bool advance(double seconds);
  bool at_end() const { return tick_ + 1 >= end_; }

  /// The tick shown, and its recorded time in s from the first tick's.
  std::uint64_t tick() const { return tick_; }
  double time() const { return time_; }
  /// Session time of the tick shown (its clock, s): the time a breathing
  /// organ is drawn at.
  double clock_time() const { return t0_ + time_; }
  /// The replayed surface at the tick shown.
  const deform::DeformableSurface& surface() const;
  /// The replayed results of the tick shown, one per probe slot.
  std::span<const haptics::ProbeTickResult> results() const {
    return {results_.data(), probe_count_};
  }
  /// Where the last seek started from: the tick of the state restored
  /// (a snapshot, a checkpoint, or the position it was at).
  std::uint64_t last_start() const { return last_start_; }
  /// Ticks re-simulated since opened (for tests and the status line).
  std::uint64_t simulated() const { return simulated_; }

 private:
  void restart_from(std::uint64_t tick);
  void run_to(std::uint64_t target);

  std::string file_;
  std::unique_ptr<LoadedSession> session_;
  std::unique_ptr<haptics::LoopReplay> replay_;
  std::uint64_t first_ = 0, end_ = 0;
  double rate_ = 1000, t0_ = 0;
  std::uint64_t tick_ = 0;  // shown (the replay has made tick_ + 1 ticks once it showed one)
  bool shown_ = false;      // false right after a restore: no tick replayed yet
  double time_ = 0;
  std::array<haptics::ProbeTickResult, haptics::kMaxProbes> results_{};
  std::size_t probe_count_ = 0;
  std::vector<std::uint64_t> snapshots_;  // ticks of the file's snapshots (readable by this build)
  std::vector<std::pair<std::uint64_t, haptics::ReplayState>> checkpoints_;  // kept while playing
  std::uint64_t last_checkpoint_ = 0;  // tick of the latest checkpoint kept
  std::vector<std::shared_ptr<const deform::MaterialArrays>> pending_maps_;  // restored snapshots' pending material maps (checkpoints may name them)
  std::uint64_t last_start_ = 0, simulated_ = 0;
};

}  // namespace palpa::app
