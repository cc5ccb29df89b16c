#pragma once
// The real-time haptic loop. A dedicated thread ticks at a configurable rate
// (1 kHz default, up to 10 kHz), paced against an absolute clock
// (CLOCK_MONOTONIC, TIMER_ABSTIME), with SCHED_FIFO priority when the system
// allows it (a clear notice in the statistics when it does not). Each tick it
// reads every device, runs LoopCore (collision, eq. (4) force, safety) and
// sends the forces; it never allocates, locks, does I/O or throws.
//
// Deformation integration runs on its own thread at its own rate. It steps
// two replicas of the surface in turn: it steps the one the haptic thread is
// not reading, publishes it (atomic index), waits until the haptic thread has
// left the other one, and brings that one level with the same step. The
// haptic thread therefore always reads a complete, unchanging model and never
// waits; the price is two steps per generation.
//
// Exchange with other threads:
//   - view(): the latest per-probe state, through a lock-free triple buffer;
//   - statistics(): rate, tick duration / period jitter percentiles, misses;
//   - take_surface_changes(): the (nx, ny, nz, h) stream entries changed
//     since the last call, for the renderer (deformation thread <-> render
//     thread, mutex; the haptic thread is not involved);
//   - tick_records(), command_records(), deform_records(): lock-free SPSC
//     queues carrying every device sample, every force and every model step
//     for the session recorder; LoopReplay re-runs them bit for bit.

#include "core/spsc_queue.h"
#include "core/triple_buffer.h"
#include "devices/device.h"
#include "haptics/loop_core.h"
#include "haptics/loop_stats.h"

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace palpa::haptics {

/// Live-loop settings on top of CoreConfig.
struct LoopConfig {
  CoreConfig core;
  bool realtime = true;            ///< ask for SCHED_FIFO for the haptic thread
  int realtime_priority = 80;      ///< 1 .. 99
  int haptic_cpu = -1;             ///< pin the haptic thread to this CPU (-1: no pinning)
  int deform_cpu = -1;             ///< pin the deformation thread (-1: no pinning)
  double spin_us = 0;              ///< busy-wait this long before each tick for precise starts, us
  /// Items per recorder queue; 0 (default): no recording. A recorder sets it
  /// (e.g. 1 << 16) and drains the queues often enough (LoopRecording::drain).
  std::size_t record_capacity = 0;

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// One probe of the live loop.
struct ProbeBinding {
  devices::Device* device = nullptr;  ///< not owned; must outlive the loop; started by the caller
  std::string name;                   ///< for messages; defaults to the device label
  DeviceMapping mapping;
  SafetyLimits safety;                ///< max_force 0: the device's maximum force
};

/// Loop-level warnings shown by the GUI (bits of LoopView::warnings).
enum LoopWarning : std::uint32_t {
  kWarnNoRealtime = 1u << 0,      ///< the haptic thread runs without real-time priority
  kWarnDeadlineMiss = 1u << 1,    ///< a deadline was missed within the last second
  kWarnRecordDrop = 1u << 2,      ///< the recorder did not keep up
  kWarnStiffness = 1u << 3,       ///< a material is stiffer than a device can render stably
  kWarnModelLate = 1u << 4,       ///< the deformation model is late (forces withheld)
};

/// English texts of the warning bits set in `warnings`.
std::vector<std::string> describe_warnings(std::uint32_t warnings);
/// English texts of the safety flags set in `flags` (for one probe).
std::vector<std::string> describe_safety_flags(std::uint32_t flags);

/// The latest state of every probe (published every tick).
struct LoopView {
  std::uint64_t tick = 0;
  double time = 0;                    ///< s, CLOCK_MONOTONIC of the tick
  std::uint64_t model_generation = 0; ///< deformation steps behind the surface used
  std::uint32_t warnings = 0;         ///< LoopWarning bits
  std::uint32_t probe_count = 0;
  std::array<ProbeTickResult, kMaxProbes> probes{};
};

/// One tick in the record: inputs and outputs of every probe.
struct TickRecord {
  std::uint64_t tick = 0;
  double time = 0;                    ///< s
  std::uint64_t model_generation = 0; ///< surface generation the tick used
  double model_time = 0;              ///< s: when that generation was published
  std::uint32_t probe_count = 0;
  std::array<ProbeTickInput, kMaxProbes> inputs{};
  std::array<Triple, kMaxProbes> force_device{};  ///< the commands sent, N
  std::array<std::uint32_t, kMaxProbes> flags{};
};

/// A command, with the tick at whose start it was applied.
struct CommandRecord {
  std::uint64_t tick = 0;
  double time = 0;
  LoopCommand command;
};

/// One deformation step: generation g was made from the contacts of tick
/// `contacts_tick` with time step dt and published at `time`.
struct DeformRecord {
  std::uint64_t generation = 0;
  std::uint64_t contacts_tick = 0;
  double time = 0;   ///< s
  double dt = 0;     ///< s
  ContactSet contacts;
};

class HapticLoop {
 public:
  /// Builds the vertex tree and two surface replicas. Throws
  /// std::invalid_argument for a bad configuration or binding.
  HapticLoop(std::shared_ptr<const mesh::SurfaceMesh> mesh, deform::MaterialArrays materials,
             deform::SurfaceOptions options, LoopConfig config, std::vector<ProbeBinding> probes);
  ~HapticLoop();
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  /// Starts the deformation and haptic threads (the devices must be started).
  void start();
  /// Stops both threads and commands zero force to every device.
  void stop();
  bool running() const { return running_.load(); }

  /// Queued commands, applied at the start of the next tick. Throw
  /// std::invalid_argument for a bad probe index or mapping.
  void enable(std::size_t probe);
  void disable(std::size_t probe);
  void set_clutch(std::size_t probe, bool engaged);
  void set_mapping(std::size_t probe, const DeviceMapping& mapping);

  /// The latest published state.
  LoopView view() const;
  LoopStatistics statistics() const;

  /// Copies the stream entries changed since the last call into `stream`
  /// (resized to 4 floats per vertex; the first call copies everything) and
  /// returns their ranges.
  std::vector<IndexRange> take_surface_changes(std::vector<float>& stream);

  SpscQueue<TickRecord>* tick_records() { return tick_records_.get(); }
  SpscQueue<CommandRecord>* command_records() { return command_records_.get(); }
  SpscQueue<DeformRecord>* deform_records() { return deform_records_.get(); }

  /// Everything LoopReplay needs to re-run a recorded session.
  const std::vector<ProbeSetup>& setups() const { return core_->setups(); }
  const LoopConfig& config() const { return config_; }
  std::size_t probe_count() const { return probes_.size(); }
  const collision::VertexTree& tree() const { return *tree_; }
  /// The model as the haptic thread sees it now; use it only while the loop
  /// is stopped (both replicas are level then).
  const deform::DeformableSurface& surface() const { return *replicas_[current_.load()]; }

 private:
  void haptic_main();
  void deform_main();
  void push_command(const LoopCommand& c);
  void step_replica(int index, const ContactSet& contacts, double dt);

  LoopConfig config_;
  std::shared_ptr<const mesh::SurfaceMesh> mesh_;
  std::unique_ptr<collision::VertexTree> tree_;
  std::unique_ptr<deform::DeformableSurface> replicas_[2];
  std::unique_ptr<LoopCore> core_;
  std::vector<ProbeBinding> probes_;

  // Replica exchange (see the file comment).
  struct ReplicaMeta {
    std::uint64_t generation = 0;
    double time = 0;
  };
  ReplicaMeta meta_[2];
  std::atomic<int> current_{0};
  std::atomic<int> in_use_{-1};

  // Threads.
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_{false};
  std::thread haptic_thread_, deform_thread_;
  std::atomic<bool> haptic_ready_{false};

  // Commands: many producers (mutex on their side), the haptic thread pops.
  std::mutex command_mutex_;
  std::unique_ptr<SpscQueue<LoopCommand>> commands_;

  // Haptic thread -> others.
  std::unique_ptr<TripleBuffer<LoopView>> view_;
  mutable std::mutex view_mutex_;  // serialises readers only
  std::unique_ptr<TripleBuffer<ContactSet>> contacts_;
  std::unique_ptr<SpscQueue<TickRecord>> tick_records_;
  std::unique_ptr<SpscQueue<CommandRecord>> command_records_;
  std::unique_ptr<SpscQueue<DeformRecord>> deform_records_;

  // Deformation thread -> render thread.
  std::mutex render_mutex_;
  std::vector<float> render_stream_;
  std::vector<IndexRange> render_ranges_;
  bool render_first_ = true;
  std::vector<deform::Contact> contact_scratch_;
  struct PendingCatchUp {
    bool valid = false;
    int index = 0;
    ContactSet contacts;
    double dt = 0;
  };
  PendingCatchUp pending_;  // written by the deformation thread before it exits

  // Statistics (written by the threads, read by anyone).
  DurationHistogram tick_hist_, jitter_hist_, latency_hist_, deform_hist_;
  std::atomic<std::uint64_t> ticks_{0}, misses_{0}, skipped_{0}, watchdog_trips_{0}, model_late_{0},
      record_drops_{0}, deform_steps_{0}, deform_overruns_{0};
  std::atomic<double> start_time_{0}, stop_time_{0}, last_miss_time_{-1e9}, deform_start_time_{0};
  std::atomic<bool> realtime_{false};
  std::string realtime_notice_;  // written before haptic_ready_, read after
  std::uint32_t static_warnings_ = 0;
};

}  // namespace palpa::haptics
