#pragma once
// The session engine: one model, one state, one step.
//
// A session is a const model (the undeformed mesh, its vertex tree, the
// surface options and the timing configuration), a plain, copyable state
// (SessionState: every vertex state, the contacts, every probe's memory,
// velocity filter, safety and clutch state, the material in force, time and
// counters) and one step: the haptic tick of every probe (LoopCore::tick)
// followed, on the schedule CoreConfig::deform_rate_hz sets, by the
// deformation step (apply_deform_request). Edits (materials, probes,
// mappings, shape function, force parameters, reset) are LoopCommands
// applied at a step boundary, so they are part of the recorded session.
//
// Session runs both halves on the calling thread: palpa-palpate, the render
// job, the benchmarks and the replay use it. The real-time HapticLoop runs
// the very same two halves (LoopCore::tick on the haptic thread,
// apply_deform_request on the deformation thread), so with every requested
// step made before the next tick (before its held warm-up, up to 50 us
// earlier: LoopConfig::warm_before_tick) a live session and a Session give
// the same bits (tests/loop/test_session.cpp checks it).

#include "haptics/loop_core.h"
#include "tissue/field.h"

#include <limits>
#include <memory>
#include <span>
#include <vector>

namespace palpa::haptics {

/// What stepping never changes.
struct SessionModel {
  std::shared_ptr<const mesh::SurfaceMesh> mesh;
  std::shared_ptr<const collision::VertexTree> tree;
  deform::SurfaceOptions options;
  CoreConfig config;  ///< rates and the initial force and shape parameters
  /// Lesions, pulses, breathing and dynamic regions (null: none). The
  /// surfaces get its pulse drives; the ticks read it.
  std::shared_ptr<const tissue::TissueField> field;
  /// The tissue map a session starts with (a scenario's; null: the
  /// materials given to the Session or HapticLoop).
  std::shared_ptr<const deform::MaterialMap> tissue_map;

  /// Builds the vertex tree over `mesh` (O(V log V)). Throws
  /// std::invalid_argument for a null or empty mesh or a bad configuration.
  static std::shared_ptr<const SessionModel> make(std::shared_ptr<const mesh::SurfaceMesh> mesh,
                                                  deform::SurfaceOptions options, const CoreConfig& config,
                                                  std::shared_ptr<const tissue::TissueField> field = nullptr,
                                                  std::shared_ptr<const deform::MaterialMap> tissue_map = nullptr);
  /// Gives a new surface of this model its tissue map and pulse drives.
  void prepare_surface(deform::DeformableSurface& surface) const;
};

/// The material map in force: one material, or a per-vertex map kept alive here.
struct MaterialSource {
  bool uniform = true;
  deform::Material material;                            ///< when uniform
  std::shared_ptr<const deform::MaterialArrays> map;    ///< otherwise
  const deform::MaterialArrays* map_ptr = nullptr;      ///< the map the commands named (== map.get() or external)
  std::shared_ptr<const deform::MaterialMap> tissue_map; ///< a tissue map (uniform false, map null)
  /// tissue_map is a SetTissue's (false: the model's tissue map).
  bool edited_tissue_map = false;
};

/// The source of `materials`: one material when every vertex has it, else
/// a copy of the map (kept by the source).
MaterialSource material_source_of(const deform::MaterialArrays& materials);
/// Gives `surface` the materials of `source` (a map named by pointer only
/// must still be alive).
void apply_material_source(deform::DeformableSurface& surface, const MaterialSource& source);

/// The pointer among `kept` that is `p`, else one that points to `p`
/// without owning it (null for null): what a state holds of an object a
/// command named, which its sender keeps alive.
template <class T>
std::shared_ptr<const T> owner_among(const std::vector<std::shared_ptr<const T>>& kept, const T* p) {
  if (!p) return nullptr;
  for (const auto& k : kept)
    if (k.get() == p) return k;
  return std::shared_ptr<const T>(std::shared_ptr<const T>(), p);
}

/// Everything that changes while a session runs: a copy is a snapshot.
struct SessionState {
  CoreState core;
  deform::SurfaceState surface;            ///< per-vertex h (m), h' (m/s), q (m); time (s)
  std::vector<deform::Contact> contacts;   ///< the contacts of the last deformation step
  std::uint64_t tick = 0;                  ///< ticks made
  std::uint64_t generation = 0;            ///< deformation steps made
  double model_time = 0;                   ///< s: the time of the tick that asked for the last step
  MaterialSource materials;
  /// The tissue the core reads (core.tissue, also core.pending.tissue),
  /// kept alive with the state; null when no SetTissue came (the model's field).
  std::shared_ptr<const TissueModel> tissue;
  /// The tissue whose pulse drives and field the surface has (the latest
  /// SetTissue a deformation step applied); null: the model's field.
  std::shared_ptr<const TissueModel> surface_tissue;
  /// Keeps core.pending.tissue_map alive (a SetTissue's map not applied yet).
  std::shared_ptr<const deform::MaterialMap> pending_tissue_map;
};

class Session {
 public:
  /// A session at rest with `probes` in slots 0 .. n-1 (output disabled
  /// until an Enable command). Throws std::invalid_argument as LoopCore and
  /// DeformableSurface do.
  Session(std::shared_ptr<const SessionModel> model, deform::MaterialArrays materials,
          std::vector<ProbeSetup> probes);
  /// Convenience: builds the model too.
  Session(std::shared_ptr<const mesh::SurfaceMesh> mesh, deform::MaterialArrays materials,
          deform::SurfaceOptions options, const CoreConfig& config, std::vector<ProbeSetup> probes);

  const SessionModel& model() const { return *model_; }
  std::shared_ptr<const SessionModel> model_ptr() const { return model_; }

  /// Applies an edit or command at the next step boundary, time t (s).
  /// SetMaterialMap's array must outlive the session (or use set_materials).
  void apply(const LoopCommand& command, double t) noexcept;
  /// Queues per-vertex materials (kept alive by the session) for the next
  /// deformation step. Throws std::invalid_argument as MaterialArrays::validate.
  void set_materials(deform::MaterialArrays materials, double t);
  /// Queues a new tissue (kept alive by the session) as a SetTissue command:
  /// the ticks from the next one on read its field, the next deformation
  /// step gives the surface its map (null: the materials in force stay)
  /// and pulse drives. t: s. Throws std::invalid_argument for a null tissue
  /// or one that does not fit the mesh (validate_tissue); nothing changes then.
  void set_tissue(std::shared_ptr<const TissueModel> tissue, double t);
  /// The field the ticks read now (the model's until a SetTissue), and the
  /// one the deformation steps use (they differ until the step after a SetTissue).
  const tissue::TissueField* field() const { return core_->field(); }
  const tissue::TissueField* surface_field() const { return surface_field_; }
  /// Applies the edits waiting for the next deformation step (reset,
  /// materials, tissue) to the surface now, with no step, as a stopped HapticLoop
  /// does with commands it is given (CommandRecord::immediate).
  void apply_edits_now();

  /// One step at time t (s): the haptic tick of every probe, then the
  /// deformation step when one is due. `inputs` and `results` hold
  /// core().probe_count() entries (slot-indexed). Returns true when the
  /// surface stepped.
  bool step(double t, std::span<const ProbeTickInput> inputs, std::span<ProbeTickResult> results);

  /// The haptic half alone (returns true when a deformation step is due:
  /// its request is core().request()), and the deformation half. A replay
  /// passes the recorded `model_time` (s) of the generation the tick used;
  /// NaN: the time of the tick that asked for the current generation.
  /// deform() ends by bringing the next tick's data and code back into this
  /// thread's cache (LoopCore::warm_caches, then LoopCore::rehearse_tick on
  /// the last tick's inputs, which tick() keeps a copy of), which changes no
  /// result.
  bool tick(double t, std::span<const ProbeTickInput> inputs, std::span<ProbeTickResult> results,
            double model_time = std::numeric_limits<double>::quiet_NaN());
  void deform(const DeformRequest& request);

  /// The contacts of the last tick.
  const ContactSet& contacts() const { return contacts_; }
  const deform::DeformableSurface& surface() const { return *surface_; }
  deform::DeformableSurface& surface() { return *surface_; }
  const LoopCore& core() const { return *core_; }
  std::uint64_t tick_count() const { return tick_; }
  std::uint64_t generation() const { return generation_; }
  double model_time() const { return model_time_; }

  /// A copy of the whole state, and its exact restore: stepping after
  /// restore(s) gives the same bits as stepping after the snapshot was
  /// taken. Throws std::invalid_argument when the snapshot does not fit.
  SessionState snapshot() const;
  void restore(const SessionState& s);

 private:
  void note_edits(const DeformEdits& e);
  std::shared_ptr<const TissueModel> tissue_owner(const TissueModel* t) const;
  std::shared_ptr<const deform::MaterialMap> map_owner(const deform::MaterialMap* m) const;

  std::shared_ptr<const SessionModel> model_;
  std::unique_ptr<deform::DeformableSurface> surface_;
  std::unique_ptr<LoopCore> core_;
  ContactSet contacts_;
  // The last tick's inputs, for the rehearsal after a step (LoopCore::rehearse_tick), and its scratch results.
  std::array<ProbeTickInput, kMaxProbes> last_inputs_{};
  std::size_t last_input_count_ = 0;
  std::array<ProbeTickResult, kMaxProbes> rehearsal_results_{};
  std::vector<deform::Contact> scratch_;
  std::uint64_t tick_ = 0, generation_ = 0;
  double model_time_ = 0;
  MaterialSource materials_;
  std::vector<std::shared_ptr<const deform::MaterialArrays>> kept_maps_;  // maps queued by set_materials
  std::vector<std::shared_ptr<const TissueModel>> kept_tissues_;          // set_tissue's and restored ones
  std::vector<std::shared_ptr<const deform::MaterialMap>> kept_tissue_maps_;  // restored pending maps
  const TissueModel* surface_tissue_ = nullptr;       // the latest SetTissue the surface got (null: none)
  const tissue::TissueField* surface_field_ = nullptr;  // the field the deformation steps use
};

}  // namespace palpa::haptics
