#pragma once
// Exact replay of a recorded haptic session: the recorded device samples
// and commands are fed, in tick order, through a Session (the same LoopCore
// and deformation code the live loop ran), on one thread; each tick sees
// the surface generation the live tick saw (from the records). The forces
// and the surface come out bit for bit identical. A replay can be
// snapshot at any tick and restored, so it can seek.

#include "haptics/loop.h"
#include "haptics/session.h"

#include <deque>
#include <functional>
#include <span>
#include <vector>

namespace palpa::haptics {

/// Everything the loop's recorder queues carried for one session.
struct LoopRecording {
  std::vector<TickRecord> ticks;
  std::vector<CommandRecord> commands;
  std::vector<DeformRecord> deforms;

  /// Moves whatever the loop's queues hold into this recording (call from a
  /// non-real-time thread, as often as needed). Returns the items moved.
  std::size_t drain(HapticLoop& loop);
};

/// A replay's position: the session state and the deformation steps asked
/// for but not yet made at that tick.
struct ReplayState {
  SessionState session;
  std::deque<DeformRequest> pending;
};

class LoopReplay {
 public:
  /// The same mesh, materials, options, core configuration and probe setups
  /// as the recorded loop (HapticLoop::setups(), config().core).
  LoopReplay(std::shared_ptr<const mesh::SurfaceMesh> mesh, deform::MaterialArrays materials,
             deform::SurfaceOptions options, const CoreConfig& config, std::vector<ProbeSetup> setups);
  /// The same on a session model (a scenario's: its tissue field and tissue
  /// map are the recorded session's).
  LoopReplay(std::shared_ptr<const SessionModel> model, deform::MaterialArrays materials,
             std::vector<ProbeSetup> setups);

  /// Re-runs `recording` from the replay's current tick (0, or the tick of
  /// a restored state) to its end, calling `each` after every tick with the
  /// recorded tick and the replayed results; then makes the recorded
  /// deformation steps that followed the last tick. `until` (exclusive)
  /// stops early at that tick. Throws std::invalid_argument when the
  /// recording does not hold the current tick, has gaps, or lacks a
  /// deformation step that a tick used.
  void run(const LoopRecording& recording,
           const std::function<void(const TickRecord&, std::span<const ProbeTickResult>)>& each,
           std::uint64_t until = ~std::uint64_t{0});

  ReplayState snapshot() const { return {session_->snapshot(), pending_}; }
  /// The deformation steps asked for by replayed ticks and not yet made
  /// (what snapshot().pending holds).
  const std::deque<DeformRequest>& pending() const { return pending_; }
  void restore(const ReplayState& s) {
    session_->restore(s.session);
    pending_ = s.pending;
  }

  /// The surface after the replayed steps.
  const deform::DeformableSurface& surface() const { return session_->surface(); }
  std::uint64_t generation() const { return session_->generation(); }
  std::uint64_t tick() const { return session_->tick_count(); }

 private:
  static const DeformRecord* made_live(const LoopRecording& rec, std::uint64_t generation);
  void catch_up(const LoopRecording& rec, std::uint64_t generation, std::uint64_t tick, bool strict);

  std::unique_ptr<Session> session_;
  std::deque<DeformRequest> pending_;  // asked for by replayed ticks, not yet made
};

}  // namespace palpa::haptics
