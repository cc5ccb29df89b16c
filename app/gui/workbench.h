#pragma once
// The workbench's model, without Qt: the organ, the probes and the material
// the panel edits, all driven by the real-time haptic loop
// (haptics::HapticLoop, its own threads at 1 kHz). Every probe is a device
// plugin: the virtual probes the mouse drives are `mouse` devices the window
// feeds (Device::feed) with the picked tip; other probes are bound to any
// plugin (scripted, spacemouse, falcon, igtl). The window calls update() once
// per frame to read the loop's latest state and take_surface_changes() to
// move the render stream.
//
// One loop runs per organ. Adding or removing a probe, changing the
// material, shape function or force parameters, and reset() are commands
// to the running loop (applied at a tick boundary, recorded with the
// session): the dent and the other probes stay where they are. Only a new
// organ builds a new loop.
//
// Recording (docs/RECORDING.md, "In the workbench"): every loop is built
// with its record queues (LoopConfig::record_capacity); while nothing
// records, a small thread of the workbench empties them, so they never
// drop. start_recording() pauses the loop's threads for the moment a
// snapshot takes (the loop itself, its tick count, dent and probes go on),
// makes a record::Recorder that starts from that snapshot and attaches it
// to the loop; stop_recording() finishes the file.
//
// A scenario (scenario::Resolved) is an organ with its session model: the
// tissue map and the tissue field (lesions, pulses, breathing, dynamic
// regions) ride on the loop's model, so the ticks feel them. A breathing
// organ moves in the world: a mouse probe's anchor is in the organ frame and
// the tip fed to its device is where that point is at the loop's time.

#include "devices/loader.h"
#include "haptics/loop.h"
#include "record/recorder.h"
#include "mesh/organ.h"
#include "scenario/resolve.h"
#include "tissue/tissue.h"

#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace palpa::app {

/// The force law the material panel sets.
enum class MaterialLaw : std::uint8_t {
  Hertz = 0,   ///< a tissue in the units educators use, mapped by tissue::hertz_material
  Linear = 1,  ///< advanced: the per-vertex local model's own parameters (N/m)
};

/// What the material panel edits; applied to the whole organ. SI units.
struct MaterialSettings {
  MaterialLaw law = MaterialLaw::Hertz;
  /// Hertz: the tissue (E in Pa, nu, damping ratio, relaxation time s and
  /// fraction, stiffening 1/m) and the probe's tip radius (m).
  tissue::Tissue tissue;
  double tip_radius = tissue::kDefaultTipRadius;  ///< m
  /// Linear (advanced): the local model kind and its parameters.
  deform::LocalModelKind model = deform::LocalModelKind::Linear;
  double stiffness = 200.0;  ///< N/m
  double damping = 2.0;      ///< N s/m
  double mass = 1e-3;        ///< kg (also the Hertz model's vertex mass)
  deform::ShapeKind shape = deform::ShapeKind::Wendland;
  double radius = 0.025;     ///< shape-function support, m
  double friction = 0.2;     ///< K of eq. (4)
  double max_force = 8.0;    ///< N
};

/// The loop's latest state of one probe (from HapticLoop::view()).
struct ProbeReadout {
  Vec3 force = Vec3::Zero();  ///< force on the probe after safety, world frame, N
  bool in_contact = false;
  double depth = 0;           ///< penetration below the undeformed surface, m
  std::uint32_t flags = 0;    ///< haptics::SafetyFlag bits
  haptics::SafetyFault fault = haptics::SafetyFault::None;
  bool enabled = false;       ///< force output enabled (devices with force output)
  Vec3 contact_point = Vec3::Zero();   ///< on the undeformed surface, organ frame, m (in contact)
  Vec3 contact_normal = Vec3::Zero();  ///< unit, there (in contact)
  double normal_force = 0;    ///< N: the force along the contact normal (0 out of contact)
  std::uint32_t buttons = 0;  ///< the device's buttons as read (bit i: button i pressed)
};

/// One probe. Mouse probes (host_fed) are pressed `depth` into the organ at
/// an undeformed surface point along the inward normal there; other probes
/// follow their device.
struct Probe {
  int id = 0;
  std::string device = "mouse";  ///< plugin name
  std::string options;           ///< plugin options it was created with
  bool host_fed = true;          ///< the window feeds its positions (mouse)
  bool force_output = false;     ///< the device renders forces
  bool wants_output = true;      ///< enabled by the user; cleared when a fault latches
  std::string fault_text;        ///< the latched fault, until re-enabled (empty: none)
  haptics::DeviceMapping mapping;  ///< device to world (identity for mouse probes)
  bool placed = false;           ///< mouse: has a surface point; others: has a reading
  Vec3 anchor = Vec3::Zero();    ///< mouse: undeformed surface point, m
  Vec3 normal = Vec3::UnitZ();   ///< mouse: outward undeformed normal there, unit
  double depth = 0;              ///< mouse: m below the undeformed surface (0: lifted off)
  Vec3 tip = Vec3::Zero();       ///< probe position (mouse: what is fed; others: the loop's), m
  ProbeReadout output;           ///< the loop's latest state (update())
  std::shared_ptr<devices::Device> dev;  ///< started; outlives every loop that uses it
  std::size_t slot = 0;          ///< the loop's probe slot
};

class Workbench {
 public:
  /// The live loop's haptic tick rate, Hz.
  static constexpr double kHapticRateHz = 1000;

  /// Loads plugins through `loader` (default search path when omitted).
  Workbench();
  explicit Workbench(devices::PluginLoader loader);
  ~Workbench();
  Workbench(const Workbench&) = delete;
  Workbench& operator=(const Workbench&) = delete;

  /// Replaces the organ: a new loop on it (any scenario is closed); probes
  /// stay, mouse probes are unplaced. Strong guarantee: if building throws,
  /// nothing changes.
  void set_organ(mesh::Organ organ);
  bool has_organ() const { return organ_.mesh != nullptr; }
  const mesh::Organ& organ() const { return organ_; }

  /// Runs a resolved scenario: its organ, a new loop on
  /// scenario::session_model (the tissue map and the field attached) with
  /// the scenario's probe shape function and force clamp, the base tissue's
  /// Hertz material as the initial materials (the model's tissue map
  /// replaces them). The material settings become the base tissue's
  /// (tissue, tip radius, shape, force clamp). Probes stay, mouse probes are
  /// unplaced. Strong guarantee: if building throws, nothing changes.
  void set_scenario(scenario::Resolved resolved);
  /// Applies an edited scenario to the running loop (same organ file): re-resolved on the loaded organ, sent as one SetTissue
  /// command (plus the probe shape / force clamp / tip radius changes as their existing commands if those changed); probes, dent,
  /// tick count and recording go on. Strong guarantee: throws scenario::ScenarioError (nothing changed) for a scenario that does
  /// not resolve. Without a scenario running: std::logic_error. A different organ path/unit: std::invalid_argument (use set_scenario).
  ///
  /// The tip radius (m) is part of the tissue (the Hertz materials of the
  /// map and the lesion law of the field), so it travels in the SetTissue
  /// command; the shape function (support radius, m) and the force clamp
  /// (N) go as SetShape and SetForce. The material settings become the
  /// edited base tissue's, the tissue map is in force again, and scenario()
  /// returns the edited Resolved afterwards.
  void edit_scenario(scenario::Scenario edited);
  /// load_scenario + resolve + set_scenario. Throws (nothing changed)
  /// scenario::ScenarioError, or std::runtime_error whose message starts
  /// with the file's path, for a file that does not read, validate, resolve
  /// or run.
  void open_scenario(const std::filesystem::path& file);
  /// load_scenario + resolve, with the errors open_scenario throws (a
  /// window builds its view of the organ between this and set_scenario).
  static scenario::Resolved resolve_scenario(const std::filesystem::path& file);
  bool has_scenario() const { return scenario_ != nullptr; }
  /// The scenario running, or null.
  const scenario::Resolved* scenario() const { return scenario_.get(); }
  /// The running model's tissue field (null without a scenario).
  std::shared_ptr<const tissue::TissueField> field() const;
  /// True while the scenario's tissue map is in force (false once a
  /// material edit replaced it with one material for the whole organ).
  bool tissue_map_in_force() const { return scenario_ && map_in_force_; }
  /// Undoes a material edit on a scenario: the scenario's tissue map (and
  /// its base tissue in the settings) again, as a command to the running
  /// loop. No effect without a scenario or when the map is in force.
  void restore_tissue_map();

  /// New material for every vertex and new force/shape parameters, sent to
  /// the running loop as edits (probes and dent kept). With a scenario, a
  /// new material replaces its tissue map for the whole organ (see
  /// restore_tissue_map). Strong guarantee: a bad value throws
  /// std::invalid_argument and changes nothing.
  void set_material(const MaterialSettings& m);
  const MaterialSettings& material() const { return material_; }
  /// The per-vertex materials the running model uses (once settled()).
  deform::MaterialArrays materials() const;
  /// True once the latest edit has reached the running model.
  bool settled() const;

  /// Adds a mouse probe and selects it; returns its id. Throws (nothing
  /// changed) when the mouse plugin cannot be loaded or the loop is full.
  int add_probe();
  /// Adds a probe bound to plugin `plugin` created with `options`, started,
  /// mapped with `mapping`, force output enabled; selects it and returns its
  /// id. Throws devices::DeviceError (or std::invalid_argument from the
  /// loop) with the plugin's message; nothing changes then.
  int add_device_probe(const std::string& plugin, const std::string& options, const haptics::DeviceMapping& mapping);
  /// Removes a probe (its device stops once the loop no longer uses it).
  void remove_probe(int id);
  void select_probe(int id);
  int selected_id() const { return selected_; }
  Probe* probe(int id);
  Probe* selected_probe() { return probe(selected_); }
  const std::vector<Probe>& probes() const { return probes_; }

  /// Puts mouse probe `id` at an undeformed surface point with an
  /// indentation depth (m, clamped to 0..max_depth()) and feeds its device.
  void place(int id, const Vec3& anchor, const Vec3& normal, double depth);
  void set_depth(int id, double depth);
  /// Deepest indentation allowed, m (the shape function's support radius).
  double max_depth() const { return material_.radius; }
  /// How far above the surface a lifted mouse probe (depth 0) is held, m.
  static constexpr double kLiftClearance = 1e-3;

  /// Re-enables force output of probe `id` (clears a latched fault).
  void reenable(int id);

  /// Reads the loop's latest state into every probe's output and tip;
  /// latches fault texts. Call once per frame.
  void update();
  /// The stream entries (4 floats per vertex) changed since the last call,
  /// from the loop (everything after a rebuild); empty without a loop.
  std::vector<IndexRange> take_surface_changes(std::vector<float>& stream);
  /// Hands `sink` the loop's surface (the whole stream, 4 floats per
  /// vertex: the workbench's copy of the mailbox, whose changed blocks are
  /// read with atomic loads just before) and the ranges changed since the
  /// last call; `everything`: every vertex is handed over this time.
  /// Returns false without a loop.
  bool pull_surface(const std::function<void(std::span<const float>, std::span<const IndexRange>)>& sink,
                    bool everything = false);

  /// Surface to rest (a command; the loop keeps running), every mouse probe lifted.
  void reset();

  /// Starts recording the running loop into `file` (a new file; its folder
  /// must exist) with `trainee` in its meta: the loop's threads stop for
  /// the snapshot the recording starts from and go on (the same loop, tick
  /// count, surface and probes); a record::Recorder then drains the loop's
  /// record queues. Throws (nothing recorded, the loop running on)
  /// record::RecordError naming the file, or std::logic_error without a
  /// loop, while recording or while suspended.
  void start_recording(const std::filesystem::path& file, const std::string& trainee);
  /// Finishes the recording (drains, marks it finished) and returns its
  /// file; no effect (empty path) when not recording. Throws RecordError
  /// when its writer failed (the file then holds what was committed); the
  /// recording has ended either way.
  std::filesystem::path stop_recording();
  bool recording() const { return recorder_ != nullptr; }
  /// The file being recorded (empty when not recording).
  std::filesystem::path recording_file() const;
  /// The recorder's ticks committed and records dropped (zeros when not recording).
  record::RecorderStats recording_stats() const;
  /// Wall time the loop's threads were stopped for the latest recording's
  /// snapshot, s (0 before any).
  double record_pause() const { return record_pause_s_; }
  /// s of loop time since the recording started (0 when not recording).
  double recording_elapsed() const { return recorder_ ? loop_time_ - record_start_time_ : 0.0; }
  /// Seek snapshots of a recording: the running loop is snapshot only where
  /// a recording starts, so once it stops a background pass (one thread,
  /// lowered priority) replays its file and adds a snapshot every `seconds`
  /// of session time (app::add_seek_snapshots; default 5 s, as a headless
  /// recording takes them); 0 turns the pass off for later recordings.
  /// Throws std::invalid_argument for a negative or non-finite time.
  void set_seek_snapshot_interval(double seconds);
  /// True while that pass has a file to do or is doing one.
  bool adding_seek_snapshots() const;

  /// Where probe `id` marks a finding (exam mode), organ frame, m: its
  /// contact point on the undeformed surface when in contact, else its tip
  /// (mapped into the organ frame at the loop's time); nullopt for no such
  /// probe or one not placed.
  std::optional<Vec3> finding_point(int id) const;
  /// Adds an event (a trainee's Mark, a Note) to the recording, with the
  /// loop's latest tick and time; false when not recording or the queue is
  /// full. GUI thread only: in the workbench nothing else pushes to the
  /// recorder's own event queue (the loop's records reach the writer
  /// through the loop's queues), so the queue keeps its one producer.
  bool record_event(record::EventRecord e);

  /// Stops the loop's threads (devices get zero force; mouse probes are
  /// not read) and resume() starts them again where they stopped: the
  /// window's replay. suspend() throws std::logic_error while recording.
  void suspend();
  void resume();
  bool suspended() const { return suspended_; }

  /// The running loop, or null (no organ or no probe).
  const haptics::HapticLoop* loop() const { return loop_.get(); }
  haptics::LoopView view() const;
  haptics::LoopStatistics statistics() const;
  /// Probes in contact at the latest update().
  std::size_t contact_count() const;
  /// s since the organ was set (CLOCK_MONOTONIC of the loop's latest tick).
  double time() const { return time_; }
  /// The loop's time (s, its clock) at the latest update(): the time of the
  /// field (breathing, pulses) the ticks use, and the time mouse probes'
  /// tips were last fed for.
  double loop_time() const { return loop_time_; }
  /// Where organ point `x` (organ frame, m) is in the world at the loop's
  /// time loop_time() (breathing; x itself without it).
  Vec3 to_world(const Vec3& x) const;

 private:
  haptics::LoopConfig loop_config(const MaterialSettings& m) const;
  haptics::LoopConfig loop_config() const { return loop_config(material_); }
  std::unique_ptr<haptics::HapticLoop> build_loop(const mesh::Organ& organ, const deform::MaterialArrays& materials,
                                                  const haptics::LoopConfig& config,
                                                  const std::vector<Probe>& probes,
                                                  std::shared_ptr<const haptics::SessionModel> model = nullptr) const;
  // Probes for a new organ: every mouse probe unplaced.
  std::vector<Probe> unplaced_probes() const;
  // The tip a mouse probe's device is fed, world frame at the loop's time.
  Vec3 fed_tip(const Probe& p) const;
  // Stops the current loop and starts `next` (may be null) with `probes`.
  void install(std::unique_ptr<haptics::HapticLoop> next, std::vector<Probe>& probes);
  // The thread that empties the loop's record queues while nothing records
  // (their only consumer then; the recorder's writer is while recording).
  void start_discarding();
  void stop_discarding();
  // Ends a recording without throwing (a new organ, the destructor).
  void end_recording_quietly() noexcept;
  void feed(const Probe& p) const;
  int add(Probe p);
  static haptics::ForceParams force_params(const MaterialSettings& m);
  static haptics::ProbeBinding binding(const Probe& p);

  devices::PluginLoader loader_;
  mesh::Organ organ_;
  std::unique_ptr<const scenario::Resolved> scenario_;  // null: a bare organ
  bool map_in_force_ = false;                          // the scenario's tissue map, not a uniform edit
  bool scenario_edited_ = false;                       // edit_scenario changed it since it was opened
  MaterialSettings material_;
  std::vector<Probe> probes_;
  std::vector<std::shared_ptr<devices::Device>> retired_;  // removed, maybe still read by the loop
  haptics::CommandTicket last_ticket_ = 0;
  std::unique_ptr<haptics::HapticLoop> loop_;
  int selected_ = 0;
  int next_id_ = 1;
  double epoch_ = 0;  // s, CLOCK_MONOTONIC when the organ was set
  std::vector<float> pulled_;  // pull_surface's copy of the mailbox (4 floats per vertex)
  double time_ = 0;
  double loop_time_ = 0;  // s, the loop clock's time of the latest tick read
  std::uint64_t loop_tick_ = 0;  // the latest tick read

  std::unique_ptr<record::Recorder> recorder_;  // null: not recording
  double record_start_time_ = 0;                // s, loop clock when the recording started
  std::uint32_t recorded_warnings_ = 0;         // LoopWarning bits on at the last update while recording
  double record_pause_s_ = 0;                   // s, wall time the loop stopped for the snapshot
  bool suspended_ = false;
  std::thread discard_thread_;
  std::atomic<bool> discard_stop_{false};

  // The seek snapshot pass: recordings stopped, waiting for it, in order.
  void seek_snapshot_worker();
  double seek_snapshot_interval_ = 5.0;  // s; 0: off
  mutable std::mutex seek_mutex_;
  std::condition_variable seek_cv_;
  std::deque<std::pair<std::filesystem::path, double>> seek_queue_;  // file, interval (s)
  bool seek_busy_ = false;
  std::atomic<bool> seek_stop_{false};
  std::thread seek_thread_;
};

/// The core's material from the panel's settings.
deform::Material to_material(const MaterialSettings& m);

}  // namespace palpa::app
