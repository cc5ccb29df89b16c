// Opening a session file: every fault a user can meet (missing, empty,
// foreign, truncated, newer, damaged) gives its exact message naming the
// file, never a crash; a file left "recording" by a dead writer opens as
// interrupted and is marked so.

#include "record_rig.h"
#include "record/state_io.h"

#include <sqlite3.h>
#include <sys/wait.h>

#include <gtest/gtest.h>

#include <fstream>

namespace palpa::record {
namespace {

using test::Rig;

std::string open_error(const std::filesystem::path& f) {
  try {
    const auto s = SessionFile::open(f);
    // Damage may show only when the records are read.
    (void)s.mesh();
    (void)s.ticks();
    std::vector<std::shared_ptr<const deform::MaterialArrays>> keep;
    (void)s.commands(keep);
    (void)s.deforms();
    return "no error";
  } catch (const RecordError& e) {
    return e.what();
  }
}

std::filesystem::path finished_session(const std::string& name) {
  const auto f = test::temp_dir() / name;
  std::filesystem::remove(f);
  RecorderOptions o;
  o.block_when_full = true;
  Rig().record(f, 3000, o, [](auto&, auto, auto) {});
  return f;
}

void sql(const std::filesystem::path& f, const char* q) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(f.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, q, nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  sqlite3_close(db);
}

TEST(SessionFile, MissingFile) {
  const auto f = test::temp_dir() / "nothing-here.palpa";
  EXPECT_EQ(open_error(f), f.string() + ": no such file");
}

TEST(SessionFile, Folder) {
  const auto f = test::temp_dir();
  EXPECT_EQ(open_error(f), f.string() + ": not a regular file");
}

TEST(SessionFile, EmptyFile) {
  const auto f = test::temp_dir() / "empty.palpa";
  { std::ofstream o(f); }
  EXPECT_EQ(open_error(f), f.string() + ": empty file (not a Palpa session)");
}

TEST(SessionFile, TextFile) {
  const auto f = test::temp_dir() / "notes.palpa";
  { std::ofstream(f) << "these are my notes, not a session\n"; }
  EXPECT_EQ(open_error(f), f.string() + ": not a Palpa session (not an SQLite database)");
}

TEST(SessionFile, ForeignSqliteDatabase) {
  const auto f = test::temp_dir() / "foreign.sqlite";
  std::filesystem::remove(f);
  sql(f, "CREATE TABLE t(x); INSERT INTO t VALUES (1);");
  EXPECT_EQ(open_error(f), f.string() + ": not a Palpa session (application_id 0x00000000, expected 0x50616c70)");
}

TEST(SessionFile, NewerFormat) {
  const auto f = finished_session("newer.palpa");
  sql(f, "PRAGMA user_version = 7");
  EXPECT_EQ(open_error(f), f.string() + ": session format version 7 is newer than this build reads (1)");
}

TEST(SessionFile, MissingTable) {
  const auto f = finished_session("missing-table.palpa");
  sql(f, "DROP TABLE snapshots");
  EXPECT_EQ(open_error(f), f.string() + ": damaged: table 'snapshots' is missing");
}

TEST(SessionFile, TruncatedHeader) {
  const auto f = finished_session("tiny.palpa");
  std::filesystem::resize_file(f, 60);
  EXPECT_EQ(open_error(f), f.string() + ": truncated (60 bytes; an SQLite header alone is 100)");
}

TEST(SessionFile, TruncatedToHalf) {
  const auto f = finished_session("half.palpa");
  const auto size = std::filesystem::file_size(f);
  std::filesystem::resize_file(f, size / 2);
  EXPECT_EQ(open_error(f), f.string() + ": truncated (" + std::to_string(size / 2) + " bytes, its header says " +
                               std::to_string(size) + ")");
}

// Garbage over the pages of the tick chunks: SQLite or the column decoder
// notices; either way a message, never a crash or wrong numbers.
TEST(SessionFile, DamagedPages) {
  const auto f = finished_session("damaged.palpa");
  const auto size = std::filesystem::file_size(f);
  {
    std::fstream io(f, std::ios::in | std::ios::out | std::ios::binary);
    std::uint64_t x = 88172645463325252ull;
    for (std::uint64_t at = 3 * 16384; at + 64 < size; at += 997) {
      io.seekp(static_cast<std::streamoff>(at));
      for (int k = 0; k < 64; ++k) {
        x ^= x << 13; x ^= x >> 7; x ^= x << 17;
        io.put(static_cast<char>(x));
      }
    }
  }
  const std::string e = open_error(f);
  EXPECT_EQ(e.rfind(f.string() + ": ", 0), 0u) << e;
  EXPECT_NE(e.find("damaged"), std::string::npos) << e;
}

TEST(SessionFile, DamagedColumn) {
  const auto f = finished_session("damaged-column.palpa");
  sql(f, "UPDATE probe_chunks SET position = x'0108ffff0000' WHERE first_tick = 0 AND probe = 1");
  std::int64_t count = 0;
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(f.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(db, "SELECT count FROM tick_chunks WHERE first_tick = 0", -1, &st, nullptr);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    count = sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    sqlite3_close(db);
  }
  EXPECT_EQ(open_error(f), f.string() + ": damaged (position: column has 65535 elements, expected " +
                               std::to_string(3 * count) + ")");
}

// Counts in the file are limits-checked before anything is sized from them.
TEST(SessionFile, MeshCountsBeyondTheLimits) {
  const auto f = finished_session("mesh-count.palpa");
  sql(f, "UPDATE mesh SET vertex_count = 1099511627776 WHERE id = 0");
  EXPECT_EQ(open_error(f), f.string() + ": damaged (the mesh claims 1099511627776 vertices; a session's mesh has 3 .. 20000000)");
  sql(f, "UPDATE mesh SET vertex_count = 2 WHERE id = 0");
  EXPECT_EQ(open_error(f), f.string() + ": damaged (the mesh claims 2 vertices; a session's mesh has 3 .. 20000000)");
  const auto g = finished_session("mesh-triangles.palpa");
  sql(g, "UPDATE mesh SET triangle_count = -5 WHERE id = 0");
  EXPECT_EQ(open_error(g), g.string() + ": damaged (the mesh claims -5 triangles; a session's mesh has 1 .. 40000000)");
}

TEST(SessionFile, AColumnCannotClaimMoreThanItsBlobHolds) {
  // 19 999 999 vertices are within the limit, but the 10-byte BLOB could not inflate to 480 MB.
  const auto f = finished_session("mesh-claim.palpa");
  sql(f, "UPDATE mesh SET vertex_count = 19999999, positions = x'010800000000aabbccdd' WHERE id = 0");
  EXPECT_EQ(open_error(f),
            f.string() + ": damaged (mesh positions: 59999997 elements cannot come from a BLOB of 10 bytes)");
}

TEST(SessionFile, OverTheSizeLimitIsNamedBeforeReading) {
  // A sparse file of 64 GiB + 1 byte takes no disk space.
  const auto f = test::temp_dir() / "huge.palpa";
  std::filesystem::remove(f);
  { std::ofstream(f) << "SQLite format 3"; }
  std::error_code ec;
  std::filesystem::resize_file(f, kMaxSessionBytes + 1, ec);
  if (ec) GTEST_SKIP() << "this file system cannot hold a sparse 64 GiB file: " << ec.message();
  EXPECT_EQ(open_error(f), f.string() + ": is 68719476737 bytes, more than the limit of 68719476736 (64 GiB, record::kMaxSessionBytes)");
  std::filesystem::remove(f);
}

// A writer that dies without finishing leaves a file that opens as interrupted.
// fuzz_session edits this session (fuzz/templates/sphere_6s.palpa). Made by
// a build of another layout, it stops every input at the layout check,
// before the command and snapshot decoders it is there to reach: remade by
// tools/make-fuzz-template.sh whenever the layout changes.
TEST(SessionFile, TheFuzzTemplateHasThisBuildsLayout) {
  const std::filesystem::path copy = test::temp_dir() / "fuzz_template.palpa";
  std::filesystem::remove(copy);
  std::filesystem::copy_file(PALPA_FUZZ_SESSION_TEMPLATE, copy);
  const auto f = SessionFile::open(copy);
  EXPECT_TRUE(f.same_layout()) << PALPA_FUZZ_SESSION_TEMPLATE << " was recorded with layout '" << f.header().layout
                               << "', this build's is '" << layout_tag()
                               << "': remake it with tools/make-fuzz-template.sh";
  std::vector<std::shared_ptr<const deform::MaterialArrays>> keep;
  EXPECT_NO_THROW((void)f.commands(keep));
  EXPECT_FALSE(f.snapshots().empty());
}

TEST(SessionFile, DeadWriterMeansInterrupted) {
  const auto f = test::temp_dir() / "dead-writer.palpa";
  std::filesystem::remove(f);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    RecorderOptions o;
    o.block_when_full = true;
    o.commit_interval_s = 0.01;
    const Rig rig;
    auto s = rig.session();
    const auto map = rig.stiffness_map();
    auto* r = new Recorder(f, *rig.model, rig.initial, rig.setups, {}, o);
    std::array<haptics::ProbeTickInput, 2> in;
    std::array<haptics::ProbeTickResult, 2> out;
    for (std::uint64_t n = 0; n < 500; ++n) {
      rig.commands(*r, *s, n, map);
      for (std::size_t j = 0; j < 2; ++j) in[j] = test::input(j, n);
      record_step(*r, *s, static_cast<double>(n) * 1e-3, in, out);
    }
    while (r->stats().ticks_committed < 500) usleep(1000);
    _exit(0);  // no finish(): as if killed
  }
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  {
    const auto s = SessionFile::open(f);
    EXPECT_EQ(s.header().status, SessionStatus::Interrupted);
    EXPECT_EQ(s.header().ticks, 500u);
  }
  // Marked: a second open reads "interrupted" from the status row itself.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(f.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "SELECT state FROM status", -1, &st, nullptr);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)), "interrupted");
  sqlite3_finalize(st);
  sqlite3_close(db);
}

std::string status_row(const std::filesystem::path& f) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(f.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "SELECT state FROM status", -1, &st, nullptr);
  std::string state = sqlite3_step(st) == SQLITE_ROW ? reinterpret_cast<const char*>(sqlite3_column_text(st, 0)) : "";
  sqlite3_finalize(st);
  sqlite3_close(db);
  return state;
}

// A file this process is recording is live, though its status row names our
// own process id; one left with our id by no recorder of ours is not (an
// earlier process that had the same id crashed). Opening the live one used
// to mark it interrupted, and under load that write could time out on the
// writer's lock ("cannot mark as interrupted (database is locked)").
TEST(SessionFile, AFileThisProcessIsRecordingIsLive) {
  const auto f = test::temp_dir() / "own-writer.palpa";
  const auto link = test::temp_dir() / "own-writer-link.palpa";
  std::filesystem::remove(f);
  std::filesystem::remove(link);
  const Rig rig;
  auto s = rig.session();
  RecorderOptions o;
  o.block_when_full = true;
  o.commit_interval_s = 0.01;
  {
    Recorder r(f, *rig.model, rig.initial, rig.setups, {}, o);
    std::array<haptics::ProbeTickInput, 2> in;
    std::array<haptics::ProbeTickResult, 2> out;
    for (std::uint64_t n = 0; n < 200; ++n) {
      for (std::size_t j = 0; j < 2; ++j) in[j] = test::input(j, n);
      record_step(r, *s, static_cast<double>(n) * 1e-3, in, out);
    }
    while (r.stats().ticks_committed < 200) usleep(1000);
    EXPECT_TRUE(recording_in_this_process(f));
    std::filesystem::create_symlink(f.filename(), link);
    EXPECT_TRUE(recording_in_this_process(link)) << "the same file by another path";
    EXPECT_EQ(SessionFile::open(f).header().status, SessionStatus::Recording);
    EXPECT_EQ(status_row(f), "recording") << "a live recording was marked";
    r.finish();
    EXPECT_FALSE(recording_in_this_process(f));
  }
  EXPECT_EQ(SessionFile::open(f).header().status, SessionStatus::Finished);
  EXPECT_FALSE(recording_in_this_process(test::temp_dir() / "no-such-file.palpa"));

  // Left "recording" with our id by no recorder of ours: interrupted, marked.
  sql(f, ("UPDATE status SET state = 'recording', pid = " + std::to_string(getpid()) + " WHERE id = 0").c_str());
  EXPECT_EQ(SessionFile::open(f).header().status, SessionStatus::Interrupted);
  EXPECT_EQ(status_row(f), "interrupted");
  std::filesystem::remove(link);
}

}  // namespace
}  // namespace palpa::record
