// The workbench's model: probes pressing the organ through the core.

#include "app/gui/workbench.h"

#include <algorithm>

namespace palpa::app {

deform::Material to_material(const MaterialSettings& s) {
  deform::Material m;
  m.model = s.model;
  m.stiffness = s.stiffness;
  m.damping = s.damping;
  m.mass = s.mass;
  return m;
}

void Workbench::set_organ(render::Organ organ) {
  // Build everything first, then swap (nothing changes on a throw).
  auto surface = std::make_unique<deform::DeformableSurface>(
      organ.mesh, deform::MaterialArrays::uniform(organ.mesh->vertex_count(), to_material(material_)));
  auto tree = std::make_unique<collision::VertexTree>(organ.mesh->positions);
  organ_ = std::move(organ);
  surface_ = std::move(surface);
  tree_ = std::move(tree);
  time_ = 0;
  for (Probe& p : probes_) {
    p.placed = false;
    p.depth = 0;
    p.memory = {};
    p.output = {};
  }
}

void Workbench::set_material(const MaterialSettings& m) {
  material_ = m;
  if (surface_)
    surface_->set_materials(deform::MaterialArrays::uniform(surface_->mesh().vertex_count(), to_material(m)));
  for (Probe& p : probes_) p.depth = std::min(p.depth, max_depth());
}

int Workbench::add_probe() {
  Probe p;
  p.id = next_id_++;
  probes_.push_back(p);
  selected_ = p.id;
  return p.id;
}

void Workbench::remove_probe(int id) {
  std::erase_if(probes_, [id](const Probe& p) { return p.id == id; });
  if (selected_ == id) selected_ = probes_.empty() ? 0 : probes_.back().id;
}

void Workbench::select_probe(int id) {
  if (probe(id)) selected_ = id;
}

Probe* Workbench::probe(int id) {
  for (Probe& p : probes_)
    if (p.id == id) return &p;
  return nullptr;
}

void Workbench::place(int id, const Vec3& anchor, const Vec3& normal, double depth) {
  Probe* p = probe(id);
  if (!p) return;
  p->placed = true;
  p->anchor = anchor;
  p->normal = normal.normalized();
  p->depth = std::clamp(depth, 0.0, max_depth());
  p->tip = p->anchor - p->depth * p->normal;
}

void Workbench::set_depth(int id, double depth) {
  if (Probe* p = probe(id)) p->depth = std::clamp(depth, 0.0, max_depth());
}

void Workbench::tick(double dt) {
  if (!surface_) return;
  // Probe inputs: tips from anchors and depths, velocities by difference.
  inputs_.clear();
  which_.clear();
  for (std::size_t k = 0; k < probes_.size(); ++k) {
    Probe& p = probes_[k];
    if (!p.placed) {
      p.output = {};
      continue;
    }
    const Vec3 tip = p.anchor - p.depth * p.normal;
    p.velocity = (tip - p.tip) / dt;
    p.tip = tip;
    inputs_.push_back({tip, p.velocity});
    which_.push_back(k);
  }
  memory_.resize(inputs_.size());
  outputs_.resize(inputs_.size());
  for (std::size_t j = 0; j < which_.size(); ++j) memory_[j] = probes_[which_[j]].memory;

  // Collision and eq. (4), then the contacts drive the surface for one step.
  haptics::ForceParams params;
  params.friction = material_.friction;
  params.max_force = material_.max_force;
  const deform::ShapeFunction shape{material_.shape, material_.radius};
  haptics::haptic_tick(*surface_, *tree_, inputs_, memory_, outputs_, params, shape);
  contacts_.clear();
  for (std::size_t j = 0; j < which_.size(); ++j) {
    Probe& p = probes_[which_[j]];
    p.memory = memory_[j];
    p.output = outputs_[j];
    if (p.output.in_contact && p.depth > 0) contacts_.push_back(p.output.contact);
  }
  surface_->set_contacts(contacts_);
  surface_->step(dt);
  time_ += dt;
  ++ticks_;
}

void Workbench::reset() {
  if (surface_) surface_->reset();
  for (Probe& p : probes_) {
    p.depth = 0;
    p.output = {};
    p.memory = {};
  }
}

}  // namespace palpa::app
