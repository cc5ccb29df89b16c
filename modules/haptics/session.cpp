#include "haptics/session.h"

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
  m->tree = std::make_shared<collision::VertexTree>(std::span<const Vec3>(mesh->positions));
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
  if (field && field->pulse_count > 0) {
    std::vector<Index> vertices = field->pulse_vertices;
    std::vector<std::array<float, 4>> weights(vertices.size());
    for (std::size_t j = 0; j < vertices.size(); ++j)
      for (std::size_t p = 0; p < field->pulse_count; ++p) weights[j][p] = field->pulse_weight[p][vertices[j]];
    surface.set_drives(std::move(vertices), std::move(weights));
  }
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

void Session::apply_edits_now() {
  if (!core_->state().pending.any()) return;
  const DeformEdits e = core_->take_pending_edits();
  apply_deform_edits(*surface_, e);
  note_materials(e);
}

bool Session::tick(double t, std::span<const ProbeTickInput> inputs, std::span<ProbeTickResult> results,
                   double model_time) {
  // The model at rest counts as made at the first tick.
  if (generation_ == 0 && tick_ == 0) model_time_ = t;
  const double mt = std::isnan(model_time) ? model_time_ : model_time;
  const bool due = core_->tick(tick_, t, *surface_, mt, inputs, results, contacts_);
  ++tick_;
  return due;
}

// The material in force, for snapshots.
void Session::note_materials(const DeformEdits& e) {
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
  apply_deform_request(*surface_, r, scratch_, model_->field.get());
  note_materials(r.edits);
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
  return s;
}

void Session::restore(const SessionState& s) {
  // Materials first (they shape the fields the restore rebuilds).
  apply_material_source(*surface_, s.materials);
  surface_->restore(s.surface, s.contacts);
  core_->set_state(s.core);
  tick_ = s.tick;
  generation_ = s.generation;
  model_time_ = s.model_time;
  materials_ = s.materials;
  if (s.materials.map) kept_maps_.push_back(s.materials.map);
}

}  // namespace palpa::haptics
