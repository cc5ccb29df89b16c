#pragma once
// Exact replay of a recorded haptic session: the recorded device samples,
// commands and deformation steps are fed, in tick order, through the same
// LoopCore and DeformableSurface code the live loop ran, on one thread. The
// forces and the surface come out bit for bit identical.

#include "haptics/loop.h"

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

class LoopReplay {
 public:
  /// The same mesh, materials, options, core configuration and probe setups
  /// as the recorded loop (HapticLoop::setups(), config().core).
  LoopReplay(std::shared_ptr<const mesh::SurfaceMesh> mesh, deform::MaterialArrays materials,
             deform::SurfaceOptions options, const CoreConfig& config, std::vector<ProbeSetup> setups);

  /// Re-runs `recording` from tick 0, calling `each` after every tick with
  /// the recorded tick and the replayed results; then applies the recorded
  /// deformation steps made after the last tick. Throws std::invalid_argument
  /// when the recording does not start at tick 0, has gaps, or lacks a
  /// deformation step that a tick used.
  void run(const LoopRecording& recording,
           const std::function<void(const TickRecord&, std::span<const ProbeTickResult>)>& each);

  /// The surface after the replayed steps.
  const deform::DeformableSurface& surface() const { return *surface_; }
  std::uint64_t generation() const { return generation_; }

 private:
  std::shared_ptr<const mesh::SurfaceMesh> mesh_;
  std::unique_ptr<collision::VertexTree> tree_;
  std::unique_ptr<deform::DeformableSurface> surface_;
  std::unique_ptr<LoopCore> core_;
  std::uint64_t generation_ = 0;
};

}  // namespace palpa::haptics
