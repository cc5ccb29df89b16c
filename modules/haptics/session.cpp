#include "haptics/session.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace palpa::haptics {

std::shared_ptr<const SessionModel> SessionModel::make(std::shared_ptr<const mesh::SurfaceMesh> mesh,
                                                       deform::SurfaceOptions options, const CoreConfig& config,
                                                       std::shared_ptr<const tissue::TissueField> field,
                                                       std::shared_ptr<const deform::MaterialMap> tissue_map) {
  if (!mesh) throw std::invalid_argument("session: no surface mesh");
  if (mesh->vertex_count() == 0) throw std::invalid_argument("session: the surface has no vertices");
  config.validate();
  auto m = std::make_shared<SessionModel>();
  m->tree = std::make_shared<collision::VertexTree>(*mesh);
  m->mesh = std::move(mesh);
  m->options = options;
  m->config = config;
  if (field) {
    for (std::size_t p = 0; p < field->pulse_count; ++p)
      if (field->pulse_weight[p].size() != m->mesh->vertex_count())
        throw std::invalid_argument("session: the tissue field's pulse weights do not fit the mesh");
    for (std::size_t r = 0; r < field->dynamic_count; ++r)
      if (field->dynamic_weight[r].size() != m->mesh->vertex_count())
        throw std::invalid_argument("session: the tissue field's region weights do not fit the mesh");
  }
  m->field = std::move(field);
  m->tissue_map = std::move(tissue_map);
  return m;
}

void SessionModel::prepare_surface(deform::DeformableSurface& surface) const {
  if (tissue_map) surface.set_tissue_map(*tissue_map);
  if (field && field->pulse_count > 0) set_field_drives(surface, field.get());
}

MaterialSource material_source_of(const deform::MaterialArrays& m) {
  MaterialSource s;
  bool same = m.size() > 0;
  const deform::Material first = same ? m.at(0) : deform::Material{};
  for (std::size_t i = 1; same && i < m.size(); ++i) same = m.at(static_cast<Index>(i)) == first;
  if (same) {
    s.material = first;
  } else {
    s.uniform = false;
    s.map = std::make_shared<deform::MaterialArrays>(m);
    s.map_ptr = s.map.get();
  }
  return s;
}

void apply_material_source(deform::DeformableSurface& surface, const MaterialSource& source) {
  if (source.uniform)
    surface.set_uniform_material(source.material);
  else if (source.tissue_map)
    surface.set_tissue_map(*source.tissue_map);
  else if (source.map_ptr != nullptr)
    surface.set_materials(*source.map_ptr);
}

Session::Session(std::shared_ptr<const SessionModel> model, deform::MaterialArrays materials,
                 std::vector<ProbeSetup> probes)
    : model_(std::move(model)) {
  if (!model_ || !model_->mesh || !model_->tree) throw std::invalid_argument("session: no model");
  materials_ = material_source_of(materials);
  surface_ = std::make_unique<deform::DeformableSurface>(model_->mesh, std::move(materials), model_->options);
  model_->prepare_surface(*surface_);
  if (model_->tissue_map) {
    materials_ = MaterialSource{};
    materials_.uniform = false;
    materials_.tissue_map = model_->tissue_map;
  }
  core_ = std::make_unique<LoopCore>(*model_->tree, *model_->mesh, model_->config, std::move(probes),
                                     model_->field.get());
  surface_field_ = model_->field.get();
  surface_->take_dirty_ranges();
}

Session::Session(std::shared_ptr<const mesh::SurfaceMesh> mesh, deform::MaterialArrays materials,
                 deform::SurfaceOptions options, const CoreConfig& config, std::vector<ProbeSetup> probes)
    : Session(SessionModel::make(std::move(mesh), options, config), std::move(materials), std::move(probes)) {}

void Session::apply(const LoopCommand& command, double t) noexcept { core_->apply(command, t); }

void Session::set_materials(deform::MaterialArrays materials, double t) {
  materials.validate(model_->mesh->vertex_count());
  auto kept = std::make_shared<const deform::MaterialArrays>(std::move(materials));
  kept_maps_.push_back(kept);
  LoopCommand c = LoopCommand::of(LoopCommandKind::SetMaterialMap);
  c.materials = kept.get();
  core_->apply(c, t);
}

void Session::set_tissue(std::shared_ptr<const TissueModel> tissue, double t) {
  if (!tissue) throw std::invalid_argument("session: set_tissue without a tissue");
  validate_tissue(*tissue, model_->mesh->vertex_count());
  kept_tissues_.push_back(tissue);
  LoopCommand c = LoopCommand::of(LoopCommandKind::SetTissue);
  c.tissue = tissue.get();
  core_->apply(c, t);
}

void Session::apply_edits_now() {
  if (!core_->state().pending.any()) return;
  const DeformEdits e = core_->take_pending_edits();
  apply_deform_edits(*surface_, e);
  note_edits(e);
}

std::shared_ptr<const TissueModel> Session::tissue_owner(const TissueModel* t) const {
  return owner_among(kept_tissues_, t);
}

// A tissue map's owner: the tissue that holds it, a restored map, or none.
std::shared_ptr<const deform::MaterialMap> Session::map_owner(const deform::MaterialMap* m) const {
  if (!m) return nullptr;
  for (const auto& k : kept_tissues_)
    if (k->map.get() == m) return k->map;
  return owner_among(kept_tissue_maps_, m);
}

bool Session::tick(double t, std::span<const ProbeTickInput> inputs, std::span<ProbeTickResult> results,
                   double model_time) {
  // The model at rest counts as made at the first tick.
  if (generation_ == 0 && tick_ == 0) model_time_ = t;
  const double mt = std::isnan(model_time) ? model_time_ : model_time;
  const bool due = core_->tick(tick_, t, *surface_, mt, inputs, results, contacts_);
  last_input_count_ = std::min(inputs.size(), last_inputs_.size());
  std::copy_n(inputs.begin(), last_input_count_, last_inputs_.begin());
  ++tick_;
  return due;
}

// The material and the tissue in force on the surface, for snapshots.
void Session::note_edits(const DeformEdits& e) {
  if (e.tissue) {
    surface_tissue_ = e.tissue;
    surface_field_ = e.tissue->field.get();
  }
  if (e.material == 3 && e.tissue_map != nullptr) {
    materials_ = MaterialSource{};
    materials_.uniform = false;
    materials_.tissue_map = map_owner(e.tissue_map);
    materials_.edited_tissue_map = true;
  }
  if (e.material == 1) {
    materials_ = MaterialSource{};
    materials_.material = e.uniform;
  } else if (e.material == 2 && e.map != nullptr) {
    materials_ = MaterialSource{};
    materials_.uniform = false;
    materials_.map_ptr = e.map;
    for (const auto& k : kept_maps_)
      if (k.get() == e.map) materials_.map = k;
  }
}

void Session::deform(const DeformRequest& r) {
  apply_deform_request(*surface_, r, scratch_, surface_field_);
  // The step streamed the contacts' patches (megabytes at 1M vertices)
  // through this thread's cache; the next tick would pay for it (issue 8,
  // target 3: its p99 was about twice the other ticks'), and a probe's
  // crossing past a corner found neither its triangles nor the walk's code
  // (round 31): the warm-up rehearses that crossing too. Then the tick's
  // own code around the query, which the step evicted too (round 36).
  core_->warm_caches(*surface_, true);
  core_->rehearse_tick(*surface_, std::span<const ProbeTickInput>(last_inputs_.data(), last_input_count_),
                       rehearsal_results_);
  note_edits(r.edits);
  generation_ = r.generation;
  model_time_ = r.time;
}

bool Session::step(double t, std::span<const ProbeTickInput> inputs, std::span<ProbeTickResult> results) {
  if (!tick(t, inputs, results)) return false;
  deform(core_->request());
  return true;
}

SessionState Session::snapshot() const {
  SessionState s;
  s.core = core_->state();
  s.surface = surface_->state();
  const auto c = surface_->contacts();
  s.contacts.assign(c.begin(), c.end());
  s.tick = tick_;
  s.generation = generation_;
  s.model_time = model_time_;
  s.materials = materials_;
  s.tissue = tissue_owner(s.core.tissue);
  s.surface_tissue = tissue_owner(surface_tissue_);
  s.pending_tissue_map = map_owner(s.core.pending.material == 3 ? s.core.pending.tissue_map : nullptr);
  return s;
}

void Session::restore(const SessionState& s) {
  if (s.core.tissue != s.tissue.get() || (s.core.pending.tissue && s.core.pending.tissue != s.core.tissue))
    throw std::invalid_argument("session: the snapshot's tissue does not match its core state");
  if (s.core.pending.material == 3 && s.core.pending.tissue_map != s.pending_tissue_map.get())
    throw std::invalid_argument("session: the snapshot's pending tissue map is not kept with it");
  if (s.surface_tissue) validate_tissue(*s.surface_tissue, model_->mesh->vertex_count());
  if (s.tissue) validate_tissue(*s.tissue, model_->mesh->vertex_count());
  // Materials and pulse drives first (they shape the fields the restore rebuilds).
  apply_material_source(*surface_, s.materials);
  const tissue::TissueField* field = s.surface_tissue ? s.surface_tissue->field.get() : model_->field.get();
  set_field_drives(*surface_, field);
  surface_->restore(s.surface, s.contacts);
  core_->set_state(s.core);
  tick_ = s.tick;
  generation_ = s.generation;
  model_time_ = s.model_time;
  materials_ = s.materials;
  surface_tissue_ = s.surface_tissue.get();
  surface_field_ = field;
  auto keep = [](auto& kept, const auto& p) {
    if (p && std::find(kept.begin(), kept.end(), p) == kept.end()) kept.push_back(p);
  };
  keep(kept_maps_, s.materials.map);
  keep(kept_tissues_, s.tissue);
  keep(kept_tissues_, s.surface_tissue);
  keep(kept_tissue_maps_, s.pending_tissue_map);
  keep(kept_tissue_maps_, s.materials.tissue_map);
}

}  // namespace palpa::haptics
