#pragma once
// The deterministic part of the haptic loop: what one tick does with the
// device samples it read (mapping, clutch, velocity estimate, input checks,
// collision and eq. (4) force for every probe, the safety filter, the
// contacts for the deformation model). The real-time thread (loop.h) and the
// replay of a recorded session (loop_replay.h) run exactly this code, so a
// session replays bit for bit from its recorded inputs.
//
// Everything here is plain data or preallocated: tick() does no allocation,
// locking, I/O or exception.

#include "collision/vertex_tree.h"
#include "deform/surface.h"
#include "devices/plugin_api.h"
#include "haptics/device_mapping.h"
#include "haptics/force.h"
#include "haptics/probe_tick.h"
#include "haptics/safety.h"

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace palpa::haptics {

/// Most probes one loop drives.
inline constexpr std::size_t kMaxProbes = 8;

/// A 3-vector as plain data (for records and lock-free exchange).
using Triple = std::array<double, 3>;
inline Triple to_triple(const Vec3& v) { return {v[0], v[1], v[2]}; }
inline Vec3 to_vec(const Triple& t) { return {t[0], t[1], t[2]}; }

/// Timing and model parameters shared by the live loop and the replay.
struct CoreConfig {
  double rate_hz = 1000;               ///< haptic tick rate, Hz (100 .. 10000)
  double deform_rate_hz = 500;         ///< deformation integration rate, Hz (0: no deformation)
  double watchdog_periods = 3;         ///< a tick starting later than this many periods after the previous is "loop late"
  double model_timeout_periods = 10;   ///< a model older than this many deformation periods is "model late"
  double velocity_cutoff_hz = 50;      ///< low-pass cutoff of the finite-difference probe velocity, Hz
  ForceParams force;                   ///< eq. (4) parameters (force.max_force also clamps the model force)
  deform::ShapeFunction shape;         ///< shape function of the contacts

  /// Throws std::invalid_argument naming the bad field, e.g.
  /// "loop configuration: rate_hz must be in [100, 10000], got 50000".
  void validate() const;
  double period() const { return 1.0 / rate_hz; }
};

/// One probe: its device's specification, mapping and safety limits.
struct ProbeSetup {
  std::string name;          ///< for messages ("falcon", "left hand")
  PalpaDeviceSpec spec{};    ///< the device's specification
  DeviceMapping mapping;
  SafetyLimits safety;       ///< max_force 0: use the device's spec.max_force
};

/// A probe checked and resolved for the loop (LoopCore::prepare): plain
/// data, so adding it at a tick boundary copies without allocating.
struct PreparedProbe {
  PalpaDeviceSpec spec{};
  SafetyFilter safety;       ///< limits resolved from the device's max_force, disabled
  ClutchedMapping mapping;
};

/// A tissue for a running session: the per-vertex tissue map and the field (either may be null:
/// null map = keep the materials in force; null field = no lesions/pulses/breathing/dynamic regions).
/// Plain data read by the haptic thread (the field) and the deformation thread (map, pulse drives).
struct TissueModel {
  std::shared_ptr<const deform::MaterialMap> map;
  std::shared_ptr<const tissue::TissueField> field;
};

/// Checks that `tissue` fits a mesh of `vertex_count` vertices: the map's
/// tissues (valid materials, at most 65536), one tissue index per vertex
/// (in range), scales (none or one per vertex, positive and finite); the
/// field's counts (at most kMaxLesions lesions, kMaxPulses pulses,
/// kMaxDynamicRegions regions, kMaxKeyframes keyframes each), one weight
/// per vertex for every pulse and dynamic region, pulse vertices in range,
/// a positive tip radius (m). Throws std::invalid_argument naming what is
/// wrong, e.g. "tissue: the field's pulse 0 has 12 weights for 100 vertices".
void validate_tissue(const TissueModel& tissue, std::size_t vertex_count);

/// A command from another thread, applied at the start of a tick. Every
/// change to a running session is one of these, so it is recorded with the
/// tick it took effect at and a replay applies it at the same tick.
enum class LoopCommandKind : std::uint8_t {
  Enable = 0,      ///< enable force output with a ramp-in; clears a latched fault
  Disable = 1,
  ClutchOn = 2,    ///< engage the clutch (as if the clutch button were held)
  ClutchOff = 3,
  SetMapping = 4,  ///< replace the mapping (validated before it is queued)
  AddProbe = 5,    ///< occupy slot `probe` with `prepared` (output disabled until Enable)
  RemoveProbe = 6, ///< free slot `probe` (its contact is released)
  SetShape = 7,    ///< shape function of the contacts from this tick on
  SetForce = 8,    ///< eq. (4) parameters from this tick on
  SetMaterial = 9, ///< every vertex gets `material` at the next deformation step
  SetMaterialMap = 10, ///< per-vertex `materials` (kept alive by the sender) at the next deformation step
  ResetSurface = 11,   ///< surface back to rest at the next deformation step; contacts released
  /// `tissue` (kept alive by the sender) from this tick on: the ticks read its field at once (the
  /// guarding reactions start afresh); its map (when not null) and its field's pulse drives reach
  /// the surface at the next deformation step, which uses its field's pulse values from then on.
  SetTissue = 12,
};

struct LoopCommand {
  LoopCommandKind kind = LoopCommandKind::Disable;
  std::uint32_t probe = 0;
  DeviceMapping mapping;   ///< SetMapping only
  PreparedProbe prepared;  ///< AddProbe only
  deform::ShapeFunction shape;  ///< SetShape only
  ForceParams force;            ///< SetForce only
  deform::Material material;    ///< SetMaterial only
  const deform::MaterialArrays* materials = nullptr;  ///< SetMaterialMap only; must outlive the session
  const TissueModel* tissue = nullptr;  ///< SetTissue only; must outlive the session (validate_tissue'd)

  /// A command of `kind` for slot `probe`, every payload at its default.
  static LoopCommand of(LoopCommandKind kind, std::uint32_t probe = 0) {
    LoopCommand c;
    c.kind = kind;
    c.probe = probe;
    return c;
  }
};

/// A valid reading of a probe that reports its tip position only: tip `p`
/// (m), orientation (1, 0, 0, 0), no buttons, `sequence` and time `t` (s).
/// What scripted presses (palpa-palpate, the render job, the calibration
/// press, the benchmarks) feed a Session.
inline PalpaDeviceSample position_sample(const Vec3& p, std::uint64_t sequence, double t) {
  PalpaDeviceSample s{};
  s.sequence = sequence;
  s.time = t;
  for (int k = 0; k < 3; ++k) s.position[k] = p[k];
  s.orientation[0] = 1;
  s.status = PALPA_STATUS_VALID;
  return s;
}

/// What one tick read from one device.
struct ProbeTickInput {
  PalpaDeviceSample sample{};
  bool read_ok = true;       ///< false when the plugin's read failed
};

/// What one tick did for one probe (plain data: recorded and shown).
struct ProbeTickResult {
  PalpaDeviceSample sample{};   ///< as read
  Triple world{};               ///< probe position, world frame, m
  Triple velocity{};            ///< estimated probe velocity, m/s
  Triple force_world{};         ///< force on the probe after safety, world frame, N
  Triple force_device{};        ///< the command sent, device frame, N
  Triple contact_point{};       ///< virtual vertex on the undeformed surface (when in contact), m
  Triple contact_normal{};      ///< its interpolated normal
  double depth = 0;             ///< penetration below the undeformed surface, m
  double normal_reaction = 0;   ///< Fn of eq. (4) before any clamp, N
  std::uint32_t flags = 0;      ///< SafetyFlag bits
  std::uint8_t in_contact = 0;
  std::uint8_t enabled = 0;
  std::uint8_t clutched = 0;
  std::uint8_t fault = 0;       ///< SafetyFault
  std::uint8_t path = 0;        ///< collision::ContactPath of the contact query
};

/// A contact as plain data, for the deformation thread.
struct ContactRecord {
  Triple point{};
  Triple normal{0, 0, 1};
  Index vertex = kNoIndex;
  double depth = 0;
  deform::ShapeFunction shape;
};

/// ContactSet::tick of the empty set the deformation thread sees before the
/// first tick has published contacts.
inline constexpr std::uint64_t kNoContactsTick = ~std::uint64_t{0};

/// The contacts of one tick.
struct ContactSet {
  std::uint64_t tick = kNoContactsTick;
  std::uint32_t count = 0;
  std::array<ContactRecord, kMaxProbes> contacts{};
};

/// Converts a contact set for DeformableSurface::set_contacts.
void to_contacts(const ContactSet& set, std::vector<deform::Contact>& out);

/// Model edits that wait for the next deformation step.
struct DeformEdits {
  bool reset = false;                 ///< surface to rest before the step
  std::uint8_t material = 0;          ///< 0: none, 1: `uniform`, 2: `map`, 3: `tissue_map`
  deform::Material uniform;
  const deform::MaterialArrays* map = nullptr;
  const deform::MaterialMap* tissue_map = nullptr;  ///< material 3: a SetTissue's map
  /// A SetTissue's tissue: the surface gets its field's pulse drives (none
  /// without pulses), and the steps from this one on its field's pulse values.
  const TissueModel* tissue = nullptr;
  bool any() const { return reset || material != 0 || tissue != nullptr; }
};

/// One deformation step, asked for by the tick whose contacts it uses. The
/// haptic ticks make them on a fixed schedule (CoreConfig::deform_rate_hz
/// against rate_hz), plus one with dt = 0 at a tick that applied a model edit
/// between two steps, so the sequence of steps depends only on the ticks.
struct DeformRequest {
  std::uint64_t generation = 0;  ///< the surface generation this step makes (1, 2, ...)
  std::uint64_t tick = 0;        ///< the tick whose contacts it uses
  double time = 0;               ///< s, that tick's time
  double dt = 0;                 ///< s, the step (0: edits only, no integration)
  ContactSet contacts;
  DeformEdits edits;             ///< applied before the step
};

/// Folds a later request into an earlier one not yet made (a deformation
/// thread that fell behind makes one step for both): edits in order, the
/// later contacts, tick and time, and the sum of the steps (the local models
/// integrate exactly over any step, so the surface keeps time).
void merge_requests(DeformRequest& into, const DeformRequest& later);

/// Gives `surface` the pulse drives of `field` (its pulse vertices and
/// weights); none when `field` is null or has no pulse (then the drive
/// values are zeroed too). Allocates; throws what set_drives throws.
void set_field_drives(deform::DeformableSurface& surface, const tissue::TissueField* field);

/// Applies model edits to a surface: reset first, then the material (or a
/// tissue's map), then a tissue's pulse drives. Throws only what the
/// surface's edits throw for bad materials.
void apply_deform_edits(deform::DeformableSurface& surface, const DeformEdits& edits);

/// The field the deformation steps use after `edits`: the field of the
/// tissue they set (possibly null), else `current`.
inline const tissue::TissueField* field_after(const DeformEdits& edits, const tissue::TissueField* current) {
  return edits.tissue ? edits.tissue->field.get() : current;
}

/// Applies a request to a surface: edits, contacts, the pulse drives'
/// values at the request's time (when the field in use has pulses: `field`,
/// or the field of a tissue the request's edits set), step. `scratch` keeps
/// its capacity between calls. Throws only what the surface's edits throw
/// for bad materials (they were validated before they were queued).
void apply_deform_request(deform::DeformableSurface& surface, const DeformRequest& request,
                          std::vector<deform::Contact>& scratch, const tissue::TissueField* field = nullptr);

/// Everything one probe slot of the core remembers between ticks.
struct CoreProbeState {
  bool active = false;
  PalpaDeviceSpec spec{};
  SafetyFilter safety;
  ClutchedMapping mapping;
  bool clutch_command = false;
  bool have_world = false;
  Vec3 world = Vec3::Zero();          ///< last valid probe position, m
  Vec3 velocity = Vec3::Zero();       ///< filtered, m/s
  std::uint64_t last_sequence = 0;
  double last_sample_time = 0;        ///< s
  Vec3 last_sample_world = Vec3::Zero();
  bool have_sample = false;
};

/// The whole mutable state of a LoopCore: plain, copyable data. A copy is a
/// snapshot; LoopCore::set_state restores it exactly.
struct CoreState {
  std::array<CoreProbeState, kMaxProbes> probes{};
  std::array<ProbeMemory, kMaxProbes> memory{};  ///< per slot: collision cursor and contact hysteresis
  ForceParams force;                  ///< eq. (4) parameters in force now
  deform::ShapeFunction shape;        ///< shape function given to contacts now
  double last_tick_time = 0;          ///< s
  bool have_last_tick = false;
  double deform_phase = 0;            ///< deformation steps owed, in steps (0 .. 1)
  std::uint64_t generations = 0;      ///< deformation steps requested so far
  DeformEdits pending;                ///< edits waiting for the next request
  tissue::ReactionState reactions;    ///< guarding reactions of the tissue field's dynamic regions
  /// The tissue of the latest SetTissue, whose field the ticks read (null:
  /// none yet, the field the core was built with).
  const TissueModel* tissue = nullptr;
};

class LoopCore {
 public:
  /// `tree` and `mesh` must outlive the core. Throws std::invalid_argument
  /// for a bad configuration, too many probes or bad mappings/limits. The
  /// probes take slots 0 .. probes.size() - 1 with output disabled.
  /// `field` (lesions, pulses, breathing, dynamic regions; may be null)
  /// must outlive the core too; a SetTissue command replaces it (field()
  /// is the one in force). With breathing the probes are brought into
  /// the organ frame before the contact query (contact points and depths in
  /// results are in the organ frame; forces are taken as they are: the
  /// breathing stretch is small and not applied to them).
  LoopCore(const collision::VertexTree& tree, const mesh::SurfaceMesh& mesh, const CoreConfig& config,
           std::vector<ProbeSetup> probes, const tissue::TissueField* field = nullptr);
  const tissue::TissueField* field() const { return field_; }

  /// Checks and resolves a probe for an AddProbe command. Throws
  /// std::invalid_argument naming the probe and the bad field.
  static PreparedProbe prepare(ProbeSetup setup, const CoreConfig& config);

  /// Highest occupied slot + 1: the length of the inputs and results spans.
  std::size_t probe_count() const;
  /// True when slot i holds a probe.
  bool active(std::size_t i) const { return i < kMaxProbes && state_.probes[i].active; }
  const CoreConfig& config() const { return config_; }
  /// The probes the core was built with (resolved), for a replay.
  const std::vector<ProbeSetup>& setups() const { return setups_; }
  /// The limits actually applied to probe i (max_force resolved from the spec).
  const SafetyLimits& limits(std::size_t i) const { return state_.probes[i].safety.limits(); }

  /// Applies a command at time t (s). Out-of-range probes are ignored.
  void apply(const LoopCommand& command, double t) noexcept;

  /// Brings the data the next tick reads back into the cache: runs the last
  /// tick's collision and force again against `surface`, at the same probe
  /// positions, into scratch memories and outputs. Changes nothing a tick,
  /// a result or state() shows. For a caller that has just run a
  /// deformation step on the tick's thread (Session::deform): the step
  /// streams megabytes through the cache, and the tick after it would
  /// otherwise pay for those misses; and for the haptic thread during its
  /// spin and just before the tick (LoopConfig::warm_before_tick), after a
  /// sleep and after the deformation thread wrote a new replica on another
  /// CPU. A probe the last tick found hovering clear of the surface
  /// (collision::ContactPath::Clear, no search) is asked of the tree here,
  /// so that the tree's path is in the cache on the tick the probe leaves
  /// its clearance. At each probe in contact that may leave it within a few
  /// ticks (its depth within 4 ticks of its speed, or 0.1 mm), the tree is
  /// asked, on its copy, what the tick on which the probe leaves contact
  /// asks: the nearest vertex and the clearance bound, from the root
  /// (without it, those ticks took 7 to 18 us in the running loop, against
  /// 1 to 3 for the others; docs/PERFORMANCE.md, round 33). With `rehearse_corners` (the caller has just run a
  /// step on this thread), each probe in contact is then queried once more
  /// on its copy, past the corner it is nearest (corner_rehearsal_point),
  /// so that a crossing round that corner finds its triangles and the walk's
  /// code in the cache, which the step pushed out (docs/PERFORMANCE.md,
  /// round 31). The haptic thread's warm-ups do not: there the step runs on
  /// another CPU. Costs about one
  /// tick (microseconds); no allocation, no lock.
  void warm_caches(const deform::DeformableSurface& surface, bool rehearse_corners = false) noexcept;
  /// Runs tick()'s own code once more after warm_caches, for a caller that
  /// has just run a deformation step on the tick's thread (Session::deform):
  /// the last tick again, at its time (s), with `inputs` (the inputs that
  /// tick was given, probe_count() entries) and copies of the probes'
  /// memories made as warm_caches makes them (it makes its own), into
  /// `results` (scratch, probe_count() entries) and a contact set of its
  /// own; everything tick() writes is put
  /// back after, so no later tick, result, request() or state() differs, to
  /// the bit. The step evicts the tick's code and what it reads around
  /// haptic_tick (the inputs' checks, the mapping, the safety chain, the
  /// results), which warm_caches does not run: on the 1M sphere the quiet
  /// ticks right after a step had twice the p99 of those a tick later
  /// (docs/PERFORMANCE.md, round 36). Does nothing before a tick has run
  /// (can_warm()). About one tick (microseconds); no allocation, no lock.
  void rehearse_tick(const deform::DeformableSurface& surface, std::span<const ProbeTickInput> inputs,
                     std::span<ProbeTickResult> results) noexcept;
  /// What the last warm_caches found for each probe of the last tick, in
  /// the order of its dense probes (for tests).
  std::span<const ProbeOutput> last_warm() const noexcept {
    return std::span<const ProbeOutput>(warm_outputs_.data(), last_dense_);
  }

  /// One tick at time t (s) against `surface` (the model generation in use,
  /// published at model_time, s). `inputs` and `results` hold probe_count()
  /// entries (a free slot's input is ignored, its result cleared);
  /// `contacts` receives the contacts for the deformation model. Returns
  /// true when this tick asks for a deformation step (see request()). Runs
  /// with subnormal values taken as zero (core/subnormals.h); the caller's
  /// floating-point mode is restored.
  bool tick(std::uint64_t tick, double t, const deform::DeformableSurface& surface, double model_time,
            std::span<const ProbeTickInput> inputs, std::span<ProbeTickResult> results,
            ContactSet& contacts) noexcept;
  /// The deformation step the last tick asked for (valid when it returned true).
  const DeformRequest& request() const { return request_; }

  /// Hands over the edits waiting for the next request and clears them
  /// (for a caller that applies them at once, e.g. while a loop is stopped).
  DeformEdits take_pending_edits() noexcept {
    const DeformEdits e = state_.pending;
    state_.pending = DeformEdits{};
    return e;
  }

  /// The mutable state (a snapshot), and its exact restore (the field in
  /// force too: the state's tissue's, or the one the core was built with).
  const CoreState& state() const { return state_; }
  void set_state(const CoreState& s) noexcept {
    state_ = s;
    use_field(state_.tissue ? state_.tissue->field.get() : base_field_);
    // The last tick's probe positions belong to the state before: nothing to
    // warm until a tick from this state has run.
    last_dense_ = 0;
  }
  /// Whether warm_caches has a tick to run again: a tick with at least one
  /// probe has run since the core was made or its state last set.
  bool can_warm() const noexcept { return last_dense_ > 0; }

 private:
  void use_field(const tissue::TissueField* field) noexcept {
    field_ = field;
    tissue_tick_.field = field;
  }

  const collision::VertexTree& tree_;
  const tissue::TissueField* base_field_ = nullptr;  // the field the core was built with
  const tissue::TissueField* field_ = nullptr;       // the field in force
  TissueTick tissue_tick_;
  CoreConfig config_;
  std::vector<ProbeSetup> setups_;
  CoreState state_;
  DeformRequest request_;
  std::array<ProbeInput, kMaxProbes> probe_inputs_{};
  std::array<ProbeOutput, kMaxProbes> probe_outputs_{};
  std::array<std::uint8_t, kMaxProbes> slot_of_{};  // dense index -> slot, for haptic_tick
  // warm_caches: the last tick's probe count and tissue, and its scratch.
  std::size_t last_dense_ = 0;
  bool last_tissue_ = false;
  std::array<ProbeMemory, kMaxProbes> warm_memory_{};
  // rehearse_tick: while it runs, tick() reads the memories' copies in
  // warm_memory_ (by slot); what tick() writes is kept here and put back.
  bool rehearsing_ = false;
  struct Rehearsal {
    std::array<CoreProbeState, kMaxProbes> probes{};
    double last_tick_time = 0, deform_phase = 0;
    std::uint64_t generations = 0;
    DeformEdits pending;
    tissue::ReactionState reactions;
    DeformRequest request;
    std::array<ProbeInput, kMaxProbes> inputs{};
    std::array<std::uint8_t, kMaxProbes> slot_of{};
    bool last_tissue = false;
    TissueTick tissue_tick;
    ContactSet contacts;
  } rehearsal_;
  std::array<ProbeOutput, kMaxProbes> warm_outputs_{};
  Vec3 range_lo_, range_hi_;   // positions outside are clamped onto this box (no contact possible)
  Vec3 parking_;               // where a probe with no valid position yet is placed (far from the surface)
  double step_fraction_ = 0;   // deformation steps per tick
};

}  // namespace palpa::haptics
