#pragma once
// The real-time haptic loop. A dedicated thread ticks at a configurable rate
// (1 kHz default, up to 10 kHz), paced against an absolute clock
// (CLOCK_MONOTONIC, TIMER_ABSTIME), with SCHED_FIFO priority when the system
// allows it (a clear notice in the statistics when it does not). Each tick it
// reads every device, runs LoopCore (collision, eq. (4) force, safety) and
// sends the forces; it never allocates, locks, does I/O or throws.
//
// Deformation runs on its own thread, driven by the ticks: the tick that
// the schedule (CoreConfig::deform_rate_hz) makes due sends a DeformRequest
// (its contacts and any pending edits); the deformation thread applies it to
// the replica the haptic thread is not reading, publishes it (atomic index),
// waits until the haptic thread has left the other one, and brings that one
// level with the same request. The haptic thread therefore always reads a
// complete, unchanging model and never waits. The two halves are exactly
// Session's (session.h); with every request made before the next tick (a
// ManualClock test, or an unloaded machine) a live run equals Session::step.
// (With a spin, "before the next tick" means before its held warm-up, up to
// 50 us earlier: LoopConfig::warm_before_tick.)
//
// Every change to the running session (enable, clutch, mapping, probe add
// and remove, shape function, force parameters, materials, reset) is a
// LoopCommand applied at a tick boundary and recorded with its tick; the
// loop is never rebuilt for one, so the dent and the other probes stay.
//
// Exchange with other threads:
//   - view(): the latest per-probe state, through a lock-free triple buffer;
//   - statistics(): rate, tick duration / period jitter percentiles, misses;
//   - surface(): the core::SurfaceMailbox with the (nx, ny, nz, h) stream
//     changes (bounded memory; the deformation thread never waits for it);
//   - tick_records(), command_records(), deform_records(): lock-free SPSC
//     queues carrying every device sample, every force, every command and
//     every model step for the session recorder; LoopReplay re-runs them bit
//     for bit.
//
// Time comes from a LoopClock: the monotonic clock by default, or a test's
// ManualClock so threaded tests advance the loop tick by tick.

#include "core/spsc_queue.h"
#include "core/surface_mailbox.h"
#include "core/triple_buffer.h"
#include "devices/device.h"
#include "haptics/cpu_plan.h"
#include "haptics/loop_core.h"
#include "haptics/loop_stats.h"
#include "haptics/session.h"

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace palpa::haptics {

/// The loop's source of time, ns on one monotonic scale. The haptic thread
/// calls only these two; a real clock neither allocates nor locks.
class LoopClock {
 public:
  virtual ~LoopClock() = default;
  virtual std::int64_t now_ns() = 0;
  /// Returns once now_ns() >= ns; the last spin_ns may be busy-waited.
  virtual void sleep_until(std::int64_t ns, std::int64_t spin_ns) = 0;
  /// Makes a sleep_until in progress return early (HapticLoop::stop calls
  /// it; a real clock's sleeps are short enough to need nothing).
  virtual void interrupt() {}
};

/// CLOCK_MONOTONIC with clock_nanosleep(TIMER_ABSTIME) (the default clock).
LoopClock& monotonic_clock();

/// Live-loop settings on top of CoreConfig.
struct LoopConfig {
  CoreConfig core;
  bool realtime = true;            ///< ask for SCHED_FIFO for the haptic thread
  int realtime_priority = 80;      ///< 1 .. 99
  int haptic_cpu = -1;             ///< pin the haptic thread to this CPU (-1: no pinning)
  int deform_cpu = -1;             ///< pin the deformation thread (-1: no pinning)
  double spin_us = 0;              ///< busy-wait this long before each tick for precise starts, us
  /// With a spin (spin_us > 0): at the spin's start, run the last tick again
  /// on the current replica, into scratch (LoopCore::warm_caches; changes no
  /// result), and again whenever the deformation thread publishes another
  /// (looked at every 10 us), so that the tick finds its data in this CPU's
  /// caches after the sleep and after a replica was written on another CPU.
  /// At a quarter of the spin (at most 50 us) before the tick, once more on
  /// the current replica, which the tick then reads (held: a replica
  /// published after it is read from the next tick on). None starts later
  /// (the held one as long as 10 us, or half that lead, is left before the tick;
  /// haptics::warm_during_spin), so a warm-up of a few microseconds ends
  /// before its tick; none runs before the first tick with a probe since
  /// start() or restore() (there is no last tick to run again).
  bool warm_before_tick = true;
  /// Items per recorder queue; 0 (default): no recording. A recorder sets it
  /// (e.g. 1 << 16) and drains the queues often enough (LoopRecording::drain).
  std::size_t record_capacity = 0;
  /// Time source (not owned; must outlive the loop); null: monotonic_clock().
  LoopClock* clock = nullptr;

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
  kWarnModelDropped = 1u << 5,    ///< deformation steps were dropped (the model fell behind)
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
  /// Applied while the loop was stopped: its model edits (material, reset)
  /// reached the surface at once, not at the next deformation step.
  bool immediate = false;
};

/// One deformation step: generation g was made from the request of tick
/// `contacts_tick` (its contacts and edits) with time step dt and published
/// at `time`. A generation missing from the records was dropped.
struct DeformRecord {
  std::uint64_t generation = 0;
  std::uint64_t contacts_tick = 0;
  double time = 0;   ///< s, wall time of the publication
  double dt = 0;     ///< s
  ContactSet contacts;
};

/// A handle on a queued command: HapticLoop::applied() says when the
/// haptic thread has applied it.
using CommandTicket = std::uint64_t;

class HapticLoop {
 public:
  /// Builds the model (vertex tree) and two surface replicas. Throws
  /// std::invalid_argument for a bad configuration or binding.
  HapticLoop(std::shared_ptr<const mesh::SurfaceMesh> mesh, deform::MaterialArrays materials,
             deform::SurfaceOptions options, LoopConfig config, std::vector<ProbeBinding> probes);
  /// The same on a model built before (shares its tree; config.core is
  /// replaced by model->config).
  HapticLoop(std::shared_ptr<const SessionModel> model, deform::MaterialArrays materials, LoopConfig config,
             std::vector<ProbeBinding> probes);
  ~HapticLoop();
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  /// Starts the deformation and haptic threads (the devices must be started).
  /// A loop stopped before restarts where it stopped (same surface, same probes).
  void start();
  /// Stops both threads and commands zero force to every device.
  void stop();
  bool running() const { return running_.load(); }

  /// Queued commands, applied at the start of the next tick (at once when
  /// the loop is not running). Throw std::invalid_argument for a bad probe
  /// slot, mapping, material or shape, naming it.
  CommandTicket enable(std::size_t probe);
  CommandTicket disable(std::size_t probe);
  CommandTicket set_clutch(std::size_t probe, bool engaged);
  CommandTicket set_mapping(std::size_t probe, const DeviceMapping& mapping);
  /// Binds a started device to a free slot (output disabled until enable());
  /// returns the slot through `slot`. Throws std::invalid_argument when the
  /// loop is full or the binding is bad; nothing changes then.
  CommandTicket add_probe(const ProbeBinding& binding, std::size_t& slot);
  /// Frees a slot; its device gets zero force and is not read once
  /// applied(ticket) (only then may the caller stop or destroy it).
  CommandTicket remove_probe(std::size_t probe);
  /// Shape function of the contacts from the next tick on.
  CommandTicket set_shape(const deform::ShapeFunction& shape);
  /// Friction, slip speed and force clamp of eq. (4) from the next tick on.
  CommandTicket set_force(const ForceParams& force);
  /// Every vertex gets material m at the next deformation step (O(1) on a
  /// uniform surface).
  CommandTicket set_material(const deform::Material& m);
  /// A per-vertex material map (kept alive by the loop) at the next deformation step.
  CommandTicket set_materials(deform::MaterialArrays materials);
  /// Surface back to rest at the next deformation step; contacts start afresh.
  CommandTicket reset_surface();
  /// A new tissue (kept alive by the loop) as a SetTissue command: the
  /// ticks read its field from the tick that applies it (lesions, pulse
  /// lifts, breathing, dynamic regions; guarding reactions start afresh);
  /// the deformation step that tick asks for (dt = 0, at once) gives both
  /// replicas its map (null: the materials in force stay) and its field's
  /// pulse drives, and the steps from then on its pulse values. The dent
  /// and the probes stay. Throws std::invalid_argument for a null tissue or
  /// one that does not fit the mesh (validate_tissue); nothing changes then.
  CommandTicket set_tissue(std::shared_ptr<const TissueModel> tissue);
  /// True once the haptic thread has applied the command (or at once when stopped).
  bool applied(CommandTicket t) const { return applied_.load(std::memory_order_acquire) >= t; }
  /// True once command t is applied and a deformation step made after it
  /// is published (the haptic thread ticks against a model with its edits
  /// from the next tick, or the one after where the step was published
  /// during that tick's held warm-up: LoopConfig::warm_before_tick).
  bool in_effect(CommandTicket t) const {
    return applied(t) && made_tick_.load(std::memory_order_acquire) >= applied_tick_.load(std::memory_order_acquire);
  }
  /// Waits (sleeping, real time) until applied(t) or `timeout_s` passed.
  bool wait_applied(CommandTicket t, double timeout_s) const;

  /// The latest published state.
  LoopView view() const;
  LoopStatistics statistics() const;
  /// Ticks made so far.
  std::uint64_t ticks() const { return ticks_.load(std::memory_order_acquire); }
  /// Warm-ups run before ticks so far (LoopConfig::warm_before_tick).
  std::uint64_t warm_ups() const { return warm_ups_.load(std::memory_order_acquire); }
  /// Ticks whose data were touched once more just before them
  /// (haptics::touch_before_tick: the held replica's warm-up again, the
  /// devices' reads, the view) so far.
  std::uint64_t touches() const { return touches_.load(std::memory_order_acquire); }
  /// True when no deformation request waits (every requested step is made).
  bool deform_idle() const;

  /// The stream changes for the view (one reader thread).
  core::SurfaceMailbox& surface_changes() { return *mailbox_; }
  /// Copies the stream entries changed since the last call into `stream`
  /// (resized to 4 floats per vertex; the first call copies everything) and
  /// returns their ranges (whole blocks of SurfaceMailbox::kBlock vertices).
  std::vector<IndexRange> take_surface_changes(std::vector<float>& stream);

  SpscQueue<TickRecord>* tick_records() { return tick_records_.get(); }
  SpscQueue<CommandRecord>* command_records() { return command_records_.get(); }
  SpscQueue<DeformRecord>* deform_records() { return deform_records_.get(); }

  /// Everything LoopReplay needs to re-run a recorded session.
  const std::vector<ProbeSetup>& setups() const { return core_->setups(); }
  const LoopConfig& config() const { return config_; }
  /// Highest occupied slot + 1.
  std::size_t probe_count() const;
  const collision::VertexTree& tree() const { return *tree_; }
  /// The session model the loop was built on (its field and tissue map),
  /// or null when it was built from a mesh.
  const SessionModel* model() const { return model_.get(); }
  /// The model as the haptic thread sees it now; use it only while the loop
  /// is stopped (both replicas are level then).
  const deform::DeformableSurface& surface() const { return *replicas_[current_.load()]; }
  /// The core's state (probe memories, filters...); only while stopped.
  const CoreState& core_state() const { return core_->state(); }
  /// The whole session state (only while stopped: both replicas are level
  /// then), and its restore into both replicas and the core (only while
  /// stopped; the probes' slots must match). Throws std::logic_error while
  /// running, std::invalid_argument for a snapshot that does not fit.
  SessionState snapshot() const;
  void restore(const SessionState& s);

 private:
  struct Queued {
    LoopCommand command;
    devices::Device* device = nullptr;  // AddProbe
    CommandTicket ticket = 0;
  };
  void init(deform::MaterialArrays materials, std::vector<ProbeBinding> probes);
  void haptic_main();
  void deform_main();
  CommandTicket push(const LoopCommand& c, devices::Device* device = nullptr);
  void apply_now(const Queued& q, double t);
  void bind_slot(const Queued& q) noexcept;
  void check_stiffness(const ProbeBinding& b);
  void check_slot(std::size_t probe) const;
  void process(const DeformRequest& r, bool stopping);

  LoopConfig config_;
  LoopClock* clock_ = nullptr;
  std::shared_ptr<const mesh::SurfaceMesh> mesh_;
  std::shared_ptr<const collision::VertexTree> tree_;
  deform::SurfaceOptions options_;
  std::shared_ptr<const SessionModel> model_;  // when built from a model: its field and tissue map
  const tissue::TissueField* model_field() const { return model_ ? model_->field.get() : nullptr; }
  std::unique_ptr<deform::DeformableSurface> replicas_[2];
  std::unique_ptr<LoopCore> core_;

  // Control side: the bindings by slot (names for messages) and kept maps.
  std::array<ProbeBinding, kMaxProbes> bindings_{};
  std::array<bool, kMaxProbes> used_{};
  std::vector<std::shared_ptr<const deform::MaterialArrays>> kept_maps_;
  MaterialSource material_source_;  // the material map of the latest edit (for snapshots)
  std::vector<std::shared_ptr<const TissueModel>> kept_tissues_;  // set_tissue's and restored ones
  std::shared_ptr<const deform::MaterialMap> restored_pending_map_;  // a restored state's pending tissue map
  // Deformation side (the deformation thread, or the caller while stopped):
  // the latest SetTissue the replicas got and the field their steps use.
  const TissueModel* surface_tissue_ = nullptr;
  const tissue::TissueField* surface_field_ = nullptr;
  // Haptic side: the device of each slot (null: free).
  std::array<devices::Device*, kMaxProbes> devices_{};

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
  std::uint64_t tick_ = 0;  // next tick number (haptic thread; persists across restarts)

  // Commands: many producers (mutex on their side), the haptic thread pops.
  std::mutex command_mutex_;
  std::unique_ptr<SpscQueue<Queued>> commands_;
  CommandTicket next_ticket_ = 0;
  std::atomic<CommandTicket> applied_{0};
  std::atomic<std::uint64_t> applied_tick_{0};  // tick at which the latest command was applied
  std::atomic<std::uint64_t> made_tick_{0};     // tick of the request of the latest step published (+1)

  // Haptic thread -> deformation thread: requests; a small backlog holds
  // those the queue could not take.
  std::unique_ptr<SpscQueue<DeformRequest>> requests_;
  static constexpr std::size_t kBacklog = 16;
  std::array<DeformRequest, kBacklog> backlog_{};
  std::size_t backlog_head_ = 0, backlog_size_ = 0;
  std::atomic<std::uint64_t> requested_{0}, made_{0};

  // Haptic thread -> others.
  std::unique_ptr<TripleBuffer<LoopView>> view_;
  mutable std::mutex view_mutex_;  // serialises readers only
  std::unique_ptr<SpscQueue<TickRecord>> tick_records_;
  std::unique_ptr<SpscQueue<CommandRecord>> command_records_;
  std::unique_ptr<SpscQueue<DeformRecord>> deform_records_;

  // Deformation thread -> view.
  std::unique_ptr<core::SurfaceMailbox> mailbox_;
  std::vector<deform::Contact> contact_scratch_;

  // Statistics (written by the threads, read by anyone).
  DurationHistogram tick_hist_, jitter_hist_, latency_hist_, deform_hist_;
  std::atomic<std::uint64_t> ticks_{0}, warm_ups_{0}, touches_{0}, misses_{0}, skipped_{0}, watchdog_trips_{0},
      model_late_{0}, record_drops_{0}, deform_steps_{0}, deform_overruns_{0}, deform_drops_{0};
  std::atomic<double> start_time_{0}, stop_time_{0}, last_miss_time_{-1e9}, deform_start_time_{0};
  std::atomic<bool> realtime_{false};
  std::string realtime_notice_;  // written before haptic_ready_, read after
  RealtimeContext realtime_context_;  // read by start() when realtime is asked for
  std::string memory_notice_;         // memory_monitor_notice, read by start() with it
  std::uint32_t static_warnings_ = 0;
};

}  // namespace palpa::haptics
