// The workbench's model: probes as devices of the real-time haptic loop.

#include "app/gui/workbench.h"
#include "app/replay/session_job.h"
#include "haptics/cpu_plan.h"

#include <pthread.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string_view>

namespace palpa::app {
namespace {

constexpr double kDeformRateHz = 1000;  // deformation integration rate, Hz (the stiff materials need 1 ms steps)
// Items per record queue of the loop: 8 s of ticks at 1 kHz (about 20 MB
// for the three queues), emptied every few ms by the recorder's writer or,
// while nothing records, by the workbench's discard thread.
constexpr std::size_t kRecordCapacity = std::size_t{1} << 13;
constexpr auto kDiscardPeriod = std::chrono::milliseconds(5);  // how often the discard thread empties the queues

// CLOCK_MONOTONIC in s (steady_clock is CLOCK_MONOTONIC on Linux, like the loop's clock).
double monotonic_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

deform::Material to_material(const MaterialSettings& s) {
  if (s.law == MaterialLaw::Hertz) return tissue::hertz_material(s.tissue, s.tip_radius, s.mass);
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
  end_recording_quietly();
  // A seek snapshot pass under way stops between ticks; what it added stays.
  {
    std::lock_guard<std::mutex> lock(seek_mutex_);
    seek_stop_.store(true);
  }
  seek_cv_.notify_all();
  if (seek_thread_.joinable()) seek_thread_.join();
  stop_discarding();
  // The loop stops (zero force to every device) before the devices go.
  if (loop_) loop_->stop();
  loop_.reset();
}

// ---------------------------------------------------------------------------
// The loop: one per organ, long-lived; every other change is a command.
haptics::LoopConfig Workbench::loop_config(const MaterialSettings& m) const {
  haptics::LoopConfig c;
  c.core.rate_hz = kHapticRateHz;
  c.core.deform_rate_hz = kDeformRateHz;
  c.core.force = force_params(m);
  c.core.shape = deform::ShapeFunction{m.shape, m.radius};
  c.record_capacity = kRecordCapacity;  // so that a recording can start while the loop runs
  c.haptic_cpu = haptics::reserved_haptic_cpu();  // the CPU main() kept for it (-1: none)
  // On a CPU of its own the haptic thread spins the last part of each
  // period (PALPA_HAPTIC_SPIN; main() prints the choice).
  c.spin_us = haptics::haptic_spin(c.core.rate_hz, c.haptic_cpu).spin_us;
  // PALPA_REALTIME=off: the haptic thread does not ask for SCHED_FIFO (the
  // loop then warns that it runs without real-time priority).
  if (const char* rt = std::getenv("PALPA_REALTIME"); rt && std::string_view(rt) == "off") c.realtime = false;
  return c;
}

haptics::ForceParams Workbench::force_params(const MaterialSettings& m) {
  haptics::ForceParams f;
  f.friction = m.friction;
  f.max_force = m.max_force;
  return f;
}

haptics::ProbeBinding Workbench::binding(const Probe& p) {
  haptics::ProbeBinding b;
  b.device = p.dev.get();
  b.name = "probe " + std::to_string(p.id) + " (" + p.device + ")";
  b.mapping = p.mapping;
  return b;
}

std::unique_ptr<haptics::HapticLoop> Workbench::build_loop(const mesh::Organ& organ,
                                                           const deform::MaterialArrays& materials,
                                                           const haptics::LoopConfig& config,
                                                           const std::vector<Probe>& probes,
                                                           std::shared_ptr<const haptics::SessionModel> model) const {
  if (!organ.mesh) return nullptr;
  std::vector<haptics::ProbeBinding> bindings;
  for (const Probe& p : probes) bindings.push_back(binding(p));
  // Always on a session model: a recording names it (record::Recorder).
  if (!model) model = haptics::SessionModel::make(organ.mesh, deform::SurfaceOptions{}, config.core);
  return std::make_unique<haptics::HapticLoop>(std::move(model), materials, config, std::move(bindings));
}

// Nothing here throws once `next` is built: stop the old loop, swap, start.
// The mouse devices are fed the probes' current state before the new loop
// starts, so its first ticks never read a position from before the change.
void Workbench::install(std::unique_ptr<haptics::HapticLoop> next, std::vector<Probe>& probes) {
  end_recording_quietly();  // a recording belongs to its loop
  stop_discarding();
  suspended_ = false;
  if (loop_) loop_->stop();
  std::swap(loop_, next);
  std::swap(probes_, probes);
  next.reset();  // the old loop goes before the devices only it used (in `probes`)
  for (std::size_t i = 0; i < probes_.size(); ++i) {
    probes_[i].slot = i;
    probes_[i].output = {};
  }
  loop_time_ = monotonic_now();  // the loop's clock: its first tick is about now
  for (const Probe& p : probes_) feed(p);
  if (!loop_) return;
  loop_->start();
  start_discarding();
  for (const Probe& p : probes_)
    if (p.force_output && p.wants_output) last_ticket_ = loop_->enable(p.slot);
}

// ---------------------------------------------------------------------------
// Recording.
void Workbench::start_discarding() {
  if (!loop_ || discard_thread_.joinable()) return;
  discard_stop_.store(false);
  haptics::HapticLoop* loop = loop_.get();
  discard_thread_ = std::thread([this, loop] {
    haptics::TickRecord t;
    haptics::CommandRecord c;
    haptics::DeformRecord d;
    while (!discard_stop_.load(std::memory_order_acquire)) {
      if (auto* q = loop->tick_records())
        while (q->pop(t)) {
        }
      if (auto* q = loop->command_records())
        while (q->pop(c)) {
        }
      if (auto* q = loop->deform_records())
        while (q->pop(d)) {
        }
      std::this_thread::sleep_for(kDiscardPeriod);
    }
  });
}

void Workbench::stop_discarding() {
  if (!discard_thread_.joinable()) return;
  discard_stop_.store(true, std::memory_order_release);
  discard_thread_.join();
}

std::filesystem::path Workbench::recording_file() const { return recorder_ ? recorder_->file() : std::filesystem::path(); }

record::RecorderStats Workbench::recording_stats() const { return recorder_ ? recorder_->stats() : record::RecorderStats{}; }

// The recording starts from a snapshot of the running loop: its threads
// stop (both replicas level, every queued command applied), the state is
// copied, and they go on where they stopped. The records the loop queues
// from then on wait in its queues (8 s of room) while the recorder writes
// the file's set-up, then its writer drains them.
void Workbench::start_recording(const std::filesystem::path& file, const std::string& trainee) {
  if (!loop_) throw std::logic_error("cannot record: no organ is loaded");
  if (recorder_) throw std::logic_error("cannot record: a recording is running (" + recorder_->file().string() + ")");
  if (suspended_) throw std::logic_error("cannot record during a replay; leave the replay first");
  if (!loop_->model()) throw std::logic_error("cannot record: the loop has no session model");
  record::SessionInfo info;
  info.trainee = trainee;
  info.organ = organ_.name;
  if (scenario_) {
    const std::filesystem::path sc = std::filesystem::absolute(scenario_->scenario.file);
    info.scenario_file = sc.string();
    if (scenario_edited_) {
      // Edited since it was opened: the scenario as it runs now (its lesions
      // are what an assessment of the recording grades against).
      info.scenario_json = scenario::to_json_text(scenario_->scenario);
    } else {
      std::ifstream in(sc, std::ios::binary);
      std::ostringstream text;
      text << in.rdbuf();
      info.scenario_json = text.str();
    }
    info.force_limit = scenario_->scenario.task.force_limit;
  }
  const deform::MaterialArrays initial = materials();

  // The snapshot: the loop's threads pause for it (milliseconds).
  stop_discarding();
  const auto paused = std::chrono::steady_clock::now();
  loop_->stop();
  haptics::TickRecord t;
  haptics::CommandRecord c;
  haptics::DeformRecord d;
  // Records from before the recording are not part of it.
  if (auto* q = loop_->tick_records())
    while (q->pop(t)) {
    }
  if (auto* q = loop_->command_records())
    while (q->pop(c)) {
    }
  if (auto* q = loop_->deform_records())
    while (q->pop(d)) {
    }
  haptics::SessionState state;
  std::vector<haptics::ProbeSetup> setups;
  try {
    state = loop_->snapshot();
    setups = loop_->setups();
  } catch (...) {
    loop_->start();
    start_discarding();
    throw;
  }
  loop_->start();
  record_pause_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - paused).count();

  std::unique_ptr<record::Recorder> r;
  try {
    r = std::make_unique<record::Recorder>(file, *loop_->model(), initial, setups, info);
    r->snapshot(state);
  } catch (...) {
    r.reset();
    start_discarding();  // the records queued meanwhile are dropped with the rest
    throw;
  }
  r->attach(*loop_);
  recorder_ = std::move(r);
  record_start_time_ = loop_time_;
  recorded_warnings_ = 0;  // warnings on now are events of this session too
}

std::filesystem::path Workbench::stop_recording() {
  if (!recorder_) return {};
  std::unique_ptr<record::Recorder> r = std::move(recorder_);
  const std::filesystem::path file = r->file();
  struct Resume {  // the discard thread takes the queues again, whatever happens
    Workbench& w;
    record::Recorder& r;
    ~Resume() {
      r.detach();
      w.start_discarding();
    }
  };
  {
    Resume resume{*this, *r};
    r->finish();  // throws RecordError when its writer failed
  }
  if (seek_snapshot_interval_ > 0) {
    {
      std::lock_guard<std::mutex> lock(seek_mutex_);
      seek_queue_.emplace_back(file, seek_snapshot_interval_);
    }
    if (!seek_thread_.joinable()) seek_thread_ = std::thread([this] { seek_snapshot_worker(); });
    seek_cv_.notify_one();
  }
  return file;
}

void Workbench::set_seek_snapshot_interval(double seconds) {
  if (!(seconds >= 0) || !std::isfinite(seconds))
    throw std::invalid_argument("seek snapshot interval: expected a time >= 0 s, got " + std::to_string(seconds));
  seek_snapshot_interval_ = seconds;
}

bool Workbench::adding_seek_snapshots() const {
  std::lock_guard<std::mutex> lock(seek_mutex_);
  return seek_busy_ || !seek_queue_.empty();
}

void Workbench::seek_snapshot_worker() {
  pthread_setname_np(pthread_self(), "palpa-seek-snap");
  // Behind the loop's threads and the window: a replay at full speed is not urgent.
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
  std::unique_lock<std::mutex> lock(seek_mutex_);
  for (;;) {
    seek_cv_.wait(lock, [&] { return seek_stop_.load() || !seek_queue_.empty(); });
    if (seek_stop_.load()) return;
    const auto [file, interval] = seek_queue_.front();
    seek_queue_.pop_front();
    seek_busy_ = true;
    lock.unlock();
    try {
      add_seek_snapshots(file.string(), interval, &seek_stop_);
    } catch (const std::exception& e) {
      // The recording itself is whole; only seeking far into it stays slower.
      // (The errors name the file.)
      std::fprintf(stderr, "palpa: seek snapshots not all added: %s\n", e.what());
    }
    lock.lock();
    seek_busy_ = false;
  }
}

void Workbench::end_recording_quietly() noexcept {
  try {
    stop_recording();
  } catch (...) {
    recorder_.reset();
  }
}

void Workbench::suspend() {
  if (recorder_) throw std::logic_error("cannot replay while recording; stop the recording first");
  if (suspended_ || !loop_) return;
  loop_->stop();
  suspended_ = true;
}

void Workbench::resume() {
  if (!suspended_) return;
  suspended_ = false;
  if (!loop_) return;
  for (const Probe& p : probes_) feed(p);
  loop_->start();
}

bool Workbench::settled() const { return !loop_ || loop_->in_effect(last_ticket_); }

std::shared_ptr<const tissue::TissueField> Workbench::field() const {
  return scenario_ ? scenario_->field : nullptr;
}

Vec3 Workbench::to_world(const Vec3& x) const {
  const auto f = field();
  return f ? f->to_world(x, loop_time_) : x;
}

// Mouse probes: the tip pressed `depth` below the anchor, or held just above
// it when lifted (organ frame), carried where the breathing organ is at the
// loop's time.
Vec3 Workbench::fed_tip(const Probe& p) const {
  return to_world(p.depth > 0 ? Vec3(p.anchor - p.depth * p.normal) : Vec3(p.anchor + kLiftClearance * p.normal));
}

// An unplaced probe reports "not ready" (parked by the loop).
void Workbench::feed(const Probe& p) const {
  if (!p.host_fed || !p.dev) return;
  PalpaDeviceSample s{};
  s.orientation[0] = 1;
  if (!p.placed) {
    s.status = PALPA_STATUS_NOT_READY;
  } else {
    const Vec3 tip = fed_tip(p);
    for (int k = 0; k < 3; ++k) s.position[k] = tip[k];
    s.status = PALPA_STATUS_VALID;
  }
  p.dev->feed(s);
}

// ---------------------------------------------------------------------------
// Organ and material.
std::vector<Probe> Workbench::unplaced_probes() const {
  std::vector<Probe> next = probes_;
  for (Probe& p : next)
    if (p.host_fed) {
      p.placed = false;
      p.depth = 0;
    }
  return next;
}

void Workbench::set_organ(mesh::Organ organ) {
  // Build everything first, then swap (nothing changes on a throw).
  auto materials = deform::MaterialArrays::uniform(organ.mesh->vertex_count(), to_material(material_));
  std::vector<Probe> next = unplaced_probes();
  auto loop = build_loop(organ, materials, loop_config(), next);
  organ_ = std::move(organ);
  scenario_.reset();
  map_in_force_ = false;
  install(std::move(loop), next);
  epoch_ = monotonic_now();
  time_ = 0;
}

// A scenario: the loop on its session model (tissue map and field), the
// settings from its base tissue and probe. Everything is built before
// anything is replaced.
void Workbench::set_scenario(scenario::Resolved resolved) {
  if (!resolved.organ.mesh) throw std::invalid_argument("scenario: no organ");
  const scenario::Scenario& sc = resolved.scenario;
  if (resolved.base >= sc.tissues.size() || resolved.base >= resolved.tissues.size())
    throw std::invalid_argument("scenario: base tissue index out of range");
  MaterialSettings m = material_;
  m.law = MaterialLaw::Hertz;
  m.tissue = sc.tissues[resolved.base];
  m.tip_radius = sc.probe.tip_radius;
  m.mass = tissue::kDefaultVertexMass;
  m.shape = sc.probe.shape.kind;
  m.radius = sc.probe.shape.radius;
  haptics::LoopConfig config = loop_config(m);
  config.core = scenario::core_config(resolved, kHapticRateHz, kDeformRateHz);
  m.shape = config.core.shape.kind;
  m.radius = config.core.shape.radius;
  m.friction = config.core.force.friction;
  m.max_force = config.core.force.max_force;
  auto model = scenario::session_model(resolved, config.core);
  // The initial materials: the base tissue everywhere (the model's tissue map replaces them).
  auto materials =
      deform::MaterialArrays::uniform(resolved.organ.mesh->vertex_count(), resolved.tissues[resolved.base]);
  std::vector<Probe> next = unplaced_probes();
  auto loop = build_loop(resolved.organ, materials, config, next, std::move(model));
  auto kept = std::make_unique<const scenario::Resolved>(std::move(resolved));
  // Nothing below throws.
  organ_ = kept->organ;
  scenario_ = std::move(kept);
  map_in_force_ = true;
  scenario_edited_ = false;
  material_ = m;
  install(std::move(loop), next);
  epoch_ = monotonic_now();
  time_ = 0;
}

// An edit of the running scenario: resolved and checked first (strong
// guarantee), then commands to the same loop; the dent, the probes, the
// tick count and any recording go on.
void Workbench::edit_scenario(scenario::Scenario edited) {
  if (!scenario_) throw std::logic_error("cannot edit the scenario: no scenario is running");
  const scenario::OrganRef& now = scenario_->scenario.organ;
  if (edited.organ.path != now.path || edited.organ.unit != now.unit)
    throw std::invalid_argument("cannot edit the scenario: its organ (" + edited.organ.path + ", " + edited.organ.unit +
                                ") is not the running one (" + now.path + ", " + now.unit +
                                "); open it as a new scenario");
  scenario::Resolved r = scenario::resolve_on(edited, scenario_->organ);  // throws ScenarioError
  const scenario::Scenario& sc = r.scenario;
  const std::string file = sc.file.empty() ? std::string("scenario") : sc.file.string();
  if (r.base >= sc.tissues.size() || r.base >= r.tissues.size())
    throw scenario::ScenarioError(file, "/base_tissue", "base tissue index out of range");
  haptics::CoreConfig config = scenario::core_config(r, kHapticRateHz, kDeformRateHz);
  try {
    config.validate();
  } catch (const std::invalid_argument& e) {
    throw scenario::ScenarioError(file, "/probe", e.what());
  }
  auto tissue = scenario::tissue_model(r);
  try {
    haptics::validate_tissue(*tissue, organ_.mesh->vertex_count());
  } catch (const std::invalid_argument& e) {
    throw scenario::ScenarioError(file, "/", e.what());
  }
  MaterialSettings m = material_;
  m.law = MaterialLaw::Hertz;
  m.tissue = sc.tissues[r.base];
  m.tip_radius = sc.probe.tip_radius;
  m.mass = tissue::kDefaultVertexMass;
  m.shape = config.shape.kind;
  m.radius = config.shape.radius;
  m.friction = config.force.friction;
  m.max_force = config.force.max_force;

  // Everything is checked: the commands (SetTissue first, so the shape and
  // force edits of the same moment apply with it).
  if (loop_) {
    last_ticket_ = loop_->set_tissue(tissue);
    if (m.shape != material_.shape || m.radius != material_.radius) last_ticket_ = loop_->set_shape(config.shape);
    if (m.friction != material_.friction || m.max_force != material_.max_force)
      last_ticket_ = loop_->set_force(config.force);
  }
  scenario_ = std::make_unique<const scenario::Resolved>(std::move(r));
  map_in_force_ = true;
  scenario_edited_ = true;
  material_ = m;
  for (Probe& p : probes_)
    if (p.host_fed && p.depth > max_depth()) set_depth(p.id, max_depth());
}

scenario::Resolved Workbench::resolve_scenario(const std::filesystem::path& file) {
  try {
    return scenario::resolve(scenario::load_scenario(file));
  } catch (const scenario::ScenarioError&) {
    throw;
  } catch (const std::exception& e) {
    // Name the scenario (an organ that does not load names only the organ file).
    throw std::runtime_error(file.string() + ": " + e.what());
  }
}

void Workbench::open_scenario(const std::filesystem::path& file) {
  scenario::Resolved r = resolve_scenario(file);
  try {
    set_scenario(std::move(r));
  } catch (const std::exception& e) {
    throw std::runtime_error(file.string() + ": " + e.what());
  }
}

// Undo of a uniform edit: the scenario's tissue map, vertex by vertex.
void Workbench::restore_tissue_map() {
  if (!scenario_ || map_in_force_ || !scenario_->materials) return;
  const deform::MaterialMap& map = *scenario_->materials;
  deform::MaterialArrays arrays = deform::MaterialArrays::uniform(map.tissue_of.size(), map.tissues.at(0));
  for (Index i = 0; i < map.tissue_of.size(); ++i)
    arrays.set(i, map.scale.empty() ? map.tissues[map.tissue_of[i]]
                                    : deform::scaled(map.tissues[map.tissue_of[i]], map.scale[i]));
  MaterialSettings m = material_;
  m.law = MaterialLaw::Hertz;
  m.tissue = scenario_->scenario.tissues[scenario_->base];
  m.tip_radius = scenario_->scenario.probe.tip_radius;
  m.mass = tissue::kDefaultVertexMass;
  if (loop_) last_ticket_ = loop_->set_materials(std::move(arrays));  // throws before anything changed
  material_ = m;
  map_in_force_ = true;
}

// Edits of the running loop: validated first (strong guarantee), then sent
// as commands; the dent and every probe stay where they are.
void Workbench::set_material(const MaterialSettings& m) {
  const deform::Material material = to_material(m);
  deform::validate_material(material, "material");
  haptics::CoreConfig check = loop_config().core;
  check.force = force_params(m);
  check.shape = deform::ShapeFunction{m.shape, m.radius};
  check.validate();
  const MaterialSettings old = material_;
  material_ = m;
  for (Probe& p : probes_)
    if (p.host_fed && p.depth > max_depth()) set_depth(p.id, max_depth());
  if (!(to_material(old) == material)) map_in_force_ = false;  // one material replaces a scenario's map
  if (!loop_) return;
  if (!(to_material(old) == material)) last_ticket_ = loop_->set_material(material);
  if (old.shape != m.shape || old.radius != m.radius) last_ticket_ = loop_->set_shape(check.shape);
  if (old.friction != m.friction || old.max_force != m.max_force) last_ticket_ = loop_->set_force(check.force);
}

deform::MaterialArrays Workbench::materials() const {
  if (!has_organ()) return {};
  if (tissue_map_in_force() && scenario_->materials) {
    const deform::MaterialMap& map = *scenario_->materials;
    deform::MaterialArrays arrays = deform::MaterialArrays::uniform(map.tissue_of.size(), map.tissues.at(0));
    for (Index i = 0; i < map.tissue_of.size(); ++i)
      arrays.set(i, map.scale.empty() ? map.tissues[map.tissue_of[i]]
                                      : deform::scaled(map.tissues[map.tissue_of[i]], map.scale[i]));
    return arrays;
  }
  return deform::MaterialArrays::uniform(organ_.mesh->vertex_count(), to_material(material_));
}

// ---------------------------------------------------------------------------
// Probes.
int Workbench::add(Probe p) {
  if (probes_.size() >= haptics::kMaxProbes)
    throw std::invalid_argument("cannot add probe: the haptic loop drives at most " +
                                std::to_string(haptics::kMaxProbes) + " probes");
  p.id = next_id_;
  if (loop_) {
    std::size_t slot = 0;
    last_ticket_ = loop_->add_probe(binding(p), slot);  // throws, nothing changed
    p.slot = slot;
    feed(p);
    if (p.force_output && p.wants_output) last_ticket_ = loop_->enable(slot);
  }
  probes_.push_back(std::move(p));
  ++next_id_;
  selected_ = probes_.back().id;
  return probes_.back().id;
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
  const auto it = std::find_if(probes_.begin(), probes_.end(), [id](const Probe& p) { return p.id == id; });
  if (it == probes_.end()) return;
  if (loop_) {
    const haptics::CommandTicket t = loop_->remove_probe(it->slot);
    last_ticket_ = t;
    // The device goes once the haptic thread no longer reads it.
    if (!loop_->wait_applied(t, 1.0)) retired_.push_back(it->dev);
  }
  probes_.erase(it);
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
  p->tip = to_world(p->anchor - p->depth * p->normal);
  feed(*p);
}

void Workbench::set_depth(int id, double depth) {
  Probe* p = probe(id);
  if (!p || !p->host_fed) return;
  p->depth = std::clamp(depth, 0.0, max_depth());
  p->tip = to_world(p->anchor - p->depth * p->normal);
  feed(*p);
}

void Workbench::reenable(int id) {
  Probe* p = probe(id);
  if (!p) return;
  p->wants_output = true;
  p->fault_text.clear();
  if (loop_ && p->force_output) last_ticket_ = loop_->enable(p->slot);
}

// ---------------------------------------------------------------------------
// The loop's state for the window.
void Workbench::update() {
  if (!loop_) return;
  const haptics::LoopView v = loop_->view();
  if (v.tick > 0) {
    time_ = v.time - epoch_;
    loop_time_ = v.time;
    loop_tick_ = v.tick;
  }
  // A loop warning that comes on while recording is an event of the session
  // (value: the LoopWarning bits that came on; text: what they say).
  if (recorder_ && v.tick > 0) {
    const std::uint32_t risen = v.warnings & ~recorded_warnings_;
    if (risen != 0) {
      std::string text;
      for (const std::string& w : haptics::describe_warnings(risen)) text += (text.empty() ? "" : "; ") + w;
      record::EventRecord e = record::EventRecord::make(record::EventKind::Warning, v.tick, v.time, text);
      e.value = static_cast<double>(risen);
      recorder_->push_event(e);
    }
    recorded_warnings_ = v.warnings;
  }
  // A breathing organ moves: every placed mouse probe's tip follows it.
  if (field() && field()->breathing.enabled)
    for (Probe& p : probes_)
      if (p.host_fed && p.placed) {
        p.tip = to_world(p.anchor - p.depth * p.normal);
        feed(p);
      }
  for (Probe& p : probes_) {
    if (p.slot >= v.probe_count) continue;
    const haptics::ProbeTickResult& r = v.probes[p.slot];
    p.output.force = haptics::to_vec(r.force_world);
    p.output.in_contact = r.in_contact != 0;
    p.output.depth = r.depth;
    p.output.flags = r.flags;
    p.output.fault = static_cast<haptics::SafetyFault>(r.fault);
    p.output.enabled = r.enabled != 0;
    p.output.contact_point = haptics::to_vec(r.contact_point);
    p.output.contact_normal = haptics::to_vec(r.contact_normal);
    p.output.normal_force = r.in_contact ? std::abs(p.output.force.dot(p.output.contact_normal)) : 0.0;
    p.output.buttons = r.sample.buttons;
    if (!p.host_fed) {
      // Device probes: where the loop put them (once the device reads).
      p.placed = (r.sample.status & PALPA_STATUS_VALID) != 0;
      p.tip = haptics::to_vec(r.world);
    }
    // A latched fault stays shown (and output off) until re-enabled.
    if (p.output.fault != haptics::SafetyFault::None && p.fault_text.empty()) {
      p.fault_text = haptics::to_string(p.output.fault);
      p.wants_output = false;
    }
  }
}

std::optional<Vec3> Workbench::finding_point(int id) const {
  for (const Probe& p : probes_) {
    if (p.id != id) continue;
    if (!p.placed) return std::nullopt;
    if (p.output.in_contact) return p.output.contact_point;
    const auto f = field();
    return f ? f->to_organ(p.tip, loop_time_) : p.tip;
  }
  return std::nullopt;
}

bool Workbench::record_event(record::EventRecord e) {
  if (!recorder_) return false;
  e.tick = loop_tick_;
  e.time = loop_time_;
  return recorder_->push_event(e);
}

std::vector<IndexRange> Workbench::take_surface_changes(std::vector<float>& stream) {
  if (!loop_) return {};
  return loop_->take_surface_changes(stream);
}

bool Workbench::pull_surface(
    const std::function<void(std::span<const float>, std::span<const IndexRange>)>& sink, bool everything) {
  if (!loop_) return false;
  core::SurfaceMailbox& box = loop_->surface_changes();
  if (everything) box.mark_all();
  const auto ranges = box.begin_read();
  if (pulled_.size() != 4 * box.vertex_count()) pulled_.assign(4 * box.vertex_count(), 0.0f);
  box.read_into(pulled_, ranges);
  sink(pulled_, ranges);
  box.end_read();
  return true;
}

void Workbench::reset() {
  for (Probe& p : probes_) {
    if (p.host_fed) {
      p.depth = 0;
      if (p.placed) p.tip = to_world(p.anchor + kLiftClearance * p.normal);
      feed(p);
    }
    p.output = {};
  }
  if (loop_) last_ticket_ = loop_->reset_surface();
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
