#include "haptics/cpu_plan.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace palpa::haptics {

namespace {

std::atomic<int> g_reserved{-1};

std::string read_text(const char* path) {
  std::ifstream f(path);
  std::ostringstream out;
  out << f.rdbuf();
  return f ? out.str() : std::string();
}

// The first whitespace-separated word of a file ("" when unreadable), as
// sysfs attributes hold one value and a newline.
std::string first_word_of(const std::filesystem::path& file) {
  std::istringstream in(read_text(file.c_str()));
  std::string word;
  in >> word;
  return word;
}

}  // namespace

std::vector<unsigned long long> device_interrupts_per_cpu(const std::string& proc_interrupts_text) {
  std::vector<unsigned long long> per_cpu;
  std::size_t pos = 0;
  auto next_line = [&](std::string& line) {
    if (pos >= proc_interrupts_text.size()) return false;
    const std::size_t end = std::min(proc_interrupts_text.find('\n', pos), proc_interrupts_text.size());
    line = proc_interrupts_text.substr(pos, end - pos);
    pos = end + 1;
    return true;
  };
  std::string line;
  if (!next_line(line)) return per_cpu;
  std::vector<int> columns;  // CPU number of each column
  for (std::size_t p = line.find("CPU"); p != std::string::npos; p = line.find("CPU", p + 3))
    columns.push_back(std::atoi(line.c_str() + p + 3));
  int top = -1;
  for (int c : columns) top = std::max(top, c);
  per_cpu.assign(static_cast<std::size_t>(top + 1), 0);
  while (next_line(line)) {
    const char* p = line.c_str();
    while (*p == ' ') ++p;
    if (*p < '0' || *p > '9') continue;  // NMI, LOC, RES, ...: not a device
    p = std::strchr(p, ':');
    if (!p) continue;
    ++p;
    for (int c : columns) {
      char* end = nullptr;
      const unsigned long long n = std::strtoull(p, &end, 10);
      if (end == p) break;
      per_cpu[static_cast<std::size_t>(c)] += n;
      p = end;
    }
  }
  return per_cpu;
}

CpuPlan plan_cpus(const std::vector<int>& allowed, const std::vector<unsigned long long>& interrupts,
                  const std::string& env) {
  CpuPlan plan;
  plan.others = allowed;
  if (env == "off" || env == "-1") {
    plan.note = "no CPU kept for the haptic thread (PALPA_HAPTIC_CPU=" + env + ")";
    return plan;
  }
  if (allowed.size() < 2) {
    plan.note = "no CPU kept for the haptic thread: the process may use only one CPU";
    return plan;
  }
  int haptic = allowed.back();
  if (!env.empty()) {
    char* end = nullptr;
    const long n = std::strtol(env.c_str(), &end, 10);
    if (!(end && end != env.c_str() && *end == '\0' &&
          std::find(allowed.begin(), allowed.end(), static_cast<int>(n)) != allowed.end())) {
      plan.note = "no CPU kept for the haptic thread: PALPA_HAPTIC_CPU=" + env +
                  " is not a CPU this process may use (expected off or one of them)";
      return plan;
    }
    haptic = static_cast<int>(n);
  } else {
    // The CPU that has handled the fewest device interrupts (their handlers
    // run before any thread; on the 2-CPU VM the disk's all go to CPU 1,
    // where the haptic thread missed 2% of its deadlines against 0.03-0.1%
    // on CPU 0); the highest on a tie.
    auto count = [&](int c) { return static_cast<std::size_t>(c) < interrupts.size() ? interrupts[c] : 0ull; };
    for (int c : allowed)
      if (count(c) < count(haptic) || (count(c) == count(haptic) && c > haptic)) haptic = c;
  }
  plan.haptic_cpu = haptic;
  plan.others.erase(std::remove(plan.others.begin(), plan.others.end(), haptic), plan.others.end());
  plan.renderer_threads = static_cast<int>(plan.others.size());
  plan.note = "CPU " + std::to_string(haptic) + " kept for the haptic thread; every other thread on the other " +
              std::to_string(plan.others.size()) + (plan.others.size() == 1 ? " CPU" : " CPUs");
  return plan;
}

std::vector<int> cpus_of_this_thread() {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  std::vector<int> cpus;
  if (sched_getaffinity(0, sizeof allowed, &allowed) != 0) return cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &allowed)) cpus.push_back(c);
  return cpus;
}

int run_this_thread_on(const std::vector<int>& cpus) {
  if (cpus.empty()) return EINVAL;
  cpu_set_t set;
  CPU_ZERO(&set);
  for (int c : cpus) CPU_SET(c, &set);
  return pthread_setaffinity_np(pthread_self(), sizeof set, &set);
}

int prepare_haptic_thread(int cpu, int priority) {
  if (cpu >= 0) run_this_thread_on({cpu});
  int rc = 0;
  if (priority > 0) {
    sched_param p{};
    p.sched_priority = priority;
    rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
  }
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
  return rc;
}

CpuPlan decide_haptic_cpu(const std::string& env) {
  const std::vector<int> cpus = cpus_of_this_thread();
  if (cpus.empty()) {
    CpuPlan p;
    p.note = std::string("no CPU kept for the haptic thread: sched_getaffinity failed (") + std::strerror(errno) + ")";
    return p;
  }
  return plan_cpus(cpus, device_interrupts_per_cpu(read_text("/proc/interrupts")), env);
}

CpuPlan reserve_haptic_cpu() {
  static const CpuPlan plan = [] {
    const char* env = std::getenv("PALPA_HAPTIC_CPU");
    CpuPlan p = decide_haptic_cpu(env ? env : "");
    if (p.haptic_cpu < 0) return p;
    if (const int rc = run_this_thread_on(p.others); rc != 0) {
      CpuPlan none;
      none.others = cpus_of_this_thread();
      none.note = std::string("no CPU kept for the haptic thread: pthread_setaffinity_np failed (") + std::strerror(rc) + ")";
      return none;
    }
    if (std::getenv("LP_NUM_THREADS")) {
      p.renderer_threads = 0;
    } else {
      setenv("LP_NUM_THREADS", std::to_string(p.renderer_threads).c_str(), 0);
      p.note += ", llvmpipe with " + std::to_string(p.renderer_threads) +
                (p.renderer_threads == 1 ? " worker" : " workers");
    }
    g_reserved.store(p.haptic_cpu);
    return p;
  }();
  return plan;
}

int reserved_haptic_cpu() { return g_reserved.load(); }

std::string cgroup_of_cpu_controller(const std::string& text, bool* on_v1) {
  std::istringstream in(text);
  std::string line, v1, v2;
  while (std::getline(in, line)) {
    // hierarchy-ID:controller-list:path
    const std::size_t a = line.find(':');
    const std::size_t b = a == std::string::npos ? std::string::npos : line.find(':', a + 1);
    if (b == std::string::npos) continue;
    const std::string id = line.substr(0, a), controllers = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
    if (id == "0" && controllers.empty()) {
      v2 = path;
      continue;
    }
    std::istringstream list(controllers);
    for (std::string c; std::getline(list, c, ',');)
      if (c == "cpu" && v1.empty()) v1 = path;
  }
  // Hybrid: the v1 line holds the CPU controller; the "0::" line is then
  // systemd's hierarchy without controllers.
  if (on_v1) *on_v1 = !v1.empty();
  return v1.empty() ? v2 : v1;
}

bool has_cap_sys_nice(const std::string& text) {
  const std::size_t p = text.find("CapEff:");
  if (p == std::string::npos) return false;
  const unsigned long long caps = std::strtoull(text.c_str() + p + 7, nullptr, 16);
  return (caps >> 23) & 1u;  // CAP_SYS_NICE
}

RealtimeContext read_realtime_context() {
  RealtimeContext c;
  c.root = geteuid() == 0;
  c.cap_sys_nice = has_cap_sys_nice(read_text("/proc/self/status"));
  rlimit limit{};
  if (getrlimit(RLIMIT_RTPRIO, &limit) == 0)
    c.rtprio_limit = limit.rlim_cur == RLIM_INFINITY ? -1 : static_cast<long long>(limit.rlim_cur);
  c.cgroup = cgroup_of_cpu_controller(read_text("/proc/self/cgroup"), &c.cgroup_v1);
  // The kernel's build options, where the distribution installs them.
  utsname u{};
  if (uname(&u) == 0) {
    const std::string config = read_text(("/boot/config-" + std::string(u.release)).c_str());
    if (config.find("\nCONFIG_RT_GROUP_SCHED=y") != std::string::npos)
      c.rt_group_sched = 1;
    else if (!config.empty())
      c.rt_group_sched = 0;
  }
  const std::string runtime = read_text("/proc/sys/kernel/sched_rt_runtime_us");
  if (!runtime.empty()) c.rt_runtime_us = std::atoll(runtime.c_str());
  return c;
}

SpinPlan plan_haptic_spin(double rate_hz, int haptic_cpu, const std::string& env) {
  SpinPlan p;
  if (!(std::isfinite(rate_hz) && rate_hz > 0)) {
    p.note = "the haptic thread sleeps to each tick (no valid rate)";
    return p;
  }
  const double period_us = 1e6 / rate_hz;
  // The spin leaves a sleep of kHapticSleepUs, between the least share and
  // 60% of the period; asked-for spins leave at least the least share.
  const double sleep_us = std::max(kHapticMinSleepShare * period_us, std::min(kHapticSleepUs, 0.6 * period_us));
  const double fallback = haptic_cpu >= 0 ? period_us - sleep_us : 0.0;
  const double most_us = (1 - kHapticMinSleepShare) * period_us;
  char text[200];
  if (!env.empty()) {
    // "off" reads as 0 us; otherwise the whole text must be a number >= 0.
    const bool off = env == "off";
    char* end = nullptr;
    const double us = off ? 0.0 : std::strtod(env.c_str(), &end);
    if (off || (end != env.c_str() && *end == '\0' && std::isfinite(us) && us >= 0)) {
      p.spin_us = std::min(us, most_us) + 0.0;  // + 0.0: no "-0"
      char cap[80] = "";
      if (p.spin_us < us)
        std::snprintf(cap, sizeof cap, ", capped: it sleeps %.0f us, %.0f%% of the period", period_us - p.spin_us,
                      100 * kHapticMinSleepShare);
      if (p.spin_us > 0)
        std::snprintf(text, sizeof text, "the haptic thread spins the last %.0f us of each %.0f us period (PALPA_HAPTIC_SPIN=%s%s)",
                      p.spin_us, period_us, env.c_str(), cap);
      else
        std::snprintf(text, sizeof text, "the haptic thread sleeps to each tick (PALPA_HAPTIC_SPIN=%s)", env.c_str());
      p.note = text;
      return p;
    }
    p.note = "PALPA_HAPTIC_SPIN='" + env + "' is neither 'off' nor a number of microseconds >= 0; using the default: ";
  }
  p.spin_us = fallback;
  if (p.spin_us > 0) {
    std::snprintf(text, sizeof text,
                  "the haptic thread spins the last %.0f us of each %.0f us period on CPU %d (it sleeps %.0f us)",
                  p.spin_us, period_us, haptic_cpu, period_us - p.spin_us);
  } else {
    std::snprintf(text, sizeof text, "the haptic thread sleeps to each tick (no CPU kept for it)");
  }
  p.note += text;
  return p;
}

SpinPlan haptic_spin(double rate_hz, int haptic_cpu) {
  const char* env = std::getenv("PALPA_HAPTIC_SPIN");
  return plan_haptic_spin(rate_hz, haptic_cpu, env ? env : "");
}

std::string realtime_refused_advice(int error, int priority, const RealtimeContext& c) {
  if (error != EPERM) return "the system refused it; see sched_setscheduler(2) for " + std::string(std::strerror(error));
  // The kernel asks for CAP_SYS_NICE or an rtprio limit, not for user id 0.
  const bool allowed = c.cap_sys_nice || c.rtprio_limit < 0 || c.rtprio_limit >= priority;
  if (!allowed && c.root)
    return "Palpa runs as root but without CAP_SYS_NICE (a container drops it: give it back, e.g. docker run "
           "--cap-add=SYS_NICE)";
  if (!allowed)
    return "grant CAP_SYS_NICE or an rtprio limit of at least " + std::to_string(priority) +
           " (ulimit -r, /etc/security/limits.conf) to the user running Palpa";
  if (c.rt_runtime_us == 0)
    return "the process may use it, but the kernel gives real-time threads no CPU time "
           "(kernel.sched_rt_runtime_us = 0); set it to 950000, the default";
  if (!c.cgroup.empty() && c.cgroup != "/" && c.rt_group_sched != 0) {
    const std::string how = c.cgroup_v1 ? "(as root: echo PID > /sys/fs/cgroup/cpu/tasks) or give its group a "
                                          "cpu.rt_runtime_us"
                                        : "(as root: echo PID > /sys/fs/cgroup/cgroup.procs)";
    return "the process may use it, but its control group " + c.cgroup + " has no real-time CPU time" +
           (c.rt_group_sched == 1 ? " (this kernel has RT group scheduling, which gives child groups none)"
                                  : " if the kernel has RT group scheduling (which gives child groups none)") +
           "; run Palpa in the root group " + how;
  }
  return "the process may use it, and the kernel refused it anyway (a security module?)";
}

std::vector<MemoryMonitor> running_memory_monitors(const std::string& damon_admin) {
  namespace fs = std::filesystem;
  std::vector<MemoryMonitor> found;
  std::error_code ec;
  const fs::path kdamonds = fs::path(damon_admin) / "kdamonds";
  for (fs::directory_iterator it(kdamonds, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
    if (first_word_of(it->path() / "state") != "on") continue;
    MemoryMonitor m;
    m.index = std::atoi(name.c_str());
    const fs::path context = it->path() / "contexts" / "0";
    m.operations = first_word_of(context / "operations");
    const std::string sample = first_word_of(context / "monitoring_attrs" / "intervals" / "sample_us");
    char* rest = nullptr;
    const long long us = sample.empty() ? -1 : std::strtoll(sample.c_str(), &rest, 10);
    m.sample_us = (rest && *rest == '\0' && us >= 0) ? us : -1;
    found.push_back(m);
  }
  std::sort(found.begin(), found.end(),
            [](const MemoryMonitor& a, const MemoryMonitor& b) { return a.index < b.index; });
  return found;
}

std::string memory_monitor_notice(const std::vector<MemoryMonitor>& monitors) {
  if (monitors.empty()) return "";
  std::string which, stop;
  for (const MemoryMonitor& m : monitors) {
    if (!which.empty()) which += ", ";
    which += "kdamond." + std::to_string(m.index);
    if (!m.operations.empty() || m.sample_us >= 0) {
      which += " (";
      if (m.operations == "paddr") which += "physical memory";
      else if (!m.operations.empty()) which += m.operations;
      if (m.sample_us >= 0) {
        char every[48];
        std::snprintf(every, sizeof every, "%ssampled every %g ms", m.operations.empty() ? "" : ", ",
                      static_cast<double>(m.sample_us) * 1e-3);
        which += every;
      }
      which += ")";
    }
    if (!stop.empty()) stop += "; ";
    stop += "echo off > " + std::string(kDamonAdmin) + "/kdamonds/" + std::to_string(m.index) + "/state";
  }
  return "DAMON is monitoring memory on this machine: " + which +
         ". On a 2-core virtual machine the haptic thread missed up to 0.36% of its 1 kHz deadlines while the "
         "software renderer drew with DAMON running, and at most 0.08% with it off (docs/PERFORMANCE.md, "
         "round 18). To stop it, as root: " + stop;
}

}  // namespace palpa::haptics
