// Crash safety: a recording process killed with SIGKILL at a random moment
// (PALPA_CRASH_KILLS times, 10 by default; tools/crash-test.sh runs 100)
// leaves a file that opens, says "interrupted", holds at least every tick
// the writer had reported committed (at most the batch in flight is lost),
// row counts that never went down while it was written, every tick's data
// as the script made it, and forces that replay bit for bit.

#include "record_rig.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <random>
#include <thread>

namespace palpa::record {
namespace {

using test::Rig;

// The child: records the scripted session at about 4x real time until
// killed, writing the committed tick count to `fd` after every commit.
[[noreturn]] void record_until_killed(const std::filesystem::path& file, int fd) {
  const Rig rig;
  auto s = rig.session();
  const auto map = rig.stiffness_map();
  RecorderOptions o;
  o.block_when_full = true;
  o.snapshot_interval_s = 0.5;
  Recorder r(file, *rig.model, rig.initial, rig.setups, Rig::info("crash"), o);
  std::array<haptics::ProbeTickInput, 2> in;
  std::array<haptics::ProbeTickResult, 2> out;
  std::uint64_t reported = 0;
  std::array<std::uint64_t, 2> msg{};  // ticks made, ticks committed
  const auto start = std::chrono::steady_clock::now();
  for (std::uint64_t n = 0;; ++n) {
    rig.commands(r, *s, n, map);
    for (std::size_t j = 0; j < 2; ++j) in[j] = test::input(j, n);
    record_step(r, *s, static_cast<double>(n) * 1e-3, in, out);
    const auto c = r.stats().ticks_committed;
    if (c != reported || n % 16 == 0) {
      reported = c;
      msg = {n + 1, c};
      if (write(fd, msg.data(), sizeof msg) != sizeof msg) _exit(3);
    }
    if (n % 16 == 0) std::this_thread::sleep_until(start + std::chrono::microseconds(250 * n));
  }
}

TEST(Crash, KilledRecordingsKeepEverythingCommitted) {
  const char* env = std::getenv("PALPA_CRASH_KILLS");
  const int kills = env ? std::atoi(env) : 10;
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> delay_ms(30, 900);
  const Rig rig;
  int interrupted = 0, unmade = 0;
  std::uint64_t ticks_total = 0, lost_max = 0;
  for (int k = 0; k < kills; ++k) {
    const auto file = test::temp_dir() / ("crash-" + std::to_string(k) + ".palpa");
    std::filesystem::remove(file);
    std::filesystem::remove(file.string() + "-wal");
    std::filesystem::remove(file.string() + "-shm");
    int p[2];
    ASSERT_EQ(pipe(p), 0);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      close(p[0]);
      record_until_killed(file, p[1]);
    }
    close(p[1]);

    // While it runs: the row counts seen by a reader never go down.
    std::array<std::int64_t, 6> seen{};
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(delay_ms(rng));
    while (std::chrono::steady_clock::now() < until) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20 + delay_ms(rng) % 40));
      try {
        const auto f = SessionFile::open(file, false);
        const auto c = f.row_counts();
        for (std::size_t i = 0; i < c.size(); ++i) ASSERT_GE(c[i], seen[i]) << "run " << k << ", table " << i;
        seen = c;
      } catch (const RecordError&) {
        // Not created yet, or its first transaction not committed yet.
      }
    }
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "run " << k;
    std::uint64_t committed = 0, made = 0;
    std::array<std::uint64_t, 2> msg{};
    while (read(p[0], msg.data(), sizeof msg) == sizeof msg) {
      made = msg[0];
      committed = msg[1];
    }
    close(p[0]);
    if (!std::filesystem::exists(file)) {  // killed before the file was made (while it was set up)
      ++unmade;
      continue;
    }

    // After: it opens, says interrupted, holds every committed tick.
    SessionFile f = [&] {
      try {
        return SessionFile::open(file);
      } catch (const RecordError& e) {
        ADD_FAILURE() << "run " << k << ": " << e.what();
        throw;
      }
    }();
    EXPECT_EQ(f.header().status, SessionStatus::Interrupted) << "run " << k;
    interrupted += f.header().status == SessionStatus::Interrupted;
    const auto counts = f.row_counts();
    for (std::size_t i = 0; i < counts.size(); ++i) EXPECT_GE(counts[i], seen[i]) << "run " << k << ", table " << i;
    const auto span = f.ticks();
    ASSERT_GE(span.ticks.size(), committed) << "run " << k << ": a committed tick was lost";
    ASSERT_EQ(span.ticks.size(), f.header().ticks);
    ticks_total += span.ticks.size();
    // Lost: what was made before the kill and is not in the file (at most
    // the batch in flight: under a commit interval of ticks, plus the 16
    // ticks between two reports).
    const std::uint64_t lost = made > span.ticks.size() ? made - span.ticks.size() : 0;
    lost_max = std::max(lost_max, lost);
    for (std::uint64_t n = 0; n < span.ticks.size(); ++n) {
      ASSERT_EQ(span.ticks[n].tick, n);
      for (std::size_t j = 0; j < 2; ++j) {
        const auto in = test::input(j, n);
        ASSERT_EQ(std::memcmp(&span.ticks[n].inputs[j].sample, &in.sample, sizeof in.sample), 0)
            << "run " << k << ", tick " << n;
      }
    }
    // The forces of every tick in the file, the last committed included, replay bit for bit.
    if (span.ticks.empty()) continue;
    std::vector<std::shared_ptr<const deform::MaterialArrays>> keep;
    haptics::LoopRecording rec;
    rec.ticks = span.ticks;
    rec.commands = f.commands(keep);
    rec.deforms = f.deforms();
    haptics::LoopReplay replay(f.mesh(), f.initial_materials(), f.header().options, f.header().config,
                               f.header().setups);
    std::uint64_t n = 0;
    replay.run(rec, [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r) {
      for (std::size_t j = 0; j < 2; ++j) {
        ASSERT_EQ(std::memcmp(&r[j].force_world, &span.results[t.tick][j].force_world, sizeof(haptics::Triple)), 0)
            << "run " << k << ", tick " << t.tick;
      }
      ++n;
    });
    EXPECT_EQ(n, span.ticks.size());
    std::filesystem::remove(file);
  }
  std::printf("crash: %d kills, %d files interrupted and intact, %d killed before the file was made, %llu ticks checked, "
              "at most %llu ticks (%.0f ms of wall time at 4 kHz) lost\n",
              kills, interrupted, unmade, static_cast<unsigned long long>(ticks_total),
              static_cast<unsigned long long>(lost_max), static_cast<double>(lost_max) / 4.0);
  // One batch: the ticks since the last commit began (250 ms = 1000 ticks at
  // 4 kHz, plus however long that commit took on a loaded machine).
  EXPECT_LT(lost_max, 2000u + 16u) << "more than one batch lost";
  EXPECT_EQ(interrupted + unmade, kills);
}

}  // namespace
}  // namespace palpa::record
