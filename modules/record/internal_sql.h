#pragma once
// Internal: a thin RAII layer over SQLite's C API, and the schema of the
// session file (docs/RECORDING.md). Every failure throws RecordError naming
// the file.

#include "record/format.h"

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace palpa::record::internal {

/// The tables of schema version 1 (created by the recorder in one transaction).
inline constexpr const char* kSchema = R"sql(
CREATE TABLE meta(key TEXT PRIMARY KEY, value) WITHOUT ROWID;
CREATE TABLE mesh(id INTEGER PRIMARY KEY CHECK (id = 0), vertex_count INTEGER NOT NULL,
  triangle_count INTEGER NOT NULL, positions BLOB NOT NULL, triangles BLOB NOT NULL, sha256 TEXT NOT NULL);
CREATE TABLE tick_chunks(first_tick INTEGER PRIMARY KEY, count INTEGER NOT NULL, probes INTEGER NOT NULL,
  time BLOB NOT NULL, model_generation BLOB NOT NULL, model_time BLOB NOT NULL, probe_count BLOB NOT NULL);
CREATE TABLE probe_chunks(first_tick INTEGER NOT NULL, probe INTEGER NOT NULL, count INTEGER NOT NULL,
  sequence BLOB NOT NULL, sample_time BLOB NOT NULL, position BLOB NOT NULL, orientation BLOB NOT NULL,
  buttons BLOB NOT NULL, status BLOB NOT NULL, read_ok BLOB NOT NULL, force_device BLOB NOT NULL, flags BLOB NOT NULL,
  world BLOB, force_world BLOB, contact_point BLOB, depth BLOB, state BLOB,
  PRIMARY KEY (first_tick, probe)) WITHOUT ROWID;
CREATE TABLE deform_chunks(first_generation INTEGER PRIMARY KEY, count INTEGER NOT NULL,
  contacts_tick BLOB NOT NULL, time BLOB NOT NULL, dt BLOB NOT NULL);
CREATE TABLE commands(seq INTEGER PRIMARY KEY, tick INTEGER NOT NULL, time REAL NOT NULL, kind INTEGER NOT NULL,
  probe INTEGER NOT NULL, immediate INTEGER NOT NULL, payload BLOB NOT NULL);
CREATE TABLE events(seq INTEGER PRIMARY KEY, tick INTEGER NOT NULL, time REAL NOT NULL, kind TEXT NOT NULL,
  probe INTEGER NOT NULL, x REAL, y REAL, z REAL, value REAL, text TEXT NOT NULL);
CREATE TABLE snapshots(tick INTEGER PRIMARY KEY, time REAL NOT NULL, generation INTEGER NOT NULL, state BLOB NOT NULL);
CREATE TABLE status(id INTEGER PRIMARY KEY CHECK (id = 0), state TEXT NOT NULL, started_utc TEXT NOT NULL,
  updated_utc TEXT NOT NULL, ended_utc TEXT, ticks INTEGER NOT NULL, dropped INTEGER NOT NULL,
  commits INTEGER NOT NULL, pid INTEGER NOT NULL, host TEXT NOT NULL);
)sql";

inline constexpr const char* kTables[] = {"meta",     "mesh",      "tick_chunks", "probe_chunks", "deform_chunks",
                                          "commands", "events",    "snapshots",   "status"};

class Stmt;

class Db {
 public:
  Db() = default;
  /// Opens with sqlite3_open_v2 `flags`. Throws RecordError.
  Db(const std::filesystem::path& file, int flags);
  ~Db();
  Db(Db&& o) noexcept : db_(o.db_), file_(std::move(o.file_)) { o.db_ = nullptr; }
  Db& operator=(Db&& o) noexcept;
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;

  /// Runs SQL with no results. Throws RecordError("<what>: <sqlite message>").
  void exec(const char* sql, const char* what = "damaged");
  /// One integer of a query with one row (PRAGMAs).
  std::int64_t integer(const char* sql, const char* what = "damaged");
  [[noreturn]] void fail(const std::string& what) const;
  sqlite3* get() const { return db_; }
  const std::filesystem::path& file() const { return file_; }

 private:
  sqlite3* db_ = nullptr;
  std::filesystem::path file_;
};

class Stmt {
 public:
  Stmt(const Db& db, const char* sql);
  ~Stmt();
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  void bind(int i, std::int64_t v);
  void bind(int i, double v);
  void bind(int i, const std::string& v);
  void bind(int i, std::span<const std::uint8_t> v);
  void bind_null(int i);
  /// Steps once: true while a row is there.
  bool step();
  /// Steps a statement with no result and resets it for the next binding.
  void run();
  void reset();

  std::int64_t integer(int col) const { return sqlite3_column_int64(s_, col); }
  double real(int col) const { return sqlite3_column_double(s_, col); }
  bool is_null(int col) const { return sqlite3_column_type(s_, col) == SQLITE_NULL; }
  std::string text(int col) const;
  std::span<const std::uint8_t> blob(int col) const;

 private:
  const Db& db_;
  sqlite3_stmt* s_ = nullptr;
};

/// Now as ISO 8601 UTC, seconds.
std::string utc_now();

/// The snapshots table's insert (tick, time, generation, state), and its
/// binding: what the recorder and SnapshotAppender both write.
inline constexpr const char* kInsertSnapshot = "INSERT OR REPLACE INTO snapshots VALUES (?, ?, ?, ?)";
void bind_snapshot(Stmt& st, const SnapshotInfo& info, std::span<const std::uint8_t> state);

}  // namespace palpa::record::internal
