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

/// reserve_haptic_cpu's decision for the calling thread, without applying
/// it: the CPUs it may use and /proc/interrupts through plan_cpus, with
/// `env` as PALPA_HAPTIC_CPU's value. palpa-bench's threaded run places its
/// threads by it.
CpuPlan decide_haptic_cpu(const std::string& env);

/// The CPUs the calling thread may run on (sched_getaffinity), ascending;
/// empty when the system does not say (errno tells why).
std::vector<int> cpus_of_this_thread();

/// Lets the calling thread run only on `cpus`. Returns 0, or the error
/// pthread_setaffinity_np gave (EINVAL for an empty list).
int run_this_thread_on(const std::vector<int>& cpus);

/// Sets up the calling thread as the haptic thread runs: only on `cpu`
/// (when >= 0), at SCHED_FIFO with `priority` (when > 0), and with a timer
/// slack of 1 ns so that its sleeps end when asked. Returns 0, or the error
/// pthread_setschedparam gave (the thread then keeps its policy). The
/// loop's haptic thread and palpa-loop-bench's machine floor use it.
int prepare_haptic_thread(int cpu, int priority);

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

/// Longest sleep (us) of a haptic thread with a CPU of its own between the
/// end of one tick and the spin before the next (where the period allows:
/// plan_haptic_spin). On a virtual machine a CPU that sleeps longer is
/// given back to the host: KVM keeps polling a halted virtual CPU for up to
/// 200 us (its halt_poll_ns default) before it schedules other work on the
/// physical one, and the wake then waits for the host. On the 2-core VM an
/// empty 1 kHz tick at SCHED_FIFO that slept 600 us a period started 1% of
/// its ticks 0.8 ms or more late and missed 0.8 to 1.7% of its deadlines;
/// one that slept 100 us missed 0.02%, its start's p99 0.1 us
/// (docs/PERFORMANCE.md, round 15).
inline constexpr double kHapticSleepUs = 100;
/// Least share of each period a haptic thread with a CPU of its own
/// sleeps: the kernel throttles a SCHED_FIFO thread that runs more than
/// 95% of a second (kernel.sched_rt_runtime_us 950000 of 1000000 by
/// default) for the rest of it, tens of milliseconds with no tick. A
/// virtual machine that does not report the time its host takes counts
/// that time as the thread's too (4 to 5% of a spinning thread's time on
/// the 2-core VM), hence 15% and not 5%.
inline constexpr double kHapticMinSleepShare = 0.15;

/// With a CPU kept for the haptic thread (haptic_cpu >= 0), the period less
/// a sleep of kHapticSleepUs, the sleep kept between kHapticMinSleepShare
/// and 60% of the period: at 1 kHz the thread sleeps 150 us and spins 850
/// us, at 4 kHz it sleeps 100 us and spins 150 us, at 10 kHz it spins
/// 40 us (40%, the share used before round 15). The thread wakes that early
/// and spins to the tick's start, so the start waits neither for the CPU to
/// come out of idle nor, on a virtual machine, for the host. On the 16-CPU
/// GPU machine a 40% spin took missed deadlines from 0.015-0.058% to
/// 0-0.007% and the start latency's p99 from 47-59 us to under 1 us (round
/// 7); on the 2-core VM, in palpa-loop-bench at 1 kHz, an 850 us spin took
/// them from 1.75-2.24% (400 us) to 0.21-0.25% (round 15). The CPU is kept for
/// this thread, so the spin takes no time from the others.
/// Without a kept CPU, 0 (the spin would take time from other threads).
/// `env` is PALPA_HAPTIC_SPIN's value: "" (the default above), "off" (0),
/// or a number of us, capped at 85% of the period so that the thread still
/// sleeps kHapticMinSleepShare of it; anything else keeps the
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

/// One DAMON monitoring thread (kdamond) found running.
struct MemoryMonitor {
  int index = -1;          ///< its number under kdamonds/ (its thread is kdamond.INDEX)
  std::string operations;  ///< its first context's address space: "paddr" (physical memory), "vaddr", "fvaddr"
  long long sample_us = -1;  ///< that context's sampling interval, us (-1: unknown)
};

/// DAMON's sysfs interface, where the kernel puts it.
inline constexpr const char* kDamonAdmin = "/sys/kernel/mm/damon/admin";

/// The kdamonds whose state is "on" under `damon_admin`, DAMON's sysfs
/// interface (kDamonAdmin); empty where there is none (no DAMON, or nothing
/// readable). File reads: not for the haptic thread.
std::vector<MemoryMonitor> running_memory_monitors(const std::string& damon_admin = kDamonAdmin);

/// What to tell the user about `monitors` ("" for none): each kdamond,
/// what it samples and how to stop it (under kDamonAdmin). DAMON samples memory by clearing the
/// page tables' accessed bits. On the 2-core VM of CI (a paravirtualised
/// guest, with kdamond.0 sampling physical memory every 500 ms) the haptic
/// thread missed 0.02 to 0.33% of its 1 kHz deadlines while llvmpipe drew
/// with DAMON running (0.16 to 0.36% in every run before it was restarted),
/// and 0 to 0.08% with it off; at 4 kHz it lost 1.7 to 7.9 times as many
/// periods with it running (docs/PERFORMANCE.md, round 18).
std::string memory_monitor_notice(const std::vector<MemoryMonitor>& monitors);

}  // namespace palpa::haptics
