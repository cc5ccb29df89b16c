// Where the loop's threads run (haptics/cpu_plan.h): the decision on given
// CPUs and interrupt counts, the /proc/interrupts parser, and the
// reservation applied to this process.

#include "haptics/cpu_plan.h"

#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

namespace palpa::haptics {
namespace {

std::vector<int> affinity_of_this_thread() {
  cpu_set_t set;
  CPU_ZERO(&set);
  EXPECT_EQ(pthread_getaffinity_np(pthread_self(), sizeof set, &set), 0);
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &set)) cpus.push_back(c);
  return cpus;
}

TEST(CpuPlan, ParsesTheDeviceLinesOfProcInterrupts) {
  // The layout of Linux's /proc/interrupts (3 CPUs, one offline column gap).
  const std::string text =
      "           CPU0       CPU1       CPU3       \n"
      " 28:          5          0          1 PCI-MSIX-0000:00:01.0   0-edge      virtio0-config\n"
      " 36:          0     596674          9 PCI-MSIX-0000:00:02.0   1-edge      virtio1-req.0\n"
      "  9:          2          0 IO-APIC   9-fasteoi   acpi\n"
      "NMI:          0          0          0   Non-maskable interrupts\n"
      "LOC:     900000     900000     900000   Local timer interrupts\n"
      "ERR:          0\n";
  const auto n = device_interrupts_per_cpu(text);
  ASSERT_EQ(n.size(), 4u);
  EXPECT_EQ(n[0], 7u);
  EXPECT_EQ(n[1], 596674u);
  EXPECT_EQ(n[2], 0u);  // no such column
  EXPECT_EQ(n[3], 10u);
  EXPECT_TRUE(device_interrupts_per_cpu("").empty());
}

TEST(CpuPlan, KeepsTheCpuWithTheFewestDeviceInterrupts) {
  // The 2-CPU VM: the disk's interrupts all on CPU 1.
  CpuPlan p = plan_cpus({0, 1}, {2904, 608190}, "");
  EXPECT_EQ(p.haptic_cpu, 0);
  EXPECT_EQ(p.others, std::vector<int>({1}));
  EXPECT_EQ(p.renderer_threads, 1);
  EXPECT_NE(p.note.find("CPU 0 kept"), std::string::npos) << p.note;
  // A tie (or no counts): the highest.
  p = plan_cpus({0, 1, 2, 3}, {}, "");
  EXPECT_EQ(p.haptic_cpu, 3);
  EXPECT_EQ(p.others, std::vector<int>({0, 1, 2}));
  EXPECT_EQ(p.renderer_threads, 3);
  // Only allowed CPUs count, whatever the counts of others.
  p = plan_cpus({2, 5}, {0, 0, 50, 0, 0, 70}, "");
  EXPECT_EQ(p.haptic_cpu, 2);
  EXPECT_EQ(p.others, std::vector<int>({5}));
}

TEST(CpuPlan, OneCpuOrOffKeepsNothingAndABadChoiceSaysWhy) {
  CpuPlan p = plan_cpus({0}, {}, "");
  EXPECT_EQ(p.haptic_cpu, -1);
  EXPECT_EQ(p.others, std::vector<int>({0}));
  EXPECT_NE(p.note.find("only one CPU"), std::string::npos) << p.note;
  p = plan_cpus({0, 1}, {}, "off");
  EXPECT_EQ(p.haptic_cpu, -1);
  EXPECT_NE(p.note.find("PALPA_HAPTIC_CPU=off"), std::string::npos) << p.note;
  p = plan_cpus({0, 1}, {0, 100}, "1");  // chosen by hand, against the interrupts
  EXPECT_EQ(p.haptic_cpu, 1);
  EXPECT_EQ(p.others, std::vector<int>({0}));
  for (const char* bad : {"7", "x", "1x", ""}) {
    if (*bad == '\0') continue;
    p = plan_cpus({0, 1}, {}, bad);
    EXPECT_EQ(p.haptic_cpu, -1) << bad;
    EXPECT_NE(p.note.find(std::string("PALPA_HAPTIC_CPU=") + bad + " is not a CPU"), std::string::npos) << p.note;
  }
}

TEST(CpuPlan, ReadsAndSetsTheCpusOfTheCallingThreadAndDecidesWithoutApplying) {
  // On a thread of its own, so the test's thread keeps its CPUs.
  std::thread([] {
    const std::vector<int> mine = affinity_of_this_thread();
    EXPECT_EQ(cpus_of_this_thread(), mine);
    EXPECT_EQ(run_this_thread_on({}), EINVAL);
    EXPECT_EQ(affinity_of_this_thread(), mine);
    // The decision changes nothing: "off" keeps nothing and leaves every CPU
    // to the others; naming the last allowed CPU keeps it.
    const CpuPlan off = decide_haptic_cpu("off");
    EXPECT_EQ(off.haptic_cpu, -1);
    EXPECT_EQ(off.others, mine);
    if (mine.size() >= 2) {
      const CpuPlan last = decide_haptic_cpu(std::to_string(mine.back()));
      EXPECT_EQ(last.haptic_cpu, mine.back());
      EXPECT_EQ(last.others, std::vector<int>(mine.begin(), mine.end() - 1));
    } else {
      std::printf("one CPU allowed: no CPU to keep (%s)\n", decide_haptic_cpu("").note.c_str());
    }
    EXPECT_EQ(affinity_of_this_thread(), mine);
    ASSERT_FALSE(mine.empty());
    EXPECT_EQ(run_this_thread_on({mine.front()}), 0);
    EXPECT_EQ(affinity_of_this_thread(), std::vector<int>{mine.front()});
    EXPECT_EQ(cpus_of_this_thread(), std::vector<int>{mine.front()});
  }).join();
}

TEST(CpuPlan, PreparingAHapticThreadPinsItTightensItsTimerSlackAndAsksForSchedFifo) {
  std::thread([] {
    const std::vector<int> mine = affinity_of_this_thread();
    ASSERT_FALSE(mine.empty());
    prctl(PR_SET_TIMERSLACK, 50000UL, 0, 0, 0);  // the kernel's default, 50 us
    // No priority: pinned and 1 ns of slack, the policy untouched.
    EXPECT_EQ(prepare_haptic_thread(mine.back(), 0), 0);
    EXPECT_EQ(affinity_of_this_thread(), std::vector<int>{mine.back()});
    EXPECT_EQ(prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0), 1);
    EXPECT_EQ(sched_getscheduler(0), SCHED_OTHER);
    // Priority 80: SCHED_FIFO where the process may, else the error and the
    // policy as it was (said, not skipped).
    const int rc = prepare_haptic_thread(-1, 80);
    if (rc == 0) {
      EXPECT_EQ(sched_getscheduler(0), SCHED_FIFO);
      sched_param p{};
      pthread_setschedparam(pthread_self(), SCHED_OTHER, &p);
    } else {
      std::printf("SCHED_FIFO not allowed here (%s): the thread kept its policy\n", std::strerror(rc));
      EXPECT_EQ(sched_getscheduler(0), SCHED_OTHER);
    }
    // cpu -1 leaves the CPUs as they were.
    EXPECT_EQ(affinity_of_this_thread(), std::vector<int>{mine.back()});
  }).join();
}

TEST(CpuPlan, ReservingMovesThisThreadAndLaterThreadsOffTheHapticCpu) {
  const std::vector<int> before = affinity_of_this_thread();
  const bool lp_was_set = std::getenv("LP_NUM_THREADS") != nullptr;
  const CpuPlan p = reserve_haptic_cpu();
  if (before.size() < 2) {
    // Said, not skipped silently: on one CPU nothing is kept.
    std::printf("one CPU allowed: nothing kept (%s)\n", p.note.c_str());
    EXPECT_EQ(p.haptic_cpu, -1);
    EXPECT_EQ(reserved_haptic_cpu(), -1);
    return;
  }
  if (const char* env = std::getenv("PALPA_HAPTIC_CPU"); env && std::string(env) == "off") {
    std::printf("PALPA_HAPTIC_CPU=off: nothing kept (%s)\n", p.note.c_str());
    EXPECT_EQ(p.haptic_cpu, -1);
    return;
  }
  ASSERT_GE(p.haptic_cpu, 0) << p.note;
  EXPECT_EQ(reserved_haptic_cpu(), p.haptic_cpu);
  EXPECT_EQ(affinity_of_this_thread(), p.others);
  std::vector<int> child;
  std::thread([&] { child = affinity_of_this_thread(); }).join();
  EXPECT_EQ(child, p.others);  // inherited: the renderer's and the deformation's threads
  if (!lp_was_set) {
    ASSERT_NE(std::getenv("LP_NUM_THREADS"), nullptr);
    EXPECT_EQ(std::string(std::getenv("LP_NUM_THREADS")), std::to_string(p.others.size()));
  }
  // The second call returns the first plan and changes nothing more.
  const CpuPlan again = reserve_haptic_cpu();
  EXPECT_EQ(again.haptic_cpu, p.haptic_cpu);
  EXPECT_EQ(affinity_of_this_thread(), p.others);
}

TEST(HapticSpin, SleepsAHundredMicrosecondsOrFifteenPercentOfThePeriodOnAKeptCpu) {
  // 1 kHz: 1000 us period, a 150 us sleep (15% of it); 4 kHz: 250 us, 100 us.
  EXPECT_DOUBLE_EQ(plan_haptic_spin(1000, 1, "").spin_us, 850);
  EXPECT_DOUBLE_EQ(plan_haptic_spin(4000, 0, "").spin_us, 150);
  // 10 kHz: a 100 us period sleeps 60% of it (the spin is never below 40%).
  EXPECT_DOUBLE_EQ(plan_haptic_spin(10000, 0, "").spin_us, 40);
  // 500 Hz and 100 Hz: at least 15% of the period asleep (the kernel
  // throttles a real-time thread that runs more than 95% of a second).
  EXPECT_DOUBLE_EQ(plan_haptic_spin(500, 0, "").spin_us, 1700);
  EXPECT_DOUBLE_EQ(plan_haptic_spin(100, 0, "").spin_us, 8500);
  const SpinPlan at_1k = plan_haptic_spin(1000, 1, "");
  EXPECT_NE(at_1k.note.find("CPU 1"), std::string::npos) << at_1k.note;
  EXPECT_NE(at_1k.note.find("sleeps 150 us"), std::string::npos) << at_1k.note;
  // Over a sweep of rates: the sleep (period - spin) is at least 15% of the
  // period and at most 60% of it, and at most 100 us where 15% is less.
  for (double rate = 50; rate <= 20000; rate *= 1.25) {
    const double period = 1e6 / rate;
    const double sleep = period - plan_haptic_spin(rate, 0, "").spin_us;
    EXPECT_GE(sleep, 0.15 * period * (1 - 1e-12)) << rate;
    EXPECT_LE(sleep, 0.6 * period * (1 + 1e-12)) << rate;
    EXPECT_LE(sleep, std::max(100.0, 0.15 * period) * (1 + 1e-12)) << rate;
  }
  // No CPU of its own: spinning would take time from the other threads.
  const SpinPlan shared = plan_haptic_spin(1000, -1, "");
  EXPECT_EQ(shared.spin_us, 0);
  EXPECT_NE(shared.note.find("no CPU kept"), std::string::npos) << shared.note;
}

TEST(HapticSpin, TheEnvironmentTurnsItOffOrSetsItLeavingFifteenPercentOfThePeriodAsleep) {
  const SpinPlan off = plan_haptic_spin(1000, 1, "off");
  EXPECT_EQ(off.spin_us, 0);
  EXPECT_NE(off.note.find("sleeps to each tick (PALPA_HAPTIC_SPIN=off)"), std::string::npos) << off.note;
  for (const char* zero : {"0", "-0"}) {
    const SpinPlan z = plan_haptic_spin(1000, 1, zero);
    EXPECT_EQ(z.spin_us, 0) << zero;
    EXPECT_FALSE(std::signbit(z.spin_us)) << zero;
    EXPECT_NE(z.note.find("sleeps to each tick"), std::string::npos) << z.note;
  }
  EXPECT_DOUBLE_EQ(plan_haptic_spin(1000, 1, "1e3").spin_us, 850);  // capped
  EXPECT_EQ(plan_haptic_spin(0, 1, "").spin_us, 0);                  // no valid rate: no spin
  EXPECT_EQ(plan_haptic_spin(std::nan(""), 1, "").spin_us, 0);
  EXPECT_DOUBLE_EQ(plan_haptic_spin(1000, 1, "150").spin_us, 150);
  EXPECT_DOUBLE_EQ(plan_haptic_spin(1000, -1, "150").spin_us, 150);  // asked for: also without a kept CPU
  // Never more than 85% of the period (a real-time thread that never sleeps
  // is throttled by the kernel).
  const SpinPlan most = plan_haptic_spin(1000, 1, "850");
  EXPECT_DOUBLE_EQ(most.spin_us, 850);
  EXPECT_EQ(most.note.find("capped"), std::string::npos) << most.note;
  const SpinPlan capped = plan_haptic_spin(1000, 1, "900");
  EXPECT_DOUBLE_EQ(capped.spin_us, 850);
  EXPECT_NE(capped.note.find("capped: it sleeps 150 us, 15% of the period"), std::string::npos) << capped.note;
  EXPECT_DOUBLE_EQ(plan_haptic_spin(4000, 1, "250").spin_us, 212.5);
  // Garbage keeps the default and names the value.
  for (const char* bad : {"fast", "-5", "12us", "nan", "inf"}) {
    const SpinPlan p = plan_haptic_spin(1000, 1, bad);
    EXPECT_DOUBLE_EQ(p.spin_us, 850) << bad;
    EXPECT_NE(p.note.find(std::string("PALPA_HAPTIC_SPIN='") + bad + "'"), std::string::npos) << p.note;
  }
}

TEST(RealtimeRefused, FindsTheCpuControllersGroup) {
  // cgroup v2 (one "0::" line), as on the GPU machine that refused root.
  EXPECT_EQ(cgroup_of_cpu_controller("0::/process_api/512b2cf5\n"), "/process_api/512b2cf5");
  EXPECT_EQ(cgroup_of_cpu_controller("0::/\n"), "/");
  // cgroup v1: the line whose controller list holds "cpu" (not "cpuset").
  EXPECT_EQ(cgroup_of_cpu_controller("5:cpuset:/a\n4:cpu,cpuacct:/user.slice\n1:name=systemd:/b\n"), "/user.slice");
  // Hybrid: the CPU controller is on the v1 line; "0::" is systemd's then.
  EXPECT_EQ(cgroup_of_cpu_controller("4:cpu,cpuacct:/v1\n0::/v2\n"), "/v1");
  EXPECT_EQ(cgroup_of_cpu_controller("0::/v2\n4:cpuacct,cpu:/v1\n"), "/v1");
  // A v1 layout without the cpu controller mounted: no group for it.
  EXPECT_EQ(cgroup_of_cpu_controller("5:cpuset:/a\n"), "");
  EXPECT_EQ(cgroup_of_cpu_controller(""), "");
  EXPECT_EQ(cgroup_of_cpu_controller("garbage\n"), "");
  // Which hierarchy the group came from (the advice names each one's file).
  bool v1 = true;
  EXPECT_EQ(cgroup_of_cpu_controller("0::/process_api/512b2cf5\n", &v1), "/process_api/512b2cf5");
  EXPECT_FALSE(v1);
  EXPECT_EQ(cgroup_of_cpu_controller("4:cpu,cpuacct:/v1\n0::/v2\n", &v1), "/v1");
  EXPECT_TRUE(v1);
  EXPECT_EQ(cgroup_of_cpu_controller("5:cpuset:/a\n0::/v2\n", &v1), "/v2");
  EXPECT_FALSE(v1);
}

TEST(RealtimeRefused, ReadsCapSysNiceFromTheEffectiveSet) {
  // Bit 23 is CAP_SYS_NICE; only CapEff counts (CapPrm may hold it unused).
  EXPECT_TRUE(has_cap_sys_nice("Name:\tpalpa\nCapPrm:\t0000000000000000\nCapEff:\t0000000000800000\n"));
  EXPECT_FALSE(has_cap_sys_nice("CapPrm:\t0000000000800000\nCapEff:\t00000000007fffff\n"));
  EXPECT_TRUE(has_cap_sys_nice("CapEff:\t000001ffffffffff\n"));  // root's full set
  EXPECT_FALSE(has_cap_sys_nice("Name:\tpalpa\n"));
}

TEST(RealtimeRefused, SaysWhatStandsInTheWay) {
  RealtimeContext user;  // no right at all
  user.cgroup = "/user.slice/user-1000.slice";
  user.rt_runtime_us = 950000;
  const std::string no_right = realtime_refused_advice(EPERM, 80, user);
  EXPECT_NE(no_right.find("CAP_SYS_NICE"), std::string::npos) << no_right;
  EXPECT_NE(no_right.find("at least 80"), std::string::npos) << no_right;
  EXPECT_EQ(no_right.find("root group"), std::string::npos) << no_right;

  // An rtprio limit below the priority asked for is no right either; at it,
  // or unlimited, it is.
  RealtimeContext limit = user;
  limit.rtprio_limit = 79;
  EXPECT_NE(realtime_refused_advice(EPERM, 80, limit).find("CAP_SYS_NICE"), std::string::npos);
  for (long long l : {80LL, 99LL, -1LL}) {
    limit.rtprio_limit = l;
    EXPECT_NE(realtime_refused_advice(EPERM, 80, limit).find("may use it"), std::string::npos) << l;
  }
  // CAP_SYS_NICE alone is the right.
  RealtimeContext cap = user;
  cap.cap_sys_nice = true;
  EXPECT_NE(realtime_refused_advice(EPERM, 80, cap).find("may use it"), std::string::npos);

  // Root is not the right: a container's root without CAP_SYS_NICE.
  RealtimeContext container_root = user;
  container_root.root = true;
  const std::string cr = realtime_refused_advice(EPERM, 80, container_root);
  EXPECT_NE(cr.find("root but without CAP_SYS_NICE"), std::string::npos) << cr;
  EXPECT_NE(cr.find("--cap-add=SYS_NICE"), std::string::npos) << cr;

  // Root with the capability in a child group of a kernel with RT group
  // scheduling (the H200 machine: refused, then allowed once moved to the
  // root group), and a user with an rtprio limit in the same place.
  RealtimeContext boxed;
  boxed.root = true;
  boxed.cap_sys_nice = true;
  boxed.cgroup = "/process_api/512b2cf5";
  boxed.rt_runtime_us = 950000;
  boxed.rt_group_sched = 1;
  RealtimeContext limited = boxed;
  limited.root = false;
  limited.cap_sys_nice = false;
  limited.rtprio_limit = 99;
  for (const RealtimeContext& c : {boxed, limited}) {
    const std::string a = realtime_refused_advice(EPERM, 80, c);
    EXPECT_NE(a.find("/process_api/512b2cf5"), std::string::npos) << a;
    EXPECT_NE(a.find("this kernel has RT group scheduling"), std::string::npos) << a;
    EXPECT_NE(a.find("/sys/fs/cgroup/cgroup.procs"), std::string::npos) << a;  // v2's file
    EXPECT_EQ(a.find("CAP_SYS_NICE"), std::string::npos) << a;
  }
  // The same on cgroup v1: its own file and the group's budget.
  RealtimeContext v1 = boxed;
  v1.cgroup_v1 = true;
  const std::string a1 = realtime_refused_advice(EPERM, 80, v1);
  EXPECT_NE(a1.find("/sys/fs/cgroup/cpu/tasks"), std::string::npos) << a1;
  EXPECT_NE(a1.find("cpu.rt_runtime_us"), std::string::npos) << a1;
  // Not known whether the kernel has it: said as a condition.
  RealtimeContext unknown = boxed;
  unknown.rt_group_sched = -1;
  EXPECT_NE(realtime_refused_advice(EPERM, 80, unknown).find("if the kernel has RT group scheduling"), std::string::npos);
  // Known not to have it: the group is not blamed (a desktop's user slice).
  RealtimeContext plain = boxed;
  plain.rt_group_sched = 0;
  EXPECT_EQ(realtime_refused_advice(EPERM, 80, plain).find("control group"), std::string::npos);

  // No real-time time for anyone.
  RealtimeContext none = boxed;
  none.rt_runtime_us = 0;
  EXPECT_NE(realtime_refused_advice(EPERM, 80, none).find("sched_rt_runtime_us = 0"), std::string::npos);

  // Allowed, in the root group, with time, and still refused.
  RealtimeContext odd = boxed;
  odd.cgroup = "/";
  const std::string a = realtime_refused_advice(EPERM, 80, odd);
  EXPECT_EQ(a.find("root group"), std::string::npos) << a;
  EXPECT_NE(a.find("refused it anyway"), std::string::npos) << a;

  // Another error is named as it is.
  EXPECT_NE(realtime_refused_advice(EINVAL, 80, boxed).find(std::strerror(EINVAL)), std::string::npos);
}

// A DAMON sysfs tree (kdamonds/N/state, contexts/0/operations,
// contexts/0/monitoring_attrs/intervals/sample_us) in a temporary folder.
class DamonTree {
 public:
  DamonTree() {
    root_ = std::filesystem::temp_directory_path() /
            ("palpa-damon-" + std::to_string(::getpid()) + "-" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_ / "kdamonds");
    write("kdamonds/nr_kdamonds", "0\n");
  }
  ~DamonTree() { std::filesystem::remove_all(root_); }
  void add(int n, const std::string& state, const std::string& operations, const std::string& sample_us) {
    const std::string k = "kdamonds/" + std::to_string(n);
    std::filesystem::create_directories(root_ / k / "contexts/0/monitoring_attrs/intervals");
    write(k + "/state", state + "\n");
    if (!operations.empty()) write(k + "/contexts/0/operations", operations + "\n");
    if (!sample_us.empty()) write(k + "/contexts/0/monitoring_attrs/intervals/sample_us", sample_us + "\n");
  }
  std::string path() const { return root_.string(); }

 private:
  void write(const std::string& rel, const std::string& text) { std::ofstream(root_ / rel) << text; }
  std::filesystem::path root_;
};

TEST(MemoryMonitor, FindsTheKdamondsThatAreOnWithWhatTheySample) {
  DamonTree t;
  t.add(0, "on", "paddr", "500000");
  t.add(1, "off", "vaddr", "5000");
  t.add(12, "on", "vaddr", "");  // sampling interval unreadable
  t.add(2, "on", "", "bogus");   // no operations file, a sampling interval that is no number
  const std::vector<MemoryMonitor> m = running_memory_monitors(t.path());
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].index, 0);
  EXPECT_EQ(m[0].operations, "paddr");
  EXPECT_EQ(m[0].sample_us, 500000);
  EXPECT_EQ(m[1].index, 2);
  EXPECT_EQ(m[1].operations, "");
  EXPECT_EQ(m[1].sample_us, -1);
  EXPECT_EQ(m[2].index, 12);
  EXPECT_EQ(m[2].operations, "vaddr");
  EXPECT_EQ(m[2].sample_us, -1);

  const std::string notice = memory_monitor_notice(m);
  EXPECT_NE(notice.find("kdamond.0 (physical memory, sampled every 500 ms)"), std::string::npos) << notice;
  EXPECT_NE(notice.find("kdamond.12 (vaddr)"), std::string::npos) << notice;
  EXPECT_NE(notice.find("kdamond.2,"), std::string::npos) << notice;
  EXPECT_EQ(notice.find("kdamond.1 "), std::string::npos) << notice;  // off: not named
  EXPECT_NE(notice.find("echo off > /sys/kernel/mm/damon/admin/kdamonds/0/state; "
                        "echo off > /sys/kernel/mm/damon/admin/kdamonds/2/state; "
                        "echo off > /sys/kernel/mm/damon/admin/kdamonds/12/state"),
            std::string::npos)
      << notice;
}

TEST(MemoryMonitor, SaysNothingWithoutARunningKdamond) {
  DamonTree t;
  EXPECT_TRUE(running_memory_monitors(t.path()).empty());
  t.add(0, "off", "paddr", "500000");
  EXPECT_TRUE(running_memory_monitors(t.path()).empty());
  EXPECT_TRUE(running_memory_monitors(t.path() + "/no-such-folder").empty());
  EXPECT_EQ(memory_monitor_notice({}), "");
}

}  // namespace
}  // namespace palpa::haptics
