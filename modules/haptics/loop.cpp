#include "haptics/loop.h"
#include "haptics/spin_warm.h"

#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace palpa::haptics {

namespace {

std::int64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Sleeps until the absolute CLOCK_MONOTONIC time `ns`; the last `spin_ns`
// are busy-waited for a precise start.
void mono_sleep_until(std::int64_t ns, std::int64_t spin_ns) {
  const std::int64_t wake = ns - spin_ns;
  // No system call when the wake time has passed (a short wait all spun).
  if (wake > mono_ns()) {
    timespec ts{static_cast<time_t>(wake / 1'000'000'000), static_cast<long>(wake % 1'000'000'000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
  }
  if (spin_ns > 0)
    while (mono_ns() < ns) {
#if defined(__x86_64__) || defined(__i386__)
      __builtin_ia32_pause();  // polite busy-wait
#endif
    }
}

class MonotonicClock final : public LoopClock {
 public:
  std::int64_t now_ns() override { return mono_ns(); }
  void sleep_until(std::int64_t ns, std::int64_t spin_ns) override { mono_sleep_until(ns, spin_ns); }
};

void nap_us(long us) {
  timespec ts{0, us * 1000};
  nanosleep(&ts, nullptr);
}

void pin_to_cpu(int cpu) {
  if (cpu >= 0) run_this_thread_on({cpu});
}

// Touches a stack region so the real-time loop takes no page faults on it.
void prefault_stack() {
  volatile char buf[128 * 1024];
  for (std::size_t i = 0; i < sizeof buf; i += 4096) buf[i] = 0;
}

std::string number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// The core's view of a binding: its device's specification, mapping and limits.
ProbeSetup setup_of(const ProbeBinding& b) {
  ProbeSetup s;
  s.name = b.name;
  s.spec = b.device->spec();
  s.mapping = b.mapping;
  s.safety = b.safety;
  return s;
}

}  // namespace

LoopClock& monotonic_clock() {
  static MonotonicClock clock;
  return clock;
}

void LoopConfig::validate() const {
  core.validate();
  if (realtime_priority < 1 || realtime_priority > 99)
    throw std::invalid_argument("loop configuration: realtime_priority must be in [1, 99], got " +
                                std::to_string(realtime_priority));
  if (!(std::isfinite(spin_us) && spin_us >= 0 && spin_us <= 1e6 / core.rate_hz))
    throw std::invalid_argument("loop configuration: spin_us must be in [0, one period], got " + number(spin_us));
  if (record_capacity > (std::size_t{1} << 24))
    throw std::invalid_argument("loop configuration: record_capacity must be at most 16777216, got " +
                                std::to_string(record_capacity));
}

std::vector<std::string> describe_warnings(std::uint32_t w) {
  std::vector<std::string> out;
  if (w & kWarnNoRealtime) out.push_back("the haptic thread runs without real-time priority; timing may jitter");
  if (w & kWarnDeadlineMiss) out.push_back("the haptic loop missed a deadline within the last second");
  if (w & kWarnRecordDrop) out.push_back("the session recorder did not keep up; samples were lost");
  if (w & kWarnStiffness) out.push_back("a material is stiffer than a device can render stably");
  if (w & kWarnModelLate) out.push_back("the deformation model is late; forces are withheld");
  if (w & kWarnModelDropped) out.push_back("the deformation model fell behind; steps were dropped");
  return out;
}

std::vector<std::string> describe_safety_flags(std::uint32_t f) {
  std::vector<std::string> out;
  if (f & kSafetyDisabled) out.push_back("force output disabled");
  if (f & kSafetyFaultLatched) out.push_back("fault latched: re-enable the device");
  if (f & kSafetyDeviceFault) out.push_back("device error or unplugged");
  if (f & kSafetyNonFiniteForce) out.push_back("the model produced a non-finite force");
  if (f & kSafetyNotReady) out.push_back("device not ready (homing or no reading yet)");
  if (f & kSafetyStale) out.push_back("device input is stale");
  if (f & kSafetyBadInput) out.push_back("invalid device position");
  if (f & kSafetyLoopLate) out.push_back("watchdog: the haptic loop was late");
  if (f & kSafetyModelLate) out.push_back("watchdog: the deformation model is late");
  if (f & kSafetyClutch) out.push_back("clutch engaged");
  if (f & kSafetyJump) out.push_back("the probe jumped; ramping in again");
  if (f & kSafetyClamped) out.push_back("force clamped to the device maximum");
  if (f & kSafetyRateLimited) out.push_back("force change rate-limited");
  if (f & kSafetyRamping) out.push_back("ramping in");
  return out;
}

HapticLoop::HapticLoop(std::shared_ptr<const mesh::SurfaceMesh> mesh, deform::MaterialArrays materials,
                       deform::SurfaceOptions options, LoopConfig config, std::vector<ProbeBinding> probes)
    : config_(std::move(config)) {
  config_.validate();
  if (!mesh) throw std::invalid_argument("loop configuration: no surface mesh");
  mesh_ = std::move(mesh);
  options_ = options;
  if (mesh_->vertex_count() == 0) throw std::invalid_argument("loop configuration: the surface has no vertices");
  tree_ = std::make_shared<collision::VertexTree>(*mesh_);
  init(std::move(materials), std::move(probes));
}

HapticLoop::HapticLoop(std::shared_ptr<const SessionModel> model, deform::MaterialArrays materials,
                       LoopConfig config, std::vector<ProbeBinding> probes)
    : config_(std::move(config)) {
  if (!model || !model->mesh || !model->tree) throw std::invalid_argument("loop configuration: no model");
  config_.core = model->config;
  config_.validate();
  mesh_ = model->mesh;
  tree_ = model->tree;
  options_ = model->options;
  model_ = model;
  init(std::move(materials), std::move(probes));
}

void HapticLoop::init(deform::MaterialArrays materials, std::vector<ProbeBinding> probes) {
  clock_ = config_.clock ? config_.clock : &monotonic_clock();
  if (materials.size() != mesh_->vertex_count())
    throw std::invalid_argument("loop configuration: " + std::to_string(materials.size()) + " materials for " +
                                std::to_string(mesh_->vertex_count()) + " vertices");
  if (probes.size() > kMaxProbes)
    throw std::invalid_argument("loop configuration: " + std::to_string(probes.size()) + " probes, at most " +
                                std::to_string(kMaxProbes) + " are supported");

  // Probe setups from the devices' specifications.
  std::vector<ProbeSetup> setups;
  for (std::size_t i = 0; i < probes.size(); ++i) {
    ProbeBinding& b = probes[i];
    if (b.device == nullptr || !*b.device)
      throw std::invalid_argument("loop configuration: probe " + std::to_string(i) + " has no device");
    if (b.name.empty()) b.name = b.device->label();
    setups.push_back(setup_of(b));
  }

  // The model: two identical replicas of the surface; the core on the tree.
  material_source_ = material_source_of(materials);
  replicas_[0] = std::make_unique<deform::DeformableSurface>(mesh_, materials, options_);
  replicas_[1] = std::make_unique<deform::DeformableSurface>(mesh_, std::move(materials), options_);
  const tissue::TissueField* field = nullptr;
  if (model_) {
    for (auto& r : replicas_) model_->prepare_surface(*r);
    field = model_->field.get();
    surface_field_ = field;
    if (model_->tissue_map) {
      material_source_ = MaterialSource{};
      material_source_.uniform = false;
      material_source_.tissue_map = model_->tissue_map;
    }
  }
  if (setups.empty()) {
    // A loop may start with no probe: the core needs one setup to build;
    // free its slot again at once.
    ProbeSetup placeholder;
    placeholder.name = "none";
    core_ = std::make_unique<LoopCore>(*tree_, *mesh_, config_.core, std::vector<ProbeSetup>{placeholder}, field);
    core_->apply(LoopCommand::of(LoopCommandKind::RemoveProbe, 0), 0);
  } else {
    core_ = std::make_unique<LoopCore>(*tree_, *mesh_, config_.core, std::move(setups), field);
  }
  for (std::size_t i = 0; i < probes.size(); ++i) {
    bindings_[i] = probes[i];
    used_[i] = true;
    devices_[i] = probes[i].device;
    check_stiffness(probes[i]);
  }

  // Lock-free exchange buffers, all allocated now.
  commands_ = std::make_unique<SpscQueue<Queued>>(256);
  requests_ = std::make_unique<SpscQueue<DeformRequest>>(64);
  view_ = std::make_unique<TripleBuffer<LoopView>>();
  if (config_.record_capacity > 0) {
    tick_records_ = std::make_unique<SpscQueue<TickRecord>>(config_.record_capacity);
    command_records_ = std::make_unique<SpscQueue<CommandRecord>>(std::max<std::size_t>(256, config_.record_capacity / 64));
    deform_records_ = std::make_unique<SpscQueue<DeformRecord>>(config_.record_capacity);
  }
  mailbox_ = std::make_unique<core::SurfaceMailbox>(mesh_->vertex_count());
  mailbox_->publish_all(replicas_[0]->stream());
  replicas_[0]->take_dirty_ranges();
  replicas_[1]->take_dirty_ranges();
  contact_scratch_.reserve(kMaxProbes);
}

HapticLoop::~HapticLoop() { stop(); }

std::size_t HapticLoop::probe_count() const {
  for (std::size_t i = kMaxProbes; i > 0; --i)
    if (used_[i - 1]) return i;
  return 0;
}

void HapticLoop::start() {
  if (running_.load()) return;
  for (std::size_t i = 0; i < kMaxProbes; ++i)
    if (used_[i] && !bindings_[i].device->started())
      throw std::invalid_argument("loop configuration: device " + bindings_[i].name + " is not started");
  stop_.store(false);
  haptic_ready_.store(false);
  const double t0 = static_cast<double>(clock_->now_ns()) * 1e-9;
  if (tick_ == 0) meta_[0].time = meta_[1].time = t0;
  start_time_.store(t0);
  deform_start_time_.store(t0);
  if (config_.realtime) {
    // File reads: not on the haptic thread.
    realtime_context_ = read_realtime_context();
    memory_notice_ = memory_monitor_notice(running_memory_monitors());
  }
  running_.store(true);
  deform_thread_ = std::thread([this] { deform_main(); });
  haptic_thread_ = std::thread([this] { haptic_main(); });
  while (!haptic_ready_.load(std::memory_order_acquire)) std::this_thread::yield();
}

void HapticLoop::stop() {
  if (!running_.load()) return;
  stop_.store(true);
  clock_->interrupt();
  stop_time_.store(static_cast<double>(clock_->now_ns()) * 1e-9);
  if (haptic_thread_.joinable()) haptic_thread_.join();
  if (deform_thread_.joinable()) deform_thread_.join();
  // Requests still queued: make them, so both replicas are level and every
  // recorded tick's generation exists.
  DeformRequest r;
  while (requests_->pop(r)) process(r, true);  // in order, not merged: the records stay complete
  while (backlog_size_ > 0) {
    process(backlog_[backlog_head_], true);
    backlog_head_ = (backlog_head_ + 1) % kBacklog;
    --backlog_size_;
  }
  running_.store(false);
  // Commands still queued apply at once.
  Queued q;
  while (commands_->pop(q)) apply_now(q, static_cast<double>(clock_->now_ns()) * 1e-9);
  // Zero force, expiring at once.
  PalpaForceCommand zero{};
  for (std::size_t i = 0; i < kMaxProbes; ++i)
    if (devices_[i] && devices_[i]->spec().force_dof > 0) devices_[i]->write(zero);
}

bool HapticLoop::deform_idle() const { return made_.load(std::memory_order_acquire) >= requested_.load(std::memory_order_acquire); }

bool HapticLoop::wait_applied(CommandTicket t, double timeout_s) const {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!applied(t)) {
    if (std::chrono::steady_clock::now() > until) return false;
    nap_us(100);
  }
  return true;
}

void HapticLoop::check_slot(std::size_t probe) const {
  if (probe >= kMaxProbes || !used_[probe])
    throw std::invalid_argument("loop: probe " + std::to_string(probe) + " does not exist (" +
                                std::to_string(probe_count()) + " probe slots)");
}

// Stiffness check: world stiffness k appears as k * scale * force_scale at the device.
void HapticLoop::check_stiffness(const ProbeBinding& b) {
  const auto spec = b.device->spec();
  const double k = replicas_[0]->max_stiffness();
  if (spec.force_dof > 0 && spec.max_stiffness > 0 && k * b.mapping.scale * b.mapping.force_scale > spec.max_stiffness)
    static_warnings_ |= kWarnStiffness;
}

// The device side of probe add/remove (the thread that applies the command):
// a removed probe's device gets zero force and is not read again.
void HapticLoop::bind_slot(const Queued& q) noexcept {
  const LoopCommand& c = q.command;
  if (c.probe >= kMaxProbes) return;
  if (c.kind == LoopCommandKind::AddProbe) devices_[c.probe] = q.device;
  if (c.kind == LoopCommandKind::RemoveProbe) {
    if (devices_[c.probe] && devices_[c.probe]->spec().force_dof > 0) devices_[c.probe]->write(PalpaForceCommand{});
    devices_[c.probe] = nullptr;
  }
}

// Applies a command on the calling thread (the loop is stopped).
void HapticLoop::apply_now(const Queued& q, double t) {
  const LoopCommand& c = q.command;
  bind_slot(q);
  core_->apply(c, t);
  if (command_records_ && !command_records_->push({tick_, t, c, true}))
    record_drops_.fetch_add(1, std::memory_order_relaxed);
  // Model edits reach both replicas at once (no step); the record says so,
  // so that a replay applies them at once too (Session::apply_edits_now).
  if (core_->state().pending.any()) {
    const DeformEdits edits = core_->take_pending_edits();
    for (auto& rep : replicas_) apply_deform_edits(*rep, edits);
    if (edits.tissue) {
      surface_tissue_ = edits.tissue;
      surface_field_ = edits.tissue->field.get();
    }
    const auto ranges = replicas_[current_.load()]->take_dirty_ranges();
    mailbox_->publish(replicas_[current_.load()]->stream(), ranges);
    replicas_[1 - current_.load()]->take_dirty_ranges();
  }
  applied_tick_.store(0, std::memory_order_release);
  applied_.store(q.ticket, std::memory_order_release);
}

CommandTicket HapticLoop::push(const LoopCommand& c, devices::Device* device) {
  std::lock_guard<std::mutex> lock(command_mutex_);
  Queued q{c, device, ++next_ticket_};
  if (!running_.load()) {
    apply_now(q, static_cast<double>(clock_->now_ns()) * 1e-9);
    return q.ticket;
  }
  if (!commands_->push(q)) {
    --next_ticket_;
    throw std::runtime_error("loop: command queue full (is the haptic thread running?)");
  }
  return q.ticket;
}

CommandTicket HapticLoop::enable(std::size_t probe) {
  check_slot(probe);
  return push(LoopCommand::of(LoopCommandKind::Enable, static_cast<std::uint32_t>(probe)));
}
CommandTicket HapticLoop::disable(std::size_t probe) {
  check_slot(probe);
  return push(LoopCommand::of(LoopCommandKind::Disable, static_cast<std::uint32_t>(probe)));
}
CommandTicket HapticLoop::set_clutch(std::size_t probe, bool engaged) {
  check_slot(probe);
  return push(LoopCommand::of(engaged ? LoopCommandKind::ClutchOn : LoopCommandKind::ClutchOff,
                              static_cast<std::uint32_t>(probe)));
}
CommandTicket HapticLoop::set_mapping(std::size_t probe, const DeviceMapping& m) {
  m.validate(probe < kMaxProbes && used_[probe] ? bindings_[probe].name : "probe " + std::to_string(probe));
  check_slot(probe);
  LoopCommand c = LoopCommand::of(LoopCommandKind::SetMapping, static_cast<std::uint32_t>(probe));
  c.mapping = m;
  bindings_[probe].mapping = m;
  return push(c);
}

CommandTicket HapticLoop::add_probe(const ProbeBinding& binding, std::size_t& slot) {
  ProbeBinding b = binding;
  if (b.device == nullptr || !*b.device) throw std::invalid_argument("loop: the new probe has no device");
  if (b.name.empty()) b.name = b.device->label();
  std::size_t free = kMaxProbes;
  for (std::size_t i = 0; i < kMaxProbes && free == kMaxProbes; ++i)
    if (!used_[i]) free = i;
  if (free == kMaxProbes)
    throw std::invalid_argument("loop: cannot add probe " + b.name + ": the loop drives at most " +
                                std::to_string(kMaxProbes) + " probes");
  if (running_.load() && !b.device->started())
    throw std::invalid_argument("loop: device " + b.name + " is not started");
  LoopCommand c = LoopCommand::of(LoopCommandKind::AddProbe, static_cast<std::uint32_t>(free));
  c.prepared = LoopCore::prepare(setup_of(b), config_.core);  // throws, nothing changed
  check_stiffness(b);
  bindings_[free] = b;
  used_[free] = true;
  slot = free;
  return push(c, b.device);
}

CommandTicket HapticLoop::remove_probe(std::size_t probe) {
  check_slot(probe);
  LoopCommand c = LoopCommand::of(LoopCommandKind::RemoveProbe, static_cast<std::uint32_t>(probe));
  used_[probe] = false;
  bindings_[probe] = ProbeBinding{};
  return push(c);
}

CommandTicket HapticLoop::set_shape(const deform::ShapeFunction& shape) {
  CoreConfig probe_config = config_.core;
  probe_config.shape = shape;
  probe_config.validate();
  LoopCommand c = LoopCommand::of(LoopCommandKind::SetShape);
  c.shape = shape;
  return push(c);
}

CommandTicket HapticLoop::set_force(const ForceParams& force) {
  CoreConfig probe_config = config_.core;
  probe_config.force = force;
  probe_config.validate();
  LoopCommand c = LoopCommand::of(LoopCommandKind::SetForce);
  c.force = force;
  return push(c);
}

CommandTicket HapticLoop::set_material(const deform::Material& m) {
  deform::validate_material(m, "material");
  material_source_ = MaterialSource{};
  material_source_.material = m;
  LoopCommand c = LoopCommand::of(LoopCommandKind::SetMaterial);
  c.material = m;
  return push(c);
}

CommandTicket HapticLoop::set_materials(deform::MaterialArrays materials) {
  materials.validate(mesh_->vertex_count());
  auto kept = std::make_shared<const deform::MaterialArrays>(std::move(materials));
  LoopCommand c = LoopCommand::of(LoopCommandKind::SetMaterialMap);
  c.materials = kept.get();
  {
    std::lock_guard<std::mutex> lock(command_mutex_);
    kept_maps_.push_back(kept);
  }
  material_source_ = MaterialSource{};
  material_source_.uniform = false;
  material_source_.map = kept;
  material_source_.map_ptr = kept.get();
  return push(c);
}

CommandTicket HapticLoop::reset_surface() {
  return push(LoopCommand::of(LoopCommandKind::ResetSurface));
}

CommandTicket HapticLoop::set_tissue(std::shared_ptr<const TissueModel> tissue) {
  if (!tissue) throw std::invalid_argument("loop: set_tissue without a tissue");
  validate_tissue(*tissue, mesh_->vertex_count());
  LoopCommand c = LoopCommand::of(LoopCommandKind::SetTissue);
  c.tissue = tissue.get();
  {
    std::lock_guard<std::mutex> lock(command_mutex_);
    kept_tissues_.push_back(tissue);
  }
  if (tissue->map) {
    material_source_ = MaterialSource{};
    material_source_.uniform = false;
    material_source_.tissue_map = tissue->map;
    material_source_.edited_tissue_map = true;
  }
  return push(c);
}

SessionState HapticLoop::snapshot() const {
  if (running_.load()) throw std::logic_error("loop: snapshot() needs the loop stopped");
  const deform::DeformableSurface& s = *replicas_[current_.load()];
  SessionState out;
  out.core = core_->state();
  out.surface = s.state();
  out.contacts.assign(s.contacts().begin(), s.contacts().end());
  out.tick = tick_;
  out.generation = meta_[current_.load()].generation;
  out.model_time = meta_[current_.load()].time;
  out.materials = material_source_;
  // Stopped: every command applied, its edits on both replicas.
  out.tissue = owner_among(kept_tissues_, out.core.tissue);
  out.surface_tissue = owner_among(kept_tissues_, surface_tissue_);
  if (out.core.pending.material == 3) {
    for (const auto& k : kept_tissues_)
      if (k->map.get() == out.core.pending.tissue_map) out.pending_tissue_map = k->map;
    if (!out.pending_tissue_map) out.pending_tissue_map = restored_pending_map_;
  }
  return out;
}

void HapticLoop::restore(const SessionState& st) {
  if (running_.load()) throw std::logic_error("loop: restore() needs the loop stopped");
  for (std::size_t i = 0; i < kMaxProbes; ++i)
    if (st.core.probes[i].active != used_[i])
      throw std::invalid_argument("loop: the snapshot's probe slot " + std::to_string(i) + " is " +
                                  (st.core.probes[i].active ? "used" : "free") + " but the loop's is not");
  if (st.core.tissue != st.tissue.get() || (st.core.pending.tissue && st.core.pending.tissue != st.core.tissue))
    throw std::invalid_argument("loop: the snapshot's tissue does not match its core state");
  if (st.core.pending.material == 3 && st.core.pending.tissue_map != st.pending_tissue_map.get())
    throw std::invalid_argument("loop: the snapshot's pending tissue map is not kept with it");
  if (st.tissue) validate_tissue(*st.tissue, mesh_->vertex_count());
  if (st.surface_tissue) validate_tissue(*st.surface_tissue, mesh_->vertex_count());
  const tissue::TissueField* field = st.surface_tissue ? st.surface_tissue->field.get() : model_field();
  for (auto& r : replicas_) {
    apply_material_source(*r, st.materials);
    set_field_drives(*r, field);
    r->restore(st.surface, st.contacts);
    r->take_dirty_ranges();
    r->clear_changes();  // level: the next step copies only what it changes
  }
  core_->set_state(st.core);
  tick_ = st.tick;
  meta_[0] = meta_[1] = {st.generation, st.model_time};
  material_source_ = st.materials;
  if (st.materials.map) kept_maps_.push_back(st.materials.map);
  surface_tissue_ = st.surface_tissue.get();
  surface_field_ = field;
  for (const auto& t : {st.tissue, st.surface_tissue})
    if (t && std::find(kept_tissues_.begin(), kept_tissues_.end(), t) == kept_tissues_.end()) kept_tissues_.push_back(t);
  restored_pending_map_ = st.pending_tissue_map;
  mailbox_->publish_all(replicas_[current_.load()]->stream());
}

LoopView HapticLoop::view() const {
  std::lock_guard<std::mutex> lock(view_mutex_);
  return view_->latest();
}

LoopStatistics HapticLoop::statistics() const {
  LoopStatistics s;
  s.nominal_rate_hz = config_.core.rate_hz;
  s.ticks = ticks_.load();
  // Rates over the running time (frozen once stopped).
  const double now = running_.load() ? static_cast<double>(clock_->now_ns()) * 1e-9 : stop_time_.load();
  s.elapsed_s = s.ticks ? now - start_time_.load() : 0.0;
  s.achieved_rate_hz = s.elapsed_s > 0 ? static_cast<double>(s.ticks) / s.elapsed_s : 0.0;
  s.deadline_misses = misses_.load();
  s.skipped_periods = skipped_.load();
  s.watchdog_trips = watchdog_trips_.load();
  s.model_late_ticks = model_late_.load();
  s.record_drops = record_drops_.load();
  s.tick_duration = summarize(tick_hist_);
  s.period_jitter = summarize(jitter_hist_);
  s.start_latency = summarize(latency_hist_);
  s.deform_nominal_hz = config_.core.deform_rate_hz;
  s.deform_steps = deform_steps_.load();
  const double de = now - deform_start_time_.load();
  s.deform_achieved_hz = de > 0 && s.deform_steps ? static_cast<double>(s.deform_steps) / de : 0.0;
  s.deform_overruns = deform_overruns_.load() + deform_drops_.load();
  s.deform_step = summarize(deform_hist_);
  s.realtime = realtime_.load();
  if (haptic_ready_.load(std::memory_order_acquire)) s.realtime_notice = realtime_notice_;
  return s;
}

std::vector<IndexRange> HapticLoop::take_surface_changes(std::vector<float>& stream) {
  const std::size_t n = mesh_->vertex_count();
  if (stream.size() != 4 * n) {
    stream.assign(4 * n, 0.0f);
    mailbox_->mark_all();
  }
  const auto ranges = mailbox_->begin_read();
  mailbox_->read_into(stream, ranges);
  std::vector<IndexRange> out(ranges.begin(), ranges.end());
  mailbox_->end_read();
  return out;
}

// Makes one requested step: on the replica the haptic thread is not
// reading, published; then, once the haptic thread has left the other one,
// that one gets the request's edits (materials are not copied) and is
// brought level by copying only the vertices the step changed
// (DeformableSurface::level_with): the step runs once, and the copy touches
// what changed. `stopping`: the threads are gone (no waiting).
void HapticLoop::process(const DeformRequest& r, bool stopping) {
  const std::int64_t t0 = clock_->now_ns();
  const int cur = current_.load(std::memory_order_seq_cst);
  const int other = 1 - cur;
  apply_deform_request(*replicas_[other], r, contact_scratch_, surface_field_);
  if (r.edits.tissue) {
    surface_tissue_ = r.edits.tissue;
    surface_field_ = r.edits.tissue->field.get();
  }
  mailbox_->publish(replicas_[other]->stream(), replicas_[other]->take_dirty_ranges());
  meta_[other] = {r.generation, r.time};
  current_.store(other, std::memory_order_seq_cst);
  // The haptic thread ticks against this step from its next tick (or the
  // one after, where this came during that tick's held warm-up).
  made_tick_.store(r.tick + 1, std::memory_order_release);
  if (deform_records_) {
    DeformRecord rec;
    rec.generation = r.generation;
    rec.contacts_tick = r.tick;
    rec.time = static_cast<double>(clock_->now_ns()) * 1e-9;
    rec.dt = r.dt;
    rec.contacts = r.contacts;
    if (!deform_records_->push(rec)) record_drops_.fetch_add(1, std::memory_order_relaxed);
  }
  // Wait until the haptic thread has left the old replica, then bring it level.
  if (!stopping)
    while (in_use_.load(std::memory_order_seq_cst) == cur) nap_us(20);
  apply_deform_edits(*replicas_[cur], r.edits);
  replicas_[cur]->level_with(*replicas_[other]);
  replicas_[cur]->take_dirty_ranges();
  meta_[cur] = meta_[other];
  deform_hist_.record(clock_->now_ns() - t0);
  deform_steps_.fetch_add(1, std::memory_order_relaxed);
  made_.fetch_add(1, std::memory_order_release);
}

void HapticLoop::deform_main() {
  pin_to_cpu(config_.deform_cpu);
  deform_start_time_.store(static_cast<double>(clock_->now_ns()) * 1e-9);
  DeformRequest r, later;
  while (!stop_.load(std::memory_order_relaxed)) {
    if (!requests_->pop(r)) {
      nap_us(50);
      continue;
    }
    // Behind schedule: one step for every request waiting (their edits kept).
    std::uint64_t merged = 0;
    while (requests_->pop(later)) {
      merge_requests(r, later);
      ++merged;
    }
    if (merged) deform_overruns_.fetch_add(merged, std::memory_order_relaxed);
    process(r, false);
    if (merged) made_.fetch_add(merged, std::memory_order_release);
  }
}

void HapticLoop::haptic_main() {
  // Real-time setup: pinning, SCHED_FIFO when allowed, no timer slack, a
  // prefaulted stack.
  const int rc = prepare_haptic_thread(config_.haptic_cpu, config_.realtime ? config_.realtime_priority : 0);
  if (config_.realtime) {
    if (rc == 0) {
      realtime_.store(true);
      realtime_notice_ = "haptic thread runs with SCHED_FIFO priority " + std::to_string(config_.realtime_priority);
    } else {
      realtime_notice_ = std::string("real-time priority not available (") + std::strerror(rc) +
                         "): the haptic thread runs at normal priority and may jitter; " +
                         realtime_refused_advice(rc, config_.realtime_priority, realtime_context_);
    }
  } else {
    realtime_notice_ = "real-time priority not requested (realtime = false)";
  }
  if (config_.realtime && !memory_notice_.empty()) realtime_notice_ += "; " + memory_notice_;
  prefault_stack();

  LoopClock& clock = *clock_;
  const auto period = static_cast<std::int64_t>(std::llround(1e9 / config_.core.rate_hz));
  const auto spin = static_cast<std::int64_t>(config_.spin_us * 1e3);
  const auto watchdog = static_cast<std::int64_t>(config_.core.watchdog_periods * static_cast<double>(period));
  const double expires = config_.core.watchdog_periods / config_.core.rate_hz;
  std::array<ProbeTickInput, kMaxProbes> inputs{};
  std::array<ProbeTickResult, kMaxProbes> results{};
  ContactSet contacts;
  const std::uint32_t base_warnings = static_warnings_ | (realtime_.load() ? 0u : kWarnNoRealtime);
  // The first tick's slot is fixed before start() returns: a caller that
  // moves a manual clock right after start() then gets exactly its ticks
  // (read after the release, `next` could already include the caller's
  // first advance and that tick would never come).
  std::int64_t next = clock.now_ns() + period;
  haptic_ready_.store(true, std::memory_order_release);

  std::int64_t prev_start = -1;
  // Takes the current model replica (hazard: announce, then re-check); the
  // caller stores -1 in in_use_ when done with it.
  auto take_replica = [this] {
    int idx;
    do {
      idx = current_.load(std::memory_order_seq_cst);
      in_use_.store(idx, std::memory_order_seq_cst);
    } while (current_.load(std::memory_order_seq_cst) != idx);
    return idx;
  };
  const bool warm = spin > 0 && config_.warm_before_tick;
  while (!stop_.load(std::memory_order_relaxed)) {
    // The replica held from the last warm-up for this tick (-1: none).
    int held = -1;
    if (warm && core_->can_warm()) {
      // From the spin's start until shortly before the tick: the last tick
      // again, into scratch, on the current replica (taken and left as the
      // tick does), and again whenever the deformation thread publishes
      // another; then once more at a quarter of the spin (at most 50 us)
      // before the tick, on the replica the tick will read, which stays
      // taken until the tick is done. So the tick reads from this CPU's
      // caches, warmed moments before. A few microseconds each, on a CPU
      // that would only spin; none starts after that deadline (the held one
      // at most a look, 10 us, or half the deadline after it), so a warm-up
      // ends before its tick unless it takes longer than that.
      // One warm-up on the current replica; `keep`: it stays taken for the tick.
      auto warm_up = [&](bool keep) {
        const int warmed = take_replica();
        core_->warm_caches(*replicas_[warmed]);
        if (!keep) in_use_.store(-1, std::memory_order_seq_cst);
        warm_ups_.fetch_add(1, std::memory_order_release);
        return warmed;
      };
      held = warm_during_spin(
          clock, next, spin, [this] { return current_.load(std::memory_order_acquire); },
          [&] { return warm_up(false); }, [&] { return warm_up(true); },
          [this] { return stop_.load(std::memory_order_relaxed); });
      // Then, 10 us before the tick, what the tick reads once more: the
      // held replica's warm-up again, every device (read() copies the latest
      // sample, so an extra read changes nothing; the tick reads again) and
      // the view the tick writes. The held warm-up may be 50 us old by the
      // tick, and a virtual machine's host takes lines from a spinning CPU.
      auto touch = [&] {
        if (held >= 0) core_->warm_caches(*replicas_[held]);
        const std::size_t n = core_->probe_count();
        for (std::size_t i = 0; i < n; ++i)
          if (devices_[i] != nullptr) inputs[i].read_ok = devices_[i]->read(inputs[i].sample);
        (void)commands_->size();
        const char* view = reinterpret_cast<const char*>(&view_->write_buffer());
        const std::size_t bytes = offsetof(LoopView, probes) + n * sizeof(ProbeTickResult);
        for (std::size_t b = 0; b < bytes; b += 64) __builtin_prefetch(view + b, 1, 3);
        touches_.fetch_add(1, std::memory_order_release);
      };
      touch_before_tick(clock, next, spin, touch, [this] { return stop_.load(std::memory_order_relaxed); });
      if (stop_.load(std::memory_order_relaxed)) {
        in_use_.store(-1, std::memory_order_seq_cst);
        break;
      }
    }
    clock.sleep_until(next, spin);
    if (stop_.load(std::memory_order_relaxed)) {
      in_use_.store(-1, std::memory_order_seq_cst);
      break;
    }
    const std::int64_t start = clock.now_ns();
    const double t = static_cast<double>(start) * 1e-9;
    latency_hist_.record(start - next);
    if (prev_start >= 0) {
      const std::int64_t actual = start - prev_start;
      jitter_hist_.record(actual > period ? actual - period : period - actual);
      if (actual > watchdog) watchdog_trips_.fetch_add(1, std::memory_order_relaxed);
    }
    prev_start = start;
    const std::uint64_t tick = tick_;

    // Commands queued by other threads.
    Queued q;
    for (int k = 0; k < 16 && commands_->pop(q); ++k) {
      const LoopCommand& cmd = q.command;
      bind_slot(q);
      core_->apply(cmd, t);
      if (command_records_ && !command_records_->push({tick, t, cmd}))
        record_drops_.fetch_add(1, std::memory_order_relaxed);
      applied_tick_.store(tick + 1, std::memory_order_release);
      applied_.store(q.ticket, std::memory_order_release);
    }

    // Read every device.
    const std::size_t n = core_->probe_count();
    for (std::size_t i = 0; i < n; ++i) {
      if (devices_[i] == nullptr) continue;
      inputs[i].read_ok = devices_[i]->read(inputs[i].sample);
    }

    // The model replica: the one held from the warm-up, else the current one.
    const int idx = held >= 0 ? held : take_replica();
    const ReplicaMeta meta = meta_[idx];
    const bool due = core_->tick(tick, t, *replicas_[idx], meta.time, std::span<const ProbeTickInput>(inputs.data(), n),
                                 std::span<ProbeTickResult>(results.data(), n), contacts);
    in_use_.store(-1, std::memory_order_seq_cst);

    // Send the forces; each command expires after the watchdog time.
    std::uint32_t union_flags = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (devices_[i] == nullptr || !core_->active(i)) continue;
      union_flags |= results[i].flags;
      if (devices_[i]->spec().force_dof <= 0) continue;
      PalpaForceCommand fc{};
      for (int a = 0; a < 3; ++a) fc.force[a] = results[i].force_device[a];
      fc.time = t;
      fc.expires_after = expires;
      devices_[i]->write(fc);
    }
    if (union_flags & kSafetyModelLate) model_late_.fetch_add(1, std::memory_order_relaxed);

    // The deformation step this tick asked for (the backlog keeps order).
    while (backlog_size_ > 0 && requests_->push(backlog_[backlog_head_])) {
      backlog_head_ = (backlog_head_ + 1) % kBacklog;
      --backlog_size_;
    }
    if (due) {
      requested_.fetch_add(1, std::memory_order_release);
      if (backlog_size_ > 0 || !requests_->push(core_->request())) {
        if (backlog_size_ < kBacklog) {
          backlog_[(backlog_head_ + backlog_size_) % kBacklog] = core_->request();
          ++backlog_size_;
        } else {
          // The model is far behind: fold this step into the last one waiting.
          merge_requests(backlog_[(backlog_head_ + backlog_size_ - 1) % kBacklog], core_->request());
          deform_drops_.fetch_add(1, std::memory_order_relaxed);
          made_.fetch_add(1, std::memory_order_release);
        }
      }
    }

    // Publish the view and the record.
    LoopView& v = view_->write_buffer();
    v.tick = tick;
    v.time = t;
    v.model_generation = meta.generation;
    v.probe_count = static_cast<std::uint32_t>(n);
    v.warnings = base_warnings;
    if (t - last_miss_time_.load(std::memory_order_relaxed) < 1.0) v.warnings |= kWarnDeadlineMiss;
    if (record_drops_.load(std::memory_order_relaxed) > 0) v.warnings |= kWarnRecordDrop;
    if (deform_drops_.load(std::memory_order_relaxed) > 0) v.warnings |= kWarnModelDropped;
    if (union_flags & kSafetyModelLate) v.warnings |= kWarnModelLate;
    for (std::size_t i = 0; i < n; ++i) v.probes[i] = results[i];
    view_->publish();
    if (tick_records_) {
      TickRecord rec;
      rec.tick = tick;
      rec.time = t;
      rec.model_generation = meta.generation;
      rec.model_time = meta.time;
      rec.probe_count = static_cast<std::uint32_t>(n);
      for (std::size_t i = 0; i < n; ++i) {
        rec.inputs[i] = inputs[i];
        rec.force_device[i] = results[i].force_device;
        rec.flags[i] = results[i].flags;
      }
      if (!tick_records_->push(rec)) record_drops_.fetch_add(1, std::memory_order_relaxed);
    }

    // Timing: duration, deadline (scheduled start + period), next slot.
    ++tick_;
    const std::int64_t end = clock.now_ns();
    tick_hist_.record(end - start);
    ticks_.store(tick_, std::memory_order_release);
    const std::int64_t deadline = next + period;
    if (end > deadline) {
      misses_.fetch_add(1, std::memory_order_relaxed);
      last_miss_time_.store(t, std::memory_order_relaxed);
    }
    next += period;
    if (end > next) {
      const std::int64_t k = (end - next) / period + 1;
      next += k * period;
      skipped_.fetch_add(static_cast<std::uint64_t>(k), std::memory_order_relaxed);
    }
  }

  // Leaving: zero force on every device at once.
  PalpaForceCommand zero{};
  for (std::size_t i = 0; i < kMaxProbes; ++i)
    if (devices_[i] && devices_[i]->spec().force_dof > 0) devices_[i]->write(zero);
}

}  // namespace palpa::haptics
