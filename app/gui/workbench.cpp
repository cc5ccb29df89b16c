// The workbench's model: probes as devices of the real-time haptic loop.

#include "app/gui/workbench.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace palpa::app {
namespace {

constexpr double kHapticRateHz = 1000;  // haptic tick rate, Hz
constexpr double kDeformRateHz = 1000;  // deformation integration rate, Hz (the stiff materials need 1 ms steps)

// CLOCK_MONOTONIC in s (steady_clock is CLOCK_MONOTONIC on Linux, like the loop's clock).
double monotonic_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

deform::Material to_material(const MaterialSettings& s) {
  deform::Material m;
  m.model = s.model;
  m.stiffness = s.stiffness;
  m.damping = s.damping;
  m.mass = s.mass;
  return m;
}

Workbench::Workbench() = default;
Workbench::Workbench(devices::PluginLoader loader) : loader_(std::move(loader)) {}

Workbench::~Workbench() {
  // The loop stops (zero force to every device) before the devices go.
  if (loop_) loop_->stop();
  loop_.reset();
}

// ---------------------------------------------------------------------------
// The loop: configuration from the material, built from the probes' devices.
haptics::LoopConfig Workbench::loop_config() const {
  haptics::LoopConfig c;
  c.core.rate_hz = kHapticRateHz;
  c.core.deform_rate_hz = kDeformRateHz;
  c.core.force.friction = material_.friction;
  c.core.force.max_force = material_.max_force;
  c.core.shape = deform::ShapeFunction{material_.shape, material_.radius};
  return c;
}

std::unique_ptr<haptics::HapticLoop> Workbench::build_loop(const mesh::Organ& organ,
                                                           const deform::MaterialArrays& materials,
                                                           const haptics::LoopConfig& config,
                                                           const std::vector<Probe>& probes) const {
  if (!organ.mesh || probes.empty()) return nullptr;
  std::vector<haptics::ProbeBinding> bindings;
  for (const Probe& p : probes) {
    haptics::ProbeBinding b;
    b.device = p.dev.get();
    b.name = "probe " + std::to_string(p.id) + " (" + p.device + ")";
    b.mapping = p.mapping;
    bindings.push_back(b);
  }
  return std::make_unique<haptics::HapticLoop>(organ.mesh, materials, deform::SurfaceOptions{}, config,
                                               std::move(bindings));
}

// Nothing here throws once `next` is built: stop the old loop, swap, start.
// The mouse devices are fed the probes' current state before the new loop
// starts, so its first ticks never read a position from before the change
// (a probe lifted by reset() would otherwise still press for a moment).
void Workbench::install(std::unique_ptr<haptics::HapticLoop> next, std::vector<Probe>& probes) {
  if (loop_) loop_->stop();
  std::swap(loop_, next);
  std::swap(probes_, probes);
  next.reset();  // the old loop goes before the devices only it used (in `probes`)
  for (Probe& p : probes_) p.output = {};
  for (const Probe& p : probes_) feed(p);
  if (!loop_) return;
  loop_->start();
  for (std::size_t i = 0; i < probes_.size(); ++i)
    if (probes_[i].force_output && probes_[i].wants_output) loop_->enable(i);
}

// Mouse probes: the tip pressed `depth` below the anchor, or held just above
// it when lifted; an unplaced probe reports "not ready" (parked by the loop).
void Workbench::feed(const Probe& p) const {
  if (!p.host_fed || !p.dev) return;
  PalpaDeviceSample s{};
  s.orientation[0] = 1;
  if (!p.placed) {
    s.status = PALPA_STATUS_NOT_READY;
  } else {
    const Vec3 tip = p.depth > 0 ? Vec3(p.anchor - p.depth * p.normal) : Vec3(p.anchor + kLiftClearance * p.normal);
    for (int k = 0; k < 3; ++k) s.position[k] = tip[k];
    s.status = PALPA_STATUS_VALID;
  }
  p.dev->feed(s);
}

// ---------------------------------------------------------------------------
// Organ and material.
void Workbench::set_organ(mesh::Organ organ) {
  // Build everything first, then swap (nothing changes on a throw).
  auto materials = deform::MaterialArrays::uniform(organ.mesh->vertex_count(), to_material(material_));
  std::vector<Probe> next = probes_;
  for (Probe& p : next)
    if (p.host_fed) {
      p.placed = false;
      p.depth = 0;
    }
  auto loop = build_loop(organ, materials, loop_config(), next);
  organ_ = std::move(organ);
  materials_ = std::move(materials);
  install(std::move(loop), next);
  epoch_ = monotonic_now();
  time_ = 0;
}

void Workbench::set_material(const MaterialSettings& m) {
  const MaterialSettings old = material_;
  material_ = m;
  try {
    deform::MaterialArrays materials =
        has_organ() ? deform::MaterialArrays::uniform(organ_.mesh->vertex_count(), to_material(m))
                    : deform::MaterialArrays{};
    std::vector<Probe> next = probes_;
    for (Probe& p : next) p.depth = std::min(p.depth, max_depth());
    auto loop = build_loop(organ_, materials, loop_config(), next);
    materials_ = std::move(materials);
    install(std::move(loop), next);
  } catch (...) {
    material_ = old;
    throw;
  }
}

// ---------------------------------------------------------------------------
// Probes.
int Workbench::add(Probe p) {
  if (probes_.size() >= haptics::kMaxProbes)
    throw std::invalid_argument("cannot add probe: the haptic loop drives at most " +
                                std::to_string(haptics::kMaxProbes) + " probes");
  p.id = next_id_;
  std::vector<Probe> next = probes_;
  next.push_back(p);
  auto loop = build_loop(organ_, materials_, loop_config(), next);
  install(std::move(loop), next);
  ++next_id_;
  selected_ = p.id;
  return p.id;
}

int Workbench::add_probe() {
  Probe p;
  p.dev = std::make_shared<devices::Device>(loader_.load("mouse").create("rate=60"));
  p.dev->start();
  return add(std::move(p));
}

int Workbench::add_device_probe(const std::string& plugin, const std::string& options,
                                const haptics::DeviceMapping& mapping) {
  mapping.validate(plugin);
  Probe p;
  p.device = plugin;
  p.options = options;
  p.mapping = mapping;
  p.dev = std::make_shared<devices::Device>(loader_.load(plugin).create(options));
  p.dev->start();  // DeviceError with the plugin's message
  p.host_fed = p.dev->can_feed();
  p.force_output = p.dev->spec().force_dof > 0;
  return add(std::move(p));
}

void Workbench::remove_probe(int id) {
  std::vector<Probe> next = probes_;
  std::erase_if(next, [id](const Probe& p) { return p.id == id; });
  if (next.size() == probes_.size()) return;
  install(build_loop(organ_, materials_, loop_config(), next), next);
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
  if (!p || !p->host_fed) return;
  p->placed = true;
  p->anchor = anchor;
  p->normal = normal.normalized();
  p->depth = std::clamp(depth, 0.0, max_depth());
  p->tip = p->anchor - p->depth * p->normal;
  feed(*p);
}

void Workbench::set_depth(int id, double depth) {
  Probe* p = probe(id);
  if (!p || !p->host_fed) return;
  p->depth = std::clamp(depth, 0.0, max_depth());
  p->tip = p->anchor - p->depth * p->normal;
  feed(*p);
}

void Workbench::reenable(int id) {
  for (std::size_t i = 0; i < probes_.size(); ++i) {
    Probe& p = probes_[i];
    if (p.id != id) continue;
    p.wants_output = true;
    p.fault_text.clear();
    if (loop_ && p.force_output) loop_->enable(i);
  }
}

// ---------------------------------------------------------------------------
// The loop's state for the window.
void Workbench::update() {
  if (!loop_) return;
  const haptics::LoopView v = loop_->view();
  if (v.tick > 0) time_ = v.time - epoch_;
  const std::size_t n = std::min<std::size_t>(v.probe_count, probes_.size());
  for (std::size_t i = 0; i < n; ++i) {
    const haptics::ProbeTickResult& r = v.probes[i];
    Probe& p = probes_[i];
    p.output.force = haptics::to_vec(r.force_world);
    p.output.in_contact = r.in_contact != 0;
    p.output.depth = r.depth;
    p.output.flags = r.flags;
    p.output.fault = static_cast<haptics::SafetyFault>(r.fault);
    p.output.enabled = r.enabled != 0;
    if (!p.host_fed) {
      // Device probes: where the loop put them (once the device reads).
      p.placed = (r.sample.status & PALPA_STATUS_VALID) != 0;
      p.tip = haptics::to_vec(r.world);
    }
    // A latched fault stays shown (and output off, across rebuilds) until re-enabled.
    if (p.output.fault != haptics::SafetyFault::None && p.fault_text.empty()) {
      p.fault_text = haptics::to_string(p.output.fault);
      p.wants_output = false;
    }
  }
}

std::vector<IndexRange> Workbench::take_surface_changes(std::vector<float>& stream) {
  if (!loop_) return {};
  return loop_->take_surface_changes(stream);
}

void Workbench::reset() {
  for (Probe& p : probes_) {
    if (p.host_fed) p.depth = 0;
    p.output = {};
  }
  std::vector<Probe> next = probes_;
  install(build_loop(organ_, materials_, loop_config(), next), next);
}

haptics::LoopView Workbench::view() const { return loop_ ? loop_->view() : haptics::LoopView{}; }
haptics::LoopStatistics Workbench::statistics() const {
  return loop_ ? loop_->statistics() : haptics::LoopStatistics{};
}

std::size_t Workbench::contact_count() const {
  return static_cast<std::size_t>(
      std::count_if(probes_.begin(), probes_.end(), [](const Probe& p) { return p.output.in_contact; }));
}

}  // namespace palpa::app
