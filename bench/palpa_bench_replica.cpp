// palpa-bench, issue 8: replica steps and the threaded tick (see the header).

#include "palpa_bench_replica.h"

#include "core/spsc_queue.h"
#include "haptics/cpu_plan.h"
#include "haptics/loop.h"
#include "haptics/spin_warm.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <thread>

namespace palpa::bench {

namespace {

std::unique_ptr<deform::DeformableSurface> make_replica(const haptics::SessionModel& model) {
  auto s = std::make_unique<deform::DeformableSurface>(
      model.mesh, deform::MaterialArrays::uniform(model.mesh->vertex_count(), deform::Material{}), model.options);
  model.prepare_surface(*s);
  s->take_dirty_ranges();
  return s;
}

bool same_bits(const deform::DeformableSurface& a, const deform::DeformableSurface& b) {
  const auto& va = a.state().vertices;
  const auto& vb = b.state().vertices;
  if (va.size() != vb.size() || a.state().time != b.state().time || a.active_count() != b.active_count()) return false;
  if (std::memcmp(va.data(), vb.data(), va.size() * sizeof(va[0])) != 0) return false;
  const auto sa = a.stream(), sb = b.stream();
  return std::memcmp(sa.data(), sb.data(), sa.size_bytes()) == 0;
}

}  // namespace

ReplicaStepFigures measure_replica_steps(const haptics::SessionModel& model,
                                         const std::vector<haptics::DeformRequest>& requests, std::size_t skip) {
  ReplicaStepFigures f;
  // At most the first 600 requests (each costs milliseconds at 1M vertices, twice).
  const std::size_t count = std::min<std::size_t>(requests.size(), 600);
  skip = std::min(skip, count / 2);
  std::vector<deform::Contact> scratch;
  std::vector<double> both_ns, level_ns, step_ns, copy_ns;
  // Before: each replica makes the step.
  auto a = make_replica(model), b = make_replica(model);
  for (std::size_t k = 0; k < count; ++k) {
    const auto t0 = Clock::now();
    haptics::apply_deform_request(*a, requests[k], scratch, model.field.get());
    haptics::apply_deform_request(*b, requests[k], scratch, model.field.get());
    const auto t1 = Clock::now();
    a->take_dirty_ranges();
    b->take_dirty_ranges();
    if (k >= skip) both_ns.push_back(elapsed_ns(t0, t1));
  }
  // Now: one replica steps, the other is brought level (roles alternate).
  std::unique_ptr<deform::DeformableSurface> r[2] = {make_replica(model), make_replica(model)};
  double changed = 0, active = 0;
  for (std::size_t k = 0; k < count; ++k) {
    deform::DeformableSurface& src = *r[k % 2];
    deform::DeformableSurface& dst = *r[1 - k % 2];
    const auto t0 = Clock::now();
    haptics::apply_deform_request(src, requests[k], scratch, model.field.get());
    const auto t1 = Clock::now();
    const double n_changed = static_cast<double>(src.changed_count());
    haptics::apply_deform_edits(dst, requests[k].edits);
    dst.level_with(src);
    const auto t2 = Clock::now();
    src.take_dirty_ranges();
    dst.take_dirty_ranges();
    if (k >= skip) {
      level_ns.push_back(elapsed_ns(t0, t2));
      step_ns.push_back(elapsed_ns(t0, t1));
      copy_ns.push_back(elapsed_ns(t1, t2));
      changed += n_changed;
      active += static_cast<double>(src.active_count());
    }
  }
  const double n = static_cast<double>(level_ns.size());
  f.changed_mean = n > 0 ? changed / n : 0;
  f.active_mean = n > 0 ? active / n : 0;
  f.both = latency_of(both_ns);
  f.level = latency_of(level_ns);
  f.level_step = latency_of(step_ns);
  f.level_copy = latency_of(copy_ns);
  f.equal = same_bits(*a, *b) && same_bits(*a, *r[0]) && same_bits(*a, *r[1]);
  return f;
}

ThreadedFigures measure_threaded(const std::shared_ptr<const haptics::SessionModel>& model, const ProbePaths& paths,
                                 int probes, std::size_t warmup, std::size_t ticks, const ThreadedPacing& pacing) {
  const bool level = pacing.level;
  std::vector<haptics::ProbeSetup> setups(static_cast<std::size_t>(probes));
  for (auto& su : setups) {
    su.name = "bench probe";
    su.spec.position_dof = 3;
    su.safety.max_jump = 1e3;
  }
  haptics::LoopCore core(*model->tree, *model->mesh, model->config, setups, model->field.get());
  std::unique_ptr<deform::DeformableSurface> replicas[2] = {make_replica(*model), make_replica(*model)};
  struct Meta {
    double time = 0;
  };
  Meta meta[2];
  std::atomic<int> current{0}, in_use{-1};
  std::atomic<bool> stop{false};
  SpscQueue<haptics::DeformRequest> queue(64);
  std::vector<double> step_ns;
  step_ns.reserve(ticks);
  std::size_t merged = 0;

  // Placement as in the workbench: this thread on a CPU of its own at
  // SCHED_FIFO where allowed, the deformation thread on the others.
  const std::vector<int> cpus_before = haptics::cpus_of_this_thread();
  int policy_before = SCHED_OTHER;
  sched_param param_before{};
  pthread_getschedparam(pthread_self(), &policy_before, &param_before);
  const haptics::CpuPlan plan = pacing.place ? haptics::decide_haptic_cpu("") : haptics::CpuPlan{};
  bool realtime = false;
  if (plan.haptic_cpu >= 0) {
    haptics::run_this_thread_on({plan.haptic_cpu});
    sched_param p{};
    p.sched_priority = haptics::LoopConfig{}.realtime_priority;
    realtime = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0;
  }

  // The deformation thread: HapticLoop::process.
  std::thread deform([&] {
    if (plan.haptic_cpu >= 0) haptics::run_this_thread_on(plan.others);
    std::vector<deform::Contact> scratch;
    haptics::DeformRequest r, later;
    while (!stop.load(std::memory_order_relaxed)) {
      if (!queue.pop(r)) {
        std::this_thread::sleep_for(std::chrono::microseconds(50));
        continue;
      }
      while (queue.pop(later)) {
        haptics::merge_requests(r, later);
        ++merged;
      }
      const auto t0 = Clock::now();
      const int cur = current.load();
      const int other = 1 - cur;
      haptics::apply_deform_request(*replicas[other], r, scratch, model->field.get());
      replicas[other]->take_dirty_ranges();
      meta[other].time = r.time;
      current.store(other);
      while (in_use.load() == cur) std::this_thread::sleep_for(std::chrono::microseconds(20));
      if (level) {
        haptics::apply_deform_edits(*replicas[cur], r.edits);
        replicas[cur]->level_with(*replicas[other]);
      } else {
        haptics::apply_deform_request(*replicas[cur], r, scratch, model->field.get());
      }
      replicas[cur]->take_dirty_ranges();
      meta[cur] = meta[other];
      step_ns.push_back(elapsed_ns(t0, Clock::now()));
    }
  });

  // The haptic side, paced at the model's rate on the loop's clock: sleep,
  // then spin the last spin_us, warming during the spin as HapticLoop does.
  const double period = 1.0 / model->config.rate_hz;
  const auto period_ns = static_cast<std::int64_t>(std::llround(period * 1e9));
  const auto spin_ns = static_cast<std::int64_t>(
      std::min(pacing.spin_us * 1e3, (1 - haptics::kHapticMinSleepShare) * static_cast<double>(period_ns)));
  haptics::LoopClock& clock = haptics::monotonic_clock();
  std::array<haptics::ProbeTickInput, haptics::kMaxProbes> inputs{};
  std::array<haptics::ProbeTickResult, haptics::kMaxProbes> results{};
  haptics::ContactSet contacts;
  std::vector<double> tick_ns, tick_held_ns, tick_taken_ns, warm_ns;
  tick_ns.reserve(ticks);
  tick_held_ns.reserve(ticks);
  tick_taken_ns.reserve(ticks);
  std::size_t warm_ups = 0, held_behind = 0, skipped = 0;
  // Takes the current replica (announce, then re-check), as HapticLoop does.
  auto take_replica = [&] {
    int idx;
    do {
      idx = current.load();
      in_use.store(idx);
    } while (current.load() != idx);
    return idx;
  };
  const std::size_t total = std::min(paths.ticks, warmup + ticks);
  std::int64_t next = clock.now_ns() + period_ns;
  for (std::size_t k = 0; k < total; ++k) {
    int held = -1;  // the replica held from the last warm-up for this tick
    if (pacing.warm && spin_ns > 0 && core.can_warm()) {
      // A warm-up: `hold` keeps the replica taken for the tick.
      auto warm_up = [&](bool hold) {
        const auto w0 = Clock::now();
        const int warmed = take_replica();
        core.warm_caches(*replicas[warmed]);
        if (!hold) in_use.store(-1);
        ++warm_ups;
        if (k >= warmup && warm_ns.size() < 4 * ticks) warm_ns.push_back(elapsed_ns(w0, Clock::now()));
        return warmed;
      };
      held = haptics::warm_during_spin(
          clock, next, spin_ns, [&] { return current.load(); }, [&] { return warm_up(false); },
          [&] { return pacing.hold ? warm_up(true) : -1; }, [] { return false; });
      // The held replica's warm-up once more, 10 us before the tick, as
      // HapticLoop's touch (its devices' reads and view have no twin here).
      if (held >= 0)
        haptics::touch_before_tick(clock, next, spin_ns, [&] { core.warm_caches(*replicas[held]); }, [] { return false; });
    }
    clock.sleep_until(next, spin_ns);
    const double t = static_cast<double>(k) * period;
    for (int p = 0; p < probes; ++p) inputs[p].sample = haptics::position_sample(paths.at(k, p), k + 1, t);
    // Whether the deformation thread published another replica during the
    // hold (the tick then reads one step older than the newest).
    const bool behind = held >= 0 && current.load() != held;
    const auto a = Clock::now();
    const int idx = held >= 0 ? held : take_replica();
    const bool due = core.tick(k, t, *replicas[idx], meta[idx].time,
                               std::span<const haptics::ProbeTickInput>(inputs.data(), probes),
                               std::span<haptics::ProbeTickResult>(results.data(), probes), contacts);
    in_use.store(-1);
    const auto b = Clock::now();
    if (due) queue.push(core.request());
    // The next slot; slots already past are skipped, as HapticLoop does
    // (this thread was held up: no burst of late ticks to catch up).
    next += period_ns;
    if (const std::int64_t now = clock.now_ns(); now > next) {
      const std::int64_t late = (now - next) / period_ns + 1;
      next += late * period_ns;
      if (k >= warmup) skipped += static_cast<std::size_t>(late);
    }
    if (k >= warmup) {
      const double ns = elapsed_ns(a, b);
      tick_ns.push_back(ns);
      (held >= 0 ? tick_held_ns : tick_taken_ns).push_back(ns);
      held_behind += behind;
    }
  }
  // Let the last steps finish, then stop.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  stop.store(true);
  deform.join();
  if (plan.haptic_cpu >= 0) {
    pthread_setschedparam(pthread_self(), policy_before, &param_before);
    haptics::run_this_thread_on(cpus_before);
  }
  ThreadedFigures f;
  f.haptic_cpu = plan.haptic_cpu;
  f.realtime = realtime;
  f.tick = latency_of(tick_ns);
  f.steps = step_ns.size();
  f.merged = merged;
  f.warm_ups = warm_ups;
  f.tick_held = latency_of(tick_held_ns);
  f.tick_taken = latency_of(tick_taken_ns);
  f.held_behind = held_behind;
  f.skipped = skipped;
  f.warm = latency_of(warm_ns);
  f.step = latency_of(step_ns);
  return f;
}

}  // namespace palpa::bench
