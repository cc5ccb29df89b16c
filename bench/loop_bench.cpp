// Benchmark of the real-time haptic loop (issue 4, not a timed test).
//
// Three `scripted` devices press and slide over a 1M-vertex organ while a
// headless renderer (no display) takes the changed surface stream at 60 Hz.
// Runs the loop for --seconds (60 by default) at each rate of --rates (1 kHz
// and 4 kHz by default), then once more at 1 kHz with another process
// keeping the second core busy. Prints tick duration and period jitter
// percentiles and the missed deadlines of each run.
//
// Targets: at 1 kHz fewer than 0.1 % missed deadlines under load; 4 kHz
// sustained without load.
//
// Usage: palpa-loop-bench [--seconds S] [--rates 1000,4000] [--vertices N]
//                         [--deform-rate HZ (100)] [--spin-us US] [--no-load-run] [--load-only]
//                         [--as-built-order] [--no-placement] [--no-warm] [--floor-seconds S (5)]
//                         [--no-draw]
//
// --spin-us: busy-wait this long before each tick (at most 85% of a period)
// instead of sleeping to the deadline, which hides wake-up latency. By
// default the workbench's choice (haptics::haptic_spin: on a CPU kept for
// the haptic thread, all of the period but a sleep of 150 us at 1 kHz and
// 100 us at 4 kHz; PALPA_HAPTIC_SPIN to change).
// --no-warm: no warm-up run of the last tick during the spin, nor the held
// one before the tick (LoopConfig::warm_before_tick, on by default as in the
// workbench).
// --as-built-order: keep make_organ's vertex order instead of the spatial
// order (mesh::reorder_spatially) every loaded organ gets.
// --no-placement: no CPU kept for the haptic thread (haptics::reserve_haptic_cpu),
// llvmpipe with its default worker count.
// --floor-seconds: before each run, the machine's floor for this long (0:
// none), with the second core idle and then busy: an empty tick paced as
// the haptic thread paces its ticks, with no other thread of this program
// running; the deadlines it misses are the machine's, not the loop's.
// --no-draw: the renderer still takes the changed stream into the surface
// view at 60 Hz but draws no frame: what the software renderer's drawing
// costs the haptic thread (on a CPU of its own) shows against a run with it.

#include "loop_bench_scene.h"

#include "devices/loader.h"
#include "haptics/cpu_plan.h"
#include "haptics/loop.h"
#include "haptics/spin_warm.h"
#include "mesh/generate.h"
#include "mesh/spatial_order.h"
#include "render/heap.h"
#include "render/scene.h"
#include "render/surface_view.h"

#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace palpa;
using namespace std::chrono_literals;

namespace {

struct Options {
  double seconds = 60;
  std::vector<double> rates{1000, 4000};
  std::size_t vertices = 1'000'000;
  double deform_rate = 100;
  bool load_run = true;
  bool load_only = false;
  double spin_us = -1;  // -1: as the workbench (haptics::haptic_spin)
  bool warm = true;     // LoopConfig::warm_before_tick
  bool spatial_order = true;  // mesh::reorder_spatially, as load_organ numbers every organ
  bool placement = true;      // haptics::reserve_haptic_cpu
  bool draw = true;           // the renderer draws each frame (--no-draw: it only takes the stream)
  double floor_seconds = 5;   // the machine's floor before each run (0: none)
  int width = 640;   // offscreen frame, pixels
  int height = 480;
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "palpa-loop-bench: %s\nusage: palpa-loop-bench [--seconds S] [--rates 1000,4000] [--vertices N]\n"
               "                        [--deform-rate HZ] [--spin-us US] [--no-load-run] [--load-only]\n"
               "                        [--as-built-order] [--no-placement] [--no-warm] [--floor-seconds S]\n"
               "                        [--no-draw]\n",
               why);
  std::exit(2);
}

// The whole of `v` as a number from lo to hi, or the usage error
// "OPTION: 'V' is not a number of UNIT from LO to HI".
double number_in(const std::string& option, const std::string& v, double lo, double hi, const char* unit) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !(x >= lo && x <= hi)) {
    char why[200];
    std::snprintf(why, sizeof why, "%s: '%s' is not a number of %s from %.10g to %.10g", option.c_str(), v.c_str(), unit,
                  lo, hi);
    usage(why);
  }
  return x;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(("missing value after " + a).c_str());
      return argv[++i];
    };
    if (a == "--seconds") {
      o.seconds = number_in(a, value(), 0.1, 3600, "seconds");
    } else if (a == "--rates") {
      o.rates.clear();
      std::stringstream s(value());
      std::string r;
      while (std::getline(s, r, ',')) o.rates.push_back(number_in(a, r, 10, 20000, "Hz"));
      if (o.rates.empty()) usage("--rates: no rate given");
    } else if (a == "--vertices") {
      o.vertices = static_cast<std::size_t>(number_in(a, value(), 1000, 5e6, "vertices"));
    } else if (a == "--deform-rate") {
      o.deform_rate = number_in(a, value(), 1, 1000, "Hz");
    } else if (a == "--spin-us") {
      o.spin_us = number_in(a, value(), 0, 1e6, "us");
    } else if (a == "--no-load-run") {
      o.load_run = false;
    } else if (a == "--load-only") {
      o.load_only = true;
    } else if (a == "--as-built-order") {
      o.spatial_order = false;
    } else if (a == "--no-placement") {
      o.placement = false;
    } else if (a == "--no-warm") {
      o.warm = false;
    } else if (a == "--no-draw") {
      o.draw = false;
    } else if (a == "--floor-seconds") {
      o.floor_seconds = number_in(a, value(), 0, 600, "seconds");
    } else {
      usage(("unknown option " + a).c_str());
    }
  }
  // A spin leaves the thread asleep for haptics::kHapticMinSleepShare of
  // each period, as plan_haptic_spin caps it.
  for (double rate : o.rates) {
    const double most = (1 - haptics::kHapticMinSleepShare) * 1e6 / rate;
    if (o.spin_us > most) {
      char why[200];
      std::snprintf(why, sizeof why, "--spin-us: %g us is more than %g us, %.0f%% of the %g us period at %g Hz",
                    o.spin_us, most, 100 * (1 - haptics::kHapticMinSleepShare), 1e6 / rate, rate);
      usage(why);
    }
  }
  return o;
}

// A trajectory pressing 4 mm into the surface at `point` along -normal and
// circling 3 mm around it (loop_scene::path_point); `phase` (s) shifts it in
// time. Sampled 600 times a period.
std::string write_trajectory(const std::filesystem::path& file, const Vec3& point, const Vec3& normal, double phase) {
  std::ofstream f(file);
  f << "# benchmark probe: press 4 mm and circle 3 mm, period 3 s\nt,x,y,z,buttons\n";
  for (int k = 0; k <= 600; ++k) {
    const double t = k * bench::loop_scene::kPeriod / 600;
    const Vec3 p = bench::loop_scene::path_point(point, normal, t + phase);
    char line[160];
    std::snprintf(line, sizeof line, "%.6f,%.9f,%.9f,%.9f,0\n", t, p[0], p[1], p[2]);
    f << line;
  }
  return file.string();
}

// The second core's load: this program again (/proc/self/exe), spinning on
// `cpu` until it ends or its parent `parent` does (main, "--spin-load").
// A CPU it cannot run on: says so and exits 1.
[[noreturn]] void spin_load(int cpu, pid_t parent) {
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(0);  // the parent ended before the line above
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  if (sched_setaffinity(0, sizeof set, &set) != 0) {
    std::fprintf(stderr, "palpa-loop-bench --spin-load: cannot run on CPU %d (sched_setaffinity: %s)\n", cpu,
                 std::strerror(errno));
    _exit(1);
  }
  volatile std::uint64_t x = 0;
  for (;;) x = x * 6364136223846793005ull + 1442695040888963407ull;
}

// Another process spinning on a CPU that is not the haptic thread's (the
// second core on a 2-CPU machine). It dies with this process, however that
// ends (a timeout's SIGTERM, Ctrl-C), instead of spinning on as an orphan.
// Started by posix_spawn, not fork: a fork would make every page this
// process has copy-on-write, so that the loop's threads paid a page fault
// (20 us and more on the haptic thread) at their first write to each page
// after it (docs/PERFORMANCE.md, round 33). Exits when it cannot start.
pid_t start_load() {
  const int haptic = haptics::reserved_haptic_cpu();
  std::string name = "palpa-loop-bench", flag = "--spin-load", cpu = std::to_string(haptic == 0 ? 1 : 0),
              parent = std::to_string(getpid());
  char* args[] = {name.data(), flag.data(), cpu.data(), parent.data(), nullptr};
  pid_t pid = -1;
  if (const int rc = posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, args, environ); rc != 0) {
    std::fprintf(stderr,
                 "palpa-loop-bench: cannot start the load on the second core (posix_spawn of /proc/self/exe: %s)\n",
                 std::strerror(rc));
    std::exit(1);
  }
  return pid;
}

void stop_load(pid_t pid) {
  if (pid <= 0) return;
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
}

// The machine's own floor for a run: an empty tick paced as the haptic
// thread paces its ticks (the same CPU, real-time policy, timer slack,
// sleep and spin), for `seconds`, with no other thread of this program
// running. Deadline misses and skipped periods are counted as HapticLoop
// counts them, so a run cannot be expected to miss fewer: on a virtual
// machine they are the host's (it deschedules a virtual CPU that sleeps;
// docs/PERFORMANCE.md, round 15).
struct Floor {
  std::uint64_t ticks = 0, misses = 0, skipped = 0;
  double start_p99_us = 0, start_p999_us = 0, start_max_us = 0;
  bool realtime = false;
};

Floor measure_floor(double rate, double spin_us, int cpu, int priority, double seconds) {
  Floor f;
  std::thread t([&] {
    const int rc = haptics::prepare_haptic_thread(cpu, priority);
    f.realtime = priority > 0 && rc == 0;
    haptics::LoopClock& clock = haptics::monotonic_clock();
    const auto period = static_cast<std::int64_t>(std::llround(1e9 / rate));
    const auto spin = static_cast<std::int64_t>(spin_us * 1e3);
    const auto n = static_cast<std::size_t>(seconds * rate);
    std::vector<std::int64_t> late;
    late.reserve(n);
    std::int64_t next = clock.now_ns() + period;
    for (std::size_t k = 0; k < n; ++k) {
      clock.sleep_until(next, spin);
      const std::int64_t end = clock.now_ns();  // the empty tick
      late.push_back(end - next);
      if (end > next + period) ++f.misses;
      next += period;
      if (end > next) {
        const std::int64_t skip = (end - next) / period + 1;
        next += skip * period;
        f.skipped += static_cast<std::uint64_t>(skip);
      }
    }
    f.ticks = n;
    std::sort(late.begin(), late.end());
    if (!late.empty()) {
      f.start_p99_us = 1e-3 * static_cast<double>(late[late.size() * 99 / 100]);
      f.start_p999_us = 1e-3 * static_cast<double>(late[late.size() * 999 / 1000]);
      f.start_max_us = 1e-3 * static_cast<double>(late.back());
    }
  });
  t.join();
  return f;
}

void print_timing(const char* what, const haptics::TimingSummary& t) {
  std::printf("    %-16s p50 %8.2f  p90 %8.2f  p99 %8.2f  p99.9 %8.2f  max %9.2f  (us)\n", what, t.p50_us, t.p90_us,
              t.p99_us, t.p999_us, t.max_us);
}

struct Scene {
  std::shared_ptr<mesh::SurfaceMesh> mesh;
  deform::MaterialArrays materials;
  std::vector<std::string> trajectories;
};

void run(const Scene& scene, const Options& o, double rate, bool load) {
  std::printf("\n== %.0f Hz, %s, %.0f s ==\n", rate, load ? "second core busy" : "no load", o.seconds);
  std::fflush(stdout);

  // Three scripted probes (identity mapping: the trajectories are in world coordinates).
  const devices::Plugin plugin = devices::PluginLoader().load("scripted");
  std::vector<devices::Device> devices;
  for (const auto& t : scene.trajectories) devices.push_back(plugin.create("file=" + t + ";loop=true;max_force=10"));
  std::vector<haptics::ProbeBinding> probes;
  for (auto& d : devices) {
    d.start();
    haptics::ProbeBinding b;
    b.device = &d;
    probes.push_back(b);
  }

  haptics::LoopConfig c;
  c.core.rate_hz = rate;
  c.core.deform_rate_hz = o.deform_rate;
  c.core.shape.radius = 0.015;
  // One CPU for the haptic thread alone, deformation and rendering on the
  // others (haptics::reserve_haptic_cpu, as the workbench does; the kernel
  // here is not preemptible, so other threads' system calls on the haptic
  // CPU would delay its wake-ups). --no-placement: nothing pinned.
  c.haptic_cpu = haptics::reserved_haptic_cpu();
  c.realtime = true;
  c.record_capacity = 0;
  // The thread sleeps at least haptics::kHapticMinSleepShare of the period:
  // a SCHED_FIFO thread that never sleeps is stopped by the kernel's
  // real-time throttling (sched_rt_runtime_us: 50 ms in every second by
  // default), which a full-period spin showed as 50 ms stalls.
  const haptics::SpinPlan spin = haptics::haptic_spin(rate, c.haptic_cpu);
  c.spin_us = o.spin_us >= 0 ? o.spin_us : spin.spin_us;  // --spin-us: within that share (parse)
  if (o.spin_us >= 0)
    std::printf("  spin: %.0f us before each tick (--spin-us)\n", c.spin_us);
  else
    std::printf("  spin: %s\n", spin.note.c_str());
  c.warm_before_tick = o.warm;
  if (c.spin_us > 0)
    std::printf("  warm-up of the last tick during the spin, and held for the tick at its deadline: %s\n",
                o.warm ? "on" : "off (--no-warm)");
  if (o.floor_seconds > 0) {
    // Before the loop's threads exist: once with the other CPU idle and once
    // with it busy (as the loop's deformation and rendering keep it; on a
    // virtual machine the host then has less room for its own work).
    for (const bool busy : {false, true}) {
      const pid_t floor_load = busy ? start_load() : -1;
      const Floor f = measure_floor(rate, c.spin_us, c.haptic_cpu, c.realtime_priority, o.floor_seconds);
      stop_load(floor_load);
      std::printf("  machine floor, second core %s (an empty tick paced the same way for %.0f s, %s): missed "
                  "deadlines %llu (%.4f %%), skipped periods %llu (a tick in %.2f %% of the periods); start latency "
                  "p99 %.2f p99.9 %.2f max %.2f us\n",
                  busy ? "busy" : "idle", o.floor_seconds, f.realtime ? "SCHED_FIFO" : "normal priority",
                  static_cast<unsigned long long>(f.misses),
                  f.ticks ? 100.0 * static_cast<double>(f.misses) / static_cast<double>(f.ticks) : 0.0,
                  static_cast<unsigned long long>(f.skipped),
                  f.ticks ? 100.0 * static_cast<double>(f.ticks) / static_cast<double>(f.ticks + f.skipped) : 0.0,
                  f.start_p99_us, f.start_p999_us, f.start_max_us);
      std::fflush(stdout);
    }
  }
  haptics::HapticLoop loop(scene.mesh, scene.materials, {}, c, std::move(probes));

  pid_t load_pid = load ? start_load() : -1;
  loop.start();
  for (std::size_t i = 0; i < devices.size(); ++i) loop.enable(i);

  // Headless rendering, as fast as it goes up to 60 Hz: an offscreen OpenGL
  // context (OSMesa by default, no display) draws the organ through the same
  // SurfaceView the workbench uses, uploading only the changed stream entries.
  std::atomic<bool> rendering{true};
  std::atomic<bool> render_ready{false};
  std::uint64_t frames = 0, uploaded = 0;
  std::string render_error, render_backend;
  double frame_ms_sum = 0;
  std::thread renderer([&] {
    try {
      render::OffscreenScene view_scene(o.width, o.height);
      render_backend = view_scene.window().gl_renderer();
      render::SurfaceView surface_view(scene.mesh);
      view_scene.add(surface_view.actor());
      view_scene.look_at(surface_view.bounds(), Vec3(0.3, -1.0, 0.6), Vec3::UnitZ());
      // The view reads the loop's mailbox directly (the first read holds
      // the whole stream, uploaded once).
      core::SurfaceMailbox& box = loop.surface_changes();
      std::vector<float> pulled(4 * box.vertex_count(), 0.0f);
      {
        const auto all = box.begin_read();
        box.read_into(pulled, all);
        surface_view.update(pulled, all);
        box.end_read();
      }
      render_ready.store(true);
      auto next = std::chrono::steady_clock::now();
      while (rendering.load()) {
        next += std::chrono::microseconds(16667);
        std::this_thread::sleep_until(next);
        const auto f0 = std::chrono::steady_clock::now();
        const auto ranges = box.begin_read();
        box.read_into(pulled, ranges);
        if (!ranges.empty()) surface_view.update(pulled, ranges);
        box.end_read();
        for (const auto& r : ranges) uploaded += 16ull * (r.end - r.begin);
        if (o.draw) view_scene.window().render();
        frame_ms_sum += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - f0).count();
        const haptics::LoopView v = loop.view();
        (void)v;
        ++frames;
        // A frame longer than the period: start the next one right away.
        if (std::chrono::steady_clock::now() > next) next = std::chrono::steady_clock::now();
      }
    } catch (const std::exception& e) {
      render_error = e.what();
      render_ready.store(true);
    }
  });
  while (!render_ready.load()) std::this_thread::sleep_for(10ms);
  if (!render_error.empty()) {
    std::fprintf(stderr, "palpa-loop-bench: headless rendering failed: %s\n", render_error.c_str());
  }

  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::duration<double>(o.seconds))
    std::this_thread::sleep_for(100ms);
  const haptics::LoopStatistics s = loop.statistics();
  const haptics::LoopView v = loop.view();

  // Edit latency: the time from a command to the end of the first
  // deformation step that uses it (both replicas), while everything runs.
  std::vector<double> material_ms, shape_ms;
  deform::Material soft = scene.materials.at(0), stiff = soft;
  stiff.stiffness *= 2;
  for (int k = 0; k < 20; ++k) {
    std::this_thread::sleep_for(37ms);
    auto e0 = std::chrono::steady_clock::now();
    const auto ticket = loop.set_material(k % 2 ? soft : stiff);
    while (!loop.in_effect(ticket)) std::this_thread::yield();
    material_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - e0).count());
    std::this_thread::sleep_for(23ms);
    deform::ShapeFunction sh = c.core.shape;
    sh.radius = k % 2 ? 0.015 : 0.012;
    e0 = std::chrono::steady_clock::now();
    const auto t2 = loop.set_shape(sh);
    while (!loop.in_effect(t2)) std::this_thread::yield();
    shape_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - e0).count());
  }
  std::sort(material_ms.begin(), material_ms.end());
  std::sort(shape_ms.begin(), shape_ms.end());
  rendering.store(false);
  renderer.join();
  loop.stop();
  stop_load(load_pid);

  std::printf("  %s\n", s.realtime_notice.c_str());
  std::printf("  ticks %llu in %.2f s: %.1f Hz achieved (nominal %.0f)\n", static_cast<unsigned long long>(s.ticks),
              s.elapsed_s, s.achieved_rate_hz, s.nominal_rate_hz);
  const double pct = s.ticks ? 100.0 * static_cast<double>(s.deadline_misses) / static_cast<double>(s.ticks) : 0;
  std::printf("  missed deadlines %llu (%.4f %%), skipped periods %llu, watchdog trips %llu\n",
              static_cast<unsigned long long>(s.deadline_misses), pct, static_cast<unsigned long long>(s.skipped_periods),
              static_cast<unsigned long long>(s.watchdog_trips));
  if (c.spin_us > 0 && c.warm_before_tick) {
    const double ticks = static_cast<double>(std::max<std::uint64_t>(1, loop.ticks()));
    std::printf("  warm-ups before ticks %llu (%.2f per tick, over the %llu ticks of the whole run); ticks touched "
                "%.0f us before: %.2f%%\n",
                static_cast<unsigned long long>(loop.warm_ups()), static_cast<double>(loop.warm_ups()) / ticks,
                static_cast<unsigned long long>(loop.ticks()), static_cast<double>(haptics::kTouchLeadNs) * 1e-3,
                100.0 * static_cast<double>(loop.touches()) / ticks);
  }
  print_timing("tick duration", s.tick_duration);
  print_timing("period jitter", s.period_jitter);
  print_timing("start latency", s.start_latency);
  std::printf("  deformation: %.1f Hz achieved (nominal %.0f), %llu overruns, model-late ticks %llu\n",
              s.deform_achieved_hz, s.deform_nominal_hz, static_cast<unsigned long long>(s.deform_overruns),
              static_cast<unsigned long long>(s.model_late_ticks));
  print_timing("deform step x2", s.deform_step);
  std::uint32_t contacts = 0;
  for (std::uint32_t i = 0; i < v.probe_count; ++i) contacts += v.probes[i].in_contact;
  std::printf("  renderer (%s, %dx%d, no display%s): %llu frames, mean %.1f ms each, %.1f MB of stream uploaded; "
              "probes in contact at the end: %u of %u\n",
              render_error.empty() ? render_backend.c_str() : "FAILED", o.width, o.height,
              o.draw ? "" : ", --no-draw: the stream taken, nothing drawn",
              static_cast<unsigned long long>(frames), frames ? frame_ms_sum / frames : 0.0, uploaded / 1e6, contacts,
              v.probe_count);
  const double deform_period_ms = 1e3 / o.deform_rate;
  std::printf("  edit latency (command -> first deformation step using it, %zu vertices, 20 each): material p50 %.2f "
              "ms, max %.2f ms; shape function p50 %.2f ms, max %.2f ms; deformation period %.2f ms: %s\n",
              scene.mesh->vertex_count(), material_ms[10], material_ms.back(), shape_ms[10], shape_ms.back(),
              deform_period_ms, material_ms[10] <= deform_period_ms ? "within one period (p50)" : "NOT within one period");
  const bool target = rate <= 1000 ? pct < 0.1 : s.achieved_rate_hz >= 0.999 * rate;
  std::printf("  target (%s): %s\n", rate <= 1000 ? "< 0.1 % missed deadlines" : ">= 99.9 % of the periods",
              target ? "met" : "NOT met");
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  // The load process start_load starts: this program with "--spin-load CPU PARENT".
  if (argc == 4 && std::strcmp(argv[1], "--spin-load") == 0) {
    // Whole numbers: a CPU the affinity mask can name, a process id.
    auto whole = [](const char* v, double lo, double hi, const char* unit) {
      const double x = number_in("--spin-load", v, lo, hi, unit);
      if (x != std::floor(x)) usage((std::string("--spin-load: '") + v + "' is not a whole number of " + unit).c_str());
      return static_cast<int>(x);
    };
    spin_load(whole(argv[2], 0, CPU_SETSIZE - 1, "CPU"),
              whole(argv[3], 1, std::numeric_limits<int>::max(), "process id"));
  }
  // Mesa's software renderer frees and allocates its buffers every frame:
  // keep the freed heap in the process (render/heap.h).
  render::keep_freed_heap();
  const Options o = parse(argc, argv);
  // One CPU kept for the haptic thread, everything else (and llvmpipe's
  // workers) on the others, as in the workbench.
  const std::string placement =
      o.placement ? haptics::reserve_haptic_cpu().note : std::string("no CPU kept for the haptic thread (--no-placement)");
  std::printf("palpa-loop-bench: %u CPUs, %zu-vertex organ, 3 scripted probes, deformation at %.0f Hz\n",
              std::thread::hardware_concurrency(), o.vertices, o.deform_rate);
  std::printf("placement: %s\n", placement.c_str());
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0)
    std::printf("memory locked (mlockall)\n");
  else
    std::printf("memory not locked (mlockall: %s); page faults may add latency\n", std::strerror(errno));

  // The organ, a liver-like material, and the probes' trajectories.
  Scene scene;
  auto t0 = std::chrono::steady_clock::now();
  scene.mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_organ(o.vertices));
  if (o.spatial_order) mesh::reorder_spatially(*scene.mesh);
  scene.materials = deform::MaterialArrays::uniform(scene.mesh->vertex_count(), bench::loop_scene::material());
  std::printf("organ: %zu vertices, %zu triangles, built in %.1f s\n", scene.mesh->vertex_count(),
              scene.mesh->triangle_count(), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  const collision::VertexTree tree(std::span<const Vec3>(scene.mesh->positions));
  const auto dir = std::filesystem::temp_directory_path() / "palpa-loop-bench";
  std::filesystem::create_directories(dir);
  for (int i = 0; i < bench::loop_scene::kProbes; ++i) {
    const Index v = tree.nearest(Vec3(bench::loop_scene::kProbeX[i], 0.0, 1.0)).vertex;  // on top of the organ
    scene.trajectories.push_back(write_trajectory(dir / ("probe" + std::to_string(i) + ".csv"),
                                                  scene.mesh->positions[v], scene.mesh->normals[v],
                                                  bench::loop_scene::kPhase * i));
  }

  {
    // What an edit cost before the session engine: a new loop (vertex tree
    // and two surface replicas) for every material or probe change.
    devices::Device d = devices::PluginLoader().load("scripted").create("file=" + scene.trajectories[0] + ";loop=true");
    d.start();
    haptics::ProbeBinding b;
    b.device = &d;
    const auto r0 = std::chrono::steady_clock::now();
    haptics::HapticLoop rebuilt(scene.mesh, scene.materials, {}, haptics::LoopConfig{}, {b});
    std::printf("rebuilding a loop (what an edit used to cost): %.0f ms at %zu vertices\n",
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - r0).count(),
                scene.mesh->vertex_count());
  }
  if (!o.load_only)
    for (double r : o.rates) run(scene, o, r, false);
  if (o.load_run || o.load_only) run(scene, o, 1000, true);
  return 0;
}
