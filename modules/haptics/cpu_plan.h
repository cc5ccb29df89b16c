#pragma once
// Where the live loop's threads run. On a machine with few cores the
// software renderer (llvmpipe starts one worker per CPU), the deformation
// thread and the GUI compete with the haptic thread: even at SCHED_FIFO
// priority it then wakes into caches the others have filled and shares a
// core's time with interrupts of their work. reserve_haptic_cpu() keeps one
// CPU for the haptic thread alone and everything else off it.

#include <string>
#include <vector>

namespace palpa::haptics {

/// What reserve_haptic_cpu() decided.
struct CpuPlan {
  int haptic_cpu = -1;         ///< the CPU kept for the haptic thread (LoopConfig::haptic_cpu); -1: none
  std::vector<int> others;     ///< the CPUs every other thread of the process may use
  int renderer_threads = 0;    ///< LP_NUM_THREADS given to llvmpipe (0: left as it was)
  std::string note;            ///< one line for logs and the Diagnostics dock
};

/// Call first thing in main(), before any other thread and before an
/// OpenGL context exists. With two or more CPUs allowed (sched_getaffinity),
/// keeps for the haptic thread the one that has handled the fewest device
/// interrupts (/proc/interrupts; the highest on a tie): the calling thread, and so
/// every thread it starts later (the GUI's, VTK's, llvmpipe's workers, the
/// deformation thread), may run only on the others, and llvmpipe is told to
/// start one worker per remaining CPU (LP_NUM_THREADS, unless the
/// environment already sets it). The haptic thread pins itself to
/// haptic_cpu when the loop starts (LoopConfig::haptic_cpu). With one CPU,
/// or PALPA_HAPTIC_CPU=off in the environment, nothing changes;
/// PALPA_HAPTIC_CPU=N keeps CPU N instead (when it is allowed). Remembered
/// for reserved_haptic_cpu(); calling it again returns the first plan.
CpuPlan reserve_haptic_cpu();

/// The CPU reserve_haptic_cpu() kept, or -1 (not called, or nothing kept).
int reserved_haptic_cpu();

/// The decision alone (what reserve_haptic_cpu applies): among `allowed`
/// CPUs, the haptic CPU and the others. `interrupts`: device interrupts per
/// CPU number (device_interrupts_per_cpu); `env`: PALPA_HAPTIC_CPU's value
/// ("" when unset). renderer_threads is the count of the others.
CpuPlan plan_cpus(const std::vector<int>& allowed, const std::vector<unsigned long long>& interrupts,
                  const std::string& env);

/// Sums, per CPU, the numbered (device) lines of /proc/interrupts' text;
/// the per-CPU lines (LOC, RES, NMI, ...) are left out. Indexed by CPU
/// number; empty for an empty text.
std::vector<unsigned long long> device_interrupts_per_cpu(const std::string& proc_interrupts_text);

/// The busy-wait before each tick (LoopConfig::spin_us) that a haptic thread
/// with a CPU of its own should use.
struct SpinPlan {
  double spin_us = 0;  ///< us before each tick's start (0: sleep to the start)
  std::string note;    ///< one line: what was chosen and why, or what was wrong with `env`
};

/// With a CPU kept for the haptic thread (haptic_cpu >= 0), 40% of the
/// period: the thread wakes that early and spins to the tick's start, so
/// the start no longer waits for the CPU to come out of idle. On the
/// 16-CPU GPU machine that took missed deadlines from 0.015-0.058% to
/// 0-0.007% and the start latency's p99 from 47-59 us to under 1 us;
/// on a 2-core VM it about halved them (docs/PERFORMANCE.md, round 7).
/// Without a kept CPU, 0 (the spin would take time from other threads).
/// `env` is PALPA_HAPTIC_SPIN's value: "" (the default above), "off" (0),
/// or a number of us, capped at half the period (a SCHED_FIFO thread that
/// never sleeps is throttled by the kernel); anything else keeps the
/// default and says so in the note. `rate_hz`: the haptic rate, Hz.
SpinPlan plan_haptic_spin(double rate_hz, int haptic_cpu, const std::string& env);

/// plan_haptic_spin with PALPA_HAPTIC_SPIN read from the environment (the
/// workbench and palpa-loop-bench use this).
SpinPlan haptic_spin(double rate_hz, int haptic_cpu);

/// What decides whether this process may run a thread at SCHED_FIFO, read
/// from /proc by read_realtime_context().
struct RealtimeContext {
  bool root = false;           ///< effective user id 0
  bool cap_sys_nice = false;   ///< CAP_SYS_NICE in the effective capabilities
  long long rtprio_limit = 0;  ///< RLIMIT_RTPRIO's soft limit (-1: unlimited)
  std::string cgroup;          ///< the control group of the CPU controller ("/": the root; "": unknown)
  bool cgroup_v1 = false;      ///< that controller is on a cgroup v1 hierarchy
  int rt_group_sched = -1;     ///< CONFIG_RT_GROUP_SCHED in /boot/config-RELEASE: 1 yes, 0 no, -1 unknown
  long long rt_runtime_us = -1;  ///< kernel.sched_rt_runtime_us, us per period (-1: no limit, or unknown)
};

/// Reads the context from /proc/self/status, /proc/self/cgroup,
/// /proc/sys/kernel/sched_rt_runtime_us, /boot/config-RELEASE and getrlimit. Not for the haptic
/// thread (file reads): HapticLoop calls it in start().
RealtimeContext read_realtime_context();

/// The CPU controller's group in /proc/self/cgroup's text: the v1 line
/// naming "cpu" (in a hybrid layout the "0::" line is systemd's, without
/// controllers), else the "0::" line (cgroup v2); "" when neither is there.
/// `on_v1`, when given, says whether the group came from a v1 line.
std::string cgroup_of_cpu_controller(const std::string& proc_self_cgroup_text, bool* on_v1 = nullptr);

/// Whether /proc/self/status's text gives CAP_SYS_NICE (bit 23) in CapEff.
bool has_cap_sys_nice(const std::string& proc_self_status_text);

/// The advice when SCHED_FIFO at `priority` was refused with `error`
/// (pthread_setschedparam's): what stands in the way and what to change.
/// The kernel gives the right with CAP_SYS_NICE or an rtprio limit of at
/// least `priority` (root without CAP_SYS_NICE, as in a container, has
/// none). Where the process has it and is still refused, the kernel gives
/// its control group no real-time CPU time (RT group scheduling), or none
/// to anyone (sched_rt_runtime_us = 0).
std::string realtime_refused_advice(int error, int priority, const RealtimeContext& context);

}  // namespace palpa::haptics
