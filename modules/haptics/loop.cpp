#include "haptics/loop.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace palpa::haptics {

namespace {

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Sleeps until the absolute CLOCK_MONOTONIC time `ns`; the last `spin_ns`
// are busy-waited for a precise start.
void sleep_until(std::int64_t ns, std::int64_t spin_ns) {
  const std::int64_t wake = ns - spin_ns;
  timespec ts{static_cast<time_t>(wake / 1'000'000'000), static_cast<long>(wake % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
  if (spin_ns > 0)
    while (now_ns() < ns) {
#if defined(__x86_64__) || defined(__i386__)
      __builtin_ia32_pause();  // polite busy-wait
#endif
    }
}

void pin_to_cpu(int cpu) {
  if (cpu < 0) return;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  pthread_setaffinity_np(pthread_self(), sizeof set, &set);
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

// Largest small-strain stiffness of the material map (N/m); the Maxwell arm
// adds k2 at high frequency.
double max_stiffness(const deform::MaterialArrays& m) {
  double k = 0;
  for (std::size_t i = 0; i < m.size(); ++i) {
    double ki = m.stiffness[i];
    if (m.model[i] == deform::LocalModelKind::Viscoelastic) ki += m.k2[i];
    k = std::max(k, ki);
  }
  return k;
}

}  // namespace

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
    : config_(std::move(config)), mesh_(std::move(mesh)), probes_(std::move(probes)) {
  config_.validate();
  if (!mesh_) throw std::invalid_argument("loop configuration: no surface mesh");
  if (materials.size() != mesh_->vertex_count())
    throw std::invalid_argument("loop configuration: " + std::to_string(materials.size()) + " materials for " +
                                std::to_string(mesh_->vertex_count()) + " vertices");

  // Probe setups from the devices' specifications.
  std::vector<ProbeSetup> setups;
  for (std::size_t i = 0; i < probes_.size(); ++i) {
    ProbeBinding& b = probes_[i];
    if (b.device == nullptr || !*b.device)
      throw std::invalid_argument("loop configuration: probe " + std::to_string(i) + " has no device");
    if (b.name.empty()) b.name = b.device->label();
    ProbeSetup s;
    s.name = b.name;
    s.spec = b.device->spec();
    s.mapping = b.mapping;
    s.safety = b.safety;
    setups.push_back(s);
  }

  // The model: one vertex tree, two identical replicas of the surface.
  tree_ = std::make_unique<collision::VertexTree>(std::span<const Vec3>(mesh_->positions));
  replicas_[0] = std::make_unique<deform::DeformableSurface>(mesh_, materials, options);
  replicas_[1] = std::make_unique<deform::DeformableSurface>(mesh_, std::move(materials), options);
  core_ = std::make_unique<LoopCore>(*tree_, *mesh_, config_.core, std::move(setups));

  // Stiffness check: world stiffness k appears as k * scale * force_scale at the device.
  const double k = max_stiffness(replicas_[0]->materials());
  for (const auto& s : core_->setups())
    if (s.spec.force_dof > 0 && s.spec.max_stiffness > 0 &&
        k * s.mapping.scale * s.mapping.force_scale > s.spec.max_stiffness)
      static_warnings_ |= kWarnStiffness;

  // Lock-free exchange buffers, all allocated now.
  commands_ = std::make_unique<SpscQueue<LoopCommand>>(256);
  view_ = std::make_unique<TripleBuffer<LoopView>>();
  contacts_ = std::make_unique<TripleBuffer<ContactSet>>();
  if (config_.record_capacity > 0) {
    tick_records_ = std::make_unique<SpscQueue<TickRecord>>(config_.record_capacity);
    command_records_ = std::make_unique<SpscQueue<CommandRecord>>(std::max<std::size_t>(256, config_.record_capacity / 64));
    deform_records_ = std::make_unique<SpscQueue<DeformRecord>>(config_.record_capacity);
  }
  const auto s = replicas_[0]->stream();
  render_stream_.assign(s.begin(), s.end());
  replicas_[0]->take_dirty_ranges();
  replicas_[1]->take_dirty_ranges();
}

HapticLoop::~HapticLoop() { stop(); }

void HapticLoop::start() {
  if (running_.load()) return;
  for (const auto& b : probes_)
    if (!b.device->started())
      throw std::invalid_argument("loop configuration: device " + b.name + " is not started");
  stop_.store(false);
  haptic_ready_.store(false);
  const double t0 = static_cast<double>(now_ns()) * 1e-9;
  meta_[0].time = meta_[1].time = t0;
  start_time_.store(t0);
  deform_start_time_.store(t0);
  running_.store(true);
  if (config_.core.deform_rate_hz > 0) deform_thread_ = std::thread([this] { deform_main(); });
  haptic_thread_ = std::thread([this] { haptic_main(); });
  while (!haptic_ready_.load(std::memory_order_acquire)) std::this_thread::yield();
}

void HapticLoop::stop() {
  if (!running_.load()) return;
  stop_.store(true);
  stop_time_.store(static_cast<double>(now_ns()) * 1e-9);
  if (haptic_thread_.joinable()) haptic_thread_.join();
  if (deform_thread_.joinable()) deform_thread_.join();
  // Bring the replicas level if the deformation thread stopped half-way.
  if (pending_.valid) {
    step_replica(pending_.index, pending_.contacts, pending_.dt);
    replicas_[pending_.index]->take_dirty_ranges();
    pending_.valid = false;
  }
  running_.store(false);
  // Zero force, expiring at once.
  PalpaForceCommand zero{};
  for (const auto& b : probes_)
    if (b.device->spec().force_dof > 0) b.device->write(zero);
}

void HapticLoop::push_command(const LoopCommand& c) {
  if (c.probe >= probes_.size())
    throw std::invalid_argument("loop: probe " + std::to_string(c.probe) + " does not exist (" +
                                std::to_string(probes_.size()) + " probes)");
  std::lock_guard<std::mutex> lock(command_mutex_);
  if (!commands_->push(c)) throw std::runtime_error("loop: command queue full (is the haptic thread running?)");
}

void HapticLoop::enable(std::size_t probe) {
  push_command({LoopCommandKind::Enable, static_cast<std::uint32_t>(probe), {}});
}
void HapticLoop::disable(std::size_t probe) {
  push_command({LoopCommandKind::Disable, static_cast<std::uint32_t>(probe), {}});
}
void HapticLoop::set_clutch(std::size_t probe, bool engaged) {
  push_command({engaged ? LoopCommandKind::ClutchOn : LoopCommandKind::ClutchOff, static_cast<std::uint32_t>(probe),
                {}});
}
void HapticLoop::set_mapping(std::size_t probe, const DeviceMapping& m) {
  m.validate(probe < probes_.size() ? probes_[probe].name : "probe " + std::to_string(probe));
  push_command({LoopCommandKind::SetMapping, static_cast<std::uint32_t>(probe), m});
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
  const double now = running_.load() ? static_cast<double>(now_ns()) * 1e-9 : stop_time_.load();
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
  s.deform_overruns = deform_overruns_.load();
  s.deform_step = summarize(deform_hist_);
  s.realtime = realtime_.load();
  if (haptic_ready_.load(std::memory_order_acquire)) s.realtime_notice = realtime_notice_;
  return s;
}

std::vector<IndexRange> HapticLoop::take_surface_changes(std::vector<float>& stream) {
  std::lock_guard<std::mutex> lock(render_mutex_);
  std::vector<IndexRange> ranges;
  if (render_first_ || stream.size() != render_stream_.size()) {
    // First call (or a fresh buffer): everything.
    stream = render_stream_;
    render_first_ = false;
    render_ranges_.clear();
    ranges.push_back({0, static_cast<Index>(render_stream_.size() / 4)});
    return ranges;
  }
  // Sort and merge the pending ranges, then copy their entries.
  std::sort(render_ranges_.begin(), render_ranges_.end(),
            [](const IndexRange& a, const IndexRange& b) { return a.begin < b.begin; });
  for (const auto& r : render_ranges_) {
    if (!ranges.empty() && r.begin <= ranges.back().end)
      ranges.back().end = std::max(ranges.back().end, r.end);
    else
      ranges.push_back(r);
  }
  for (const auto& r : ranges)
    std::copy(render_stream_.begin() + 4 * std::size_t{r.begin}, render_stream_.begin() + 4 * std::size_t{r.end},
              stream.begin() + 4 * std::size_t{r.begin});
  render_ranges_.clear();
  return ranges;
}

// Steps one replica with the given contacts; the published one also feeds
// the render mirror with the stream entries it changed.
void HapticLoop::step_replica(int index, const ContactSet& contacts, double dt) {
  deform::DeformableSurface& s = *replicas_[index];
  to_contacts(contacts, contact_scratch_);
  s.set_contacts(contact_scratch_);
  s.step(dt);
}

void HapticLoop::deform_main() {
  pin_to_cpu(config_.deform_cpu);
  const double rate = config_.core.deform_rate_hz;
  const auto period = static_cast<std::int64_t>(std::llround(1e9 / rate));
  const double dt = 1.0 / rate;
  std::uint64_t generation = 0;
  std::int64_t next = now_ns() + period;
  deform_start_time_.store(static_cast<double>(now_ns()) * 1e-9);

  while (!stop_.load(std::memory_order_relaxed)) {
    sleep_until(next, 0);
    const std::int64_t t0 = now_ns();
    const ContactSet contacts = contacts_->latest();

    // Step the replica the haptic thread is not using and publish it.
    const int cur = current_.load(std::memory_order_seq_cst);
    const int other = 1 - cur;
    step_replica(other, contacts, dt);
    {
      const auto ranges = replicas_[other]->take_dirty_ranges();
      const auto stream = replicas_[other]->stream();
      std::lock_guard<std::mutex> lock(render_mutex_);
      for (const auto& r : ranges) {
        std::copy(stream.begin() + 4 * std::size_t{r.begin}, stream.begin() + 4 * std::size_t{r.end},
                  render_stream_.begin() + 4 * std::size_t{r.begin});
        render_ranges_.push_back(r);
      }
    }
    ++generation;
    const double publish = static_cast<double>(now_ns()) * 1e-9;
    meta_[other] = {generation, publish};
    current_.store(other, std::memory_order_seq_cst);
    if (deform_records_) {
      DeformRecord rec;
      rec.generation = generation;
      rec.contacts_tick = contacts.tick;
      rec.time = publish;
      rec.dt = dt;
      rec.contacts = contacts;
      if (!deform_records_->push(rec)) record_drops_.fetch_add(1, std::memory_order_relaxed);
    }

    // Wait until the haptic thread has left the old replica, then bring it level.
    while (in_use_.load(std::memory_order_seq_cst) == cur && !stop_.load(std::memory_order_relaxed)) {
      timespec ts{0, 20'000};
      nanosleep(&ts, nullptr);
    }
    if (in_use_.load(std::memory_order_seq_cst) == cur) {
      // Stopping while the haptic thread still held it: stop() finishes.
      pending_ = {true, cur, contacts, dt};
      break;
    }
    step_replica(cur, contacts, dt);
    replicas_[cur]->take_dirty_ranges();

    deform_hist_.record(now_ns() - t0);
    deform_steps_.fetch_add(1, std::memory_order_relaxed);

    // Keep the phase; periods that passed during an overrun are skipped.
    next += period;
    const std::int64_t now = now_ns();
    if (now > next) {
      const std::int64_t k = (now - next) / period + 1;
      next += k * period;
      deform_overruns_.fetch_add(static_cast<std::uint64_t>(k), std::memory_order_relaxed);
    }
  }
}

void HapticLoop::haptic_main() {
  // Real-time setup: pinning, SCHED_FIFO when allowed, no timer slack, a
  // prefaulted stack.
  pin_to_cpu(config_.haptic_cpu);
  if (config_.realtime) {
    sched_param p{};
    p.sched_priority = config_.realtime_priority;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
    if (rc == 0) {
      realtime_.store(true);
      realtime_notice_ = "haptic thread runs with SCHED_FIFO priority " + std::to_string(config_.realtime_priority);
    } else {
      realtime_notice_ = std::string("real-time priority not available (") + std::strerror(rc) +
                         "): the haptic thread runs at normal priority and may jitter; grant CAP_SYS_NICE or an "
                         "rtprio limit (ulimit -r) to the user running Palpa";
    }
  } else {
    realtime_notice_ = "real-time priority not requested (realtime = false)";
  }
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
  prefault_stack();

  const std::size_t n = probes_.size();
  const auto period = static_cast<std::int64_t>(std::llround(1e9 / config_.core.rate_hz));
  const auto spin = static_cast<std::int64_t>(config_.spin_us * 1e3);
  const auto watchdog = static_cast<std::int64_t>(config_.core.watchdog_periods * static_cast<double>(period));
  const double expires = config_.core.watchdog_periods / config_.core.rate_hz;
  std::array<ProbeTickInput, kMaxProbes> inputs{};
  std::array<ProbeTickResult, kMaxProbes> results{};
  ContactSet contacts;
  std::array<bool, kMaxProbes> has_force{};
  for (std::size_t i = 0; i < n; ++i) has_force[i] = probes_[i].device->spec().force_dof > 0;
  const std::uint32_t base_warnings = static_warnings_ | (realtime_.load() ? 0u : kWarnNoRealtime);
  haptic_ready_.store(true, std::memory_order_release);

  std::uint64_t tick = 0;
  std::int64_t next = now_ns() + period;
  std::int64_t prev_start = -1;
  while (!stop_.load(std::memory_order_relaxed)) {
    sleep_until(next, spin);
    const std::int64_t start = now_ns();
    const double t = static_cast<double>(start) * 1e-9;
    latency_hist_.record(start - next);
    if (prev_start >= 0) {
      const std::int64_t actual = start - prev_start;
      jitter_hist_.record(actual > period ? actual - period : period - actual);
      if (actual > watchdog) watchdog_trips_.fetch_add(1, std::memory_order_relaxed);
    }
    prev_start = start;

    // Commands queued by other threads.
    LoopCommand cmd;
    for (int k = 0; k < 16 && commands_->pop(cmd); ++k) {
      core_->apply(cmd, t);
      if (command_records_ && !command_records_->push({tick, t, cmd}))
        record_drops_.fetch_add(1, std::memory_order_relaxed);
    }

    // Read every device.
    for (std::size_t i = 0; i < n; ++i) inputs[i].read_ok = probes_[i].device->read(inputs[i].sample);

    // Take the current model replica (hazard: announce, then re-check).
    int idx;
    do {
      idx = current_.load(std::memory_order_seq_cst);
      in_use_.store(idx, std::memory_order_seq_cst);
    } while (current_.load(std::memory_order_seq_cst) != idx);
    const ReplicaMeta meta = meta_[idx];
    core_->tick(tick, t, *replicas_[idx], meta.time, std::span<const ProbeTickInput>(inputs.data(), n),
                std::span<ProbeTickResult>(results.data(), n), contacts);
    in_use_.store(-1, std::memory_order_seq_cst);

    // Send the forces; each command expires after the watchdog time.
    std::uint32_t union_flags = 0;
    for (std::size_t i = 0; i < n; ++i) {
      union_flags |= results[i].flags;
      if (!has_force[i]) continue;
      PalpaForceCommand fc{};
      for (int a = 0; a < 3; ++a) fc.force[a] = results[i].force_device[a];
      fc.time = t;
      fc.expires_after = expires;
      probes_[i].device->write(fc);
    }
    if (config_.core.deform_rate_hz > 0) contacts_->write(contacts);
    if (union_flags & kSafetyModelLate) model_late_.fetch_add(1, std::memory_order_relaxed);

    // Publish the view and the record.
    LoopView& v = view_->write_buffer();
    v.tick = tick;
    v.time = t;
    v.model_generation = meta.generation;
    v.probe_count = static_cast<std::uint32_t>(n);
    v.warnings = base_warnings;
    if (t - last_miss_time_.load(std::memory_order_relaxed) < 1.0) v.warnings |= kWarnDeadlineMiss;
    if (record_drops_.load(std::memory_order_relaxed) > 0) v.warnings |= kWarnRecordDrop;
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
    ++tick;
    ticks_.store(tick, std::memory_order_relaxed);
    const std::int64_t end = now_ns();
    tick_hist_.record(end - start);
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
  for (std::size_t i = 0; i < n; ++i)
    if (has_force[i]) probes_[i].device->write(zero);
}

}  // namespace palpa::haptics
