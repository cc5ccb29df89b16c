// Reading a session file (session_file.h), and the SQLite layer (internal_sql.h).

#include "record/session_file.h"

#include "record/internal_chunk.h"
#include "record/internal_codec.h"
#include "record/internal_sql.h"

#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <fstream>

namespace palpa::record {

using namespace internal;

std::string_view status_name(SessionStatus s) {
  switch (s) {
    case SessionStatus::Recording: return "recording";
    case SessionStatus::Finished: return "finished";
    case SessionStatus::Interrupted: return "interrupted";
  }
  return "unknown";
}

std::string_view event_kind_name(EventKind k) {
  switch (k) {
    case EventKind::Mark: return "mark";
    case EventKind::Fault: return "fault";
    case EventKind::Warning: return "warning";
    case EventKind::Reaction: return "reaction";
    case EventKind::Note: return "note";
    case EventKind::Unmark: return "unmark";
  }
  return "note";
}

namespace {

EventKind event_kind_of(const std::string& s) {
  for (auto k : {EventKind::Mark, EventKind::Fault, EventKind::Warning, EventKind::Reaction, EventKind::Note,
                 EventKind::Unmark})
    if (s == event_kind_name(k)) return k;
  return EventKind::Note;
}

}  // namespace

// ---- SQLite layer ------------------------------------------------------------

namespace internal {

Db::Db(const std::filesystem::path& file, int flags) : file_(file) {
  if (sqlite3_open_v2(file.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
    const std::string m = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw RecordError(file, "cannot open (" + m + ")");
  }
  sqlite3_extended_result_codes(db_, 1);
  sqlite3_busy_timeout(db_, 2000);
}

Db::~Db() {
  if (db_) sqlite3_close_v2(db_);
}

Db& Db::operator=(Db&& o) noexcept {
  if (this != &o) {
    if (db_) sqlite3_close_v2(db_);
    db_ = o.db_;
    file_ = std::move(o.file_);
    o.db_ = nullptr;
  }
  return *this;
}

void Db::fail(const std::string& what) const { throw RecordError(file_, what + " (" + sqlite3_errmsg(db_) + ")"); }

void Db::exec(const char* sql, const char* what) {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string m = err ? err : sqlite3_errmsg(db_);
    sqlite3_free(err);
    throw RecordError(file_, std::string(what) + " (" + m + ")");
  }
}

std::int64_t Db::integer(const char* sql, const char* what) {
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db_, sql, -1, &s, nullptr) != SQLITE_OK) fail(what);
  const int rc = sqlite3_step(s);
  const std::int64_t v = rc == SQLITE_ROW ? sqlite3_column_int64(s, 0) : 0;
  sqlite3_finalize(s);
  if (rc != SQLITE_ROW && rc != SQLITE_DONE) fail(what);
  return v;
}

Stmt::Stmt(const Db& db, const char* sql) : db_(db) {
  if (sqlite3_prepare_v2(db.get(), sql, -1, &s_, nullptr) != SQLITE_OK) db.fail("damaged");
}
Stmt::~Stmt() { sqlite3_finalize(s_); }
void Stmt::bind(int i, std::int64_t v) { sqlite3_bind_int64(s_, i, v); }
void Stmt::bind(int i, double v) { sqlite3_bind_double(s_, i, v); }
void Stmt::bind(int i, const std::string& v) {
  sqlite3_bind_text(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
}
void Stmt::bind(int i, std::span<const std::uint8_t> v) {
  static const std::uint8_t empty = 0;
  sqlite3_bind_blob(s_, i, v.empty() ? &empty : v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
}
void Stmt::bind_null(int i) { sqlite3_bind_null(s_, i); }
bool Stmt::step() {
  const int rc = sqlite3_step(s_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  db_.fail(rc == SQLITE_FULL ? "disk full" : (rc & 0xff) == SQLITE_CORRUPT ? "damaged" : "cannot read or write");
}
void Stmt::run() {
  step();
  reset();
}
void Stmt::reset() {
  sqlite3_reset(s_);
  sqlite3_clear_bindings(s_);
}
std::string Stmt::text(int col) const {
  const auto* p = sqlite3_column_text(s_, col);
  return p ? std::string(reinterpret_cast<const char*>(p), sqlite3_column_bytes(s_, col)) : std::string();
}
std::span<const std::uint8_t> Stmt::blob(int col) const {
  const auto* p = static_cast<const std::uint8_t*>(sqlite3_column_blob(s_, col));
  return p ? std::span<const std::uint8_t>(p, sqlite3_column_bytes(s_, col)) : std::span<const std::uint8_t>();
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

void bind_snapshot(Stmt& st, const SnapshotInfo& info, std::span<const std::uint8_t> state) {
  st.bind(1, static_cast<std::int64_t>(info.tick));
  st.bind(2, info.time);
  st.bind(3, static_cast<std::int64_t>(0));  // generation: not used by a seek
  st.bind(4, state);
}

}  // namespace internal

// ---- the reader ----------------------------------------------------------------

struct SessionFile::Impl {
  std::filesystem::path file;
  Db db;
  SessionHeader header;
  std::size_t vertices = 0, triangles = 0;

  [[noreturn]] void damaged(const std::string& what) const { throw RecordError(file, "damaged (" + what + ")"); }

  template <class T>
  void column(const Stmt& s, int c, std::size_t count, std::vector<T>& out, const char* name,
              const std::vector<T>* position = nullptr) const {
    const auto blob = s.blob(c);
    if (position && is_same_as_position(blob)) {
      if (position->size() != count) damaged(std::string(name) + ": does not match the position column");
      out = *position;
      return;
    }
    // Nothing is sized from a count the BLOB cannot hold (deflate packs at most 1032:1).
    if (!column_can_hold(blob.size(), count, sizeof(T)))
      damaged(std::string(name) + ": " + std::to_string(count) + " elements cannot come from a BLOB of " +
              std::to_string(blob.size()) + " bytes");
    out.resize(count);
    try {
      decode_column(s.blob(c), count, sizeof(T), out.data());
    } catch (const DecodeError& e) {
      damaged(std::string(name) + ": " + e.what());
    }
  }
};

SessionFile::SessionFile() : impl_(std::make_unique<Impl>()) {}
SessionFile::~SessionFile() = default;
SessionFile::SessionFile(SessionFile&&) noexcept = default;
SessionFile& SessionFile::operator=(SessionFile&&) noexcept = default;

namespace {

std::uint32_t be(const unsigned char* p, int n) {
  std::uint32_t v = 0;
  for (int k = 0; k < n; ++k) v = (v << 8) | p[k];
  return v;
}

// The checks that need no SQLite: the file is there, has SQLite's header,
// and is as long as that header says (when no WAL holds later pages).
void check_bytes(const std::filesystem::path& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) {
    if (errno == ENOENT) throw RecordError(file, "no such file");
    throw RecordError(file, std::string("cannot open (") + std::strerror(errno) + ")");
  }
  if (!S_ISREG(st.st_mode)) throw RecordError(file, "not a regular file");
  if (st.st_size == 0) throw RecordError(file, "empty file (not a Palpa session)");
  if (static_cast<std::uint64_t>(st.st_size) > kMaxSessionBytes)
    throw RecordError(file, "is " + std::to_string(st.st_size) + " bytes, more than the limit of " +
                                std::to_string(kMaxSessionBytes) + " (64 GiB, record::kMaxSessionBytes)");
  unsigned char h[100] = {};
  std::ifstream in(file, std::ios::binary);
  if (!in) throw RecordError(file, std::string("cannot read (") + std::strerror(errno) + ")");
  in.read(reinterpret_cast<char*>(h), sizeof h);
  const auto got = in.gcount();
  if (std::memcmp(h, "SQLite format 3", 16) != 0 || got < 16)
    throw RecordError(file, "not a Palpa session (not an SQLite database)");
  if (got < 100)
    throw RecordError(file, "truncated (" + std::to_string(st.st_size) + " bytes; an SQLite header alone is 100)");
  std::uint32_t page = be(h + 16, 2);
  if (page == 1) page = 65536;
  const std::uint32_t pages = be(h + 28, 4);
  const bool valid = be(h + 24, 4) == be(h + 92, 4);
  struct stat wal {};
  const bool has_wal = ::stat((file.string() + "-wal").c_str(), &wal) == 0 && wal.st_size > 0;
  const std::uint64_t expected = std::uint64_t{page} * pages;
  if (valid && !has_wal && static_cast<std::uint64_t>(st.st_size) < expected)
    throw RecordError(file, "truncated (" + std::to_string(st.st_size) + " bytes, its header says " +
                                std::to_string(expected) + ")");
}

bool process_alive(int pid) { return pid > 0 && (::kill(pid, 0) == 0 || errno == EPERM); }

std::string host_name() {
  char b[256] = {};
  gethostname(b, sizeof b - 1);
  return b;
}

}  // namespace

SessionFile SessionFile::open(const std::filesystem::path& file, bool mark) {
  check_bytes(file);
  SessionFile sf;
  Impl& m = *sf.impl_;
  m.file = file;
  const bool writable = ::access(file.c_str(), W_OK) == 0;
  m.db = Db(file, writable ? SQLITE_OPEN_READWRITE : SQLITE_OPEN_READONLY);
  Db& db = m.db;

  // Whose file, which version, which tables.
  const auto app = static_cast<std::uint32_t>(db.integer("PRAGMA application_id"));
  if (app != static_cast<std::uint32_t>(kApplicationId)) {
    char b[96];
    std::snprintf(b, sizeof b, "not a Palpa session (application_id 0x%08x, expected 0x%08x)", app,
                  static_cast<std::uint32_t>(kApplicationId));
    throw RecordError(file, b);
  }
  const auto version = db.integer("PRAGMA user_version");
  if (version > kSchemaVersion)
    throw RecordError(file, "session format version " + std::to_string(version) + " is newer than this build reads (" +
                                std::to_string(kSchemaVersion) + ")");
  if (version < 1) throw RecordError(file, "not a Palpa session (format version " + std::to_string(version) + ")");
  for (const char* t : kTables) {
    Stmt s(db, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = ?");
    s.bind(1, std::string(t));
    if (!s.step() || s.integer(0) != 1) throw RecordError(file, std::string("damaged: table '") + t + "' is missing");
  }

  // Meta.
  SessionHeader& h = m.header;
  std::vector<std::uint8_t> setup_blob;
  {
    Stmt s(db, "SELECT key, value FROM meta");
    while (s.step()) {
      const std::string k = s.text(0);
      if (k == "setup") {
        const auto b = s.blob(1);
        setup_blob.assign(b.begin(), b.end());
        continue;
      }
      if (k == "initial_materials") continue;
      const std::string v = s.text(1);
      if (k == "build") h.build = v;
      else if (k == "layout") h.layout = v;
      else if (k == "created_utc") h.created_utc = v;
      else if (k == "trainee") h.info.trainee = v;
      else if (k == "organ") h.info.organ = v;
      else if (k == "scenario_file") h.info.scenario_file = v;
      else if (k == "scenario_json") h.info.scenario_json = v;
      else if (k == "scenario_sha256") h.scenario_sha256 = v;
      else if (k == "device_setup") h.device_setup = v;
      else if (k == "force_limit_n") h.info.force_limit = std::atof(v.c_str());
      else if (k == "note") h.info.note = v;
    }
  }
  if (setup_blob.empty()) throw RecordError(file, "damaged: meta 'setup' is missing");
  try {
    decode_setup(setup_blob, h.setups, h.config, h.options);
  } catch (const DecodeError& e) {
    if (h.layout != layout_tag())
      throw RecordError(file, "recorded by a build of another layout (" + h.layout + "; this build: " + layout_tag() + ")");
    m.damaged(e.what());
  }
  {
    Stmt s(db, "SELECT vertex_count, triangle_count, sha256 FROM mesh WHERE id = 0");
    if (!s.step()) throw RecordError(file, "damaged: the mesh is missing");
    const std::int64_t nv = s.integer(0), nt = s.integer(1);
    if (nv < 3 || static_cast<std::uint64_t>(nv) > kMaxSessionVertices)
      m.damaged("the mesh claims " + std::to_string(nv) + " vertices; a session's mesh has 3 .. " +
                std::to_string(kMaxSessionVertices));
    if (nt < 1 || static_cast<std::uint64_t>(nt) > kMaxSessionTriangles)
      m.damaged("the mesh claims " + std::to_string(nt) + " triangles; a session's mesh has 1 .. " +
                std::to_string(kMaxSessionTriangles));
    m.vertices = static_cast<std::size_t>(nv);
    m.triangles = static_cast<std::size_t>(nt);
    h.mesh_sha256 = s.text(2);
  }

  // Status; a "recording" file whose writer is gone was interrupted.
  {
    Stmt s(db, "SELECT state, ended_utc, dropped, commits, pid, host FROM status WHERE id = 0");
    if (!s.step()) throw RecordError(file, "damaged: the status row is missing");
    const std::string state = s.text(0);
    h.ended_utc = s.text(1);
    h.dropped = static_cast<std::uint64_t>(s.integer(2));
    h.commits = static_cast<std::uint64_t>(s.integer(3));
    h.writer_pid = static_cast<int>(s.integer(4));
    const std::string host = s.text(5);
    if (state == "finished") {
      h.status = SessionStatus::Finished;
    } else if (state == "interrupted") {
      h.status = SessionStatus::Interrupted;
    } else if (state == "recording") {
      // Our own id: live only if one of our recorders writes it now (else an
      // earlier process with the same id left it).
      const bool alive = host == host_name() && process_alive(h.writer_pid) &&
                         (h.writer_pid != getpid() || recording_in_this_process(file));
      h.status = alive ? SessionStatus::Recording : SessionStatus::Interrupted;
    } else {
      throw RecordError(file, "damaged: unknown status '" + state + "'");
    }
    s.reset();
    if (state == "recording" && h.status == SessionStatus::Interrupted && mark && writable)
      db.exec("UPDATE status SET state = 'interrupted' WHERE id = 0", "cannot mark as interrupted");
  }
  h.ticks = static_cast<std::uint64_t>(db.integer("SELECT coalesce(sum(count), 0) FROM tick_chunks"));
  return sf;
}

const std::filesystem::path& SessionFile::file() const { return impl_->file; }
const SessionHeader& SessionFile::header() const { return impl_->header; }
bool SessionFile::same_layout() const { return impl_->header.layout == layout_tag(); }

std::shared_ptr<mesh::SurfaceMesh> SessionFile::mesh() const {
  const Impl& m = *impl_;
  Stmt s(m.db, "SELECT positions, triangles FROM mesh WHERE id = 0");
  if (!s.step()) m.damaged("the mesh is missing");
  std::vector<double> pos;
  std::vector<std::uint32_t> tri;
  m.column(s, 0, 3 * m.vertices, pos, "mesh positions");
  m.column(s, 1, 3 * m.triangles, tri, "mesh triangles");
  std::vector<std::uint8_t> both(pos.size() * 8 + tri.size() * 4);
  std::memcpy(both.data(), pos.data(), pos.size() * 8);
  std::memcpy(both.data() + pos.size() * 8, tri.data(), tri.size() * 4);
  if (sha256_hex(both.data(), both.size()) != m.header.mesh_sha256) m.damaged("the mesh does not match its SHA-256");
  auto out = std::make_shared<mesh::SurfaceMesh>();
  out->positions.resize(m.vertices);
  for (std::size_t i = 0; i < m.vertices; ++i) out->positions[i] = Vec3(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]);
  out->triangles.resize(m.triangles);
  for (std::size_t i = 0; i < m.triangles; ++i) {
    for (int k = 0; k < 3; ++k) {
      if (tri[3 * i + k] >= m.vertices) m.damaged("mesh triangle " + std::to_string(i) + " names a vertex out of range");
      out->triangles[i][k] = tri[3 * i + k];
    }
  }
  try {
    mesh::finalize(*out);
  } catch (const std::exception& e) {
    m.damaged(std::string("the mesh does not finalise: ") + e.what());
  }
  return out;
}

deform::MaterialArrays SessionFile::initial_materials() const {
  const Impl& m = *impl_;
  Stmt s(m.db, "SELECT value FROM meta WHERE key = 'initial_materials'");
  if (!s.step()) m.damaged("the initial materials are missing");
  try {
    return decode_materials(s.blob(0), m.vertices);
  } catch (const DecodeError& e) {
    m.damaged(std::string("initial materials: ") + e.what());
  }
}

TickSpan SessionFile::ticks(std::uint64_t from, std::uint64_t to) const {
  const Impl& m = *impl_;
  TickSpan out;
  if (to <= from) return out;
  const auto lim = [](std::uint64_t v) { return static_cast<std::int64_t>(std::min<std::uint64_t>(v, INT64_MAX)); };
  Stmt tc(m.db,
          "SELECT first_tick, count, probes, time, model_generation, model_time, probe_count FROM tick_chunks "
          "WHERE first_tick + count > ? AND first_tick < ? ORDER BY first_tick");
  tc.bind(1, lim(from));
  tc.bind(2, lim(to));
  Stmt pc(m.db,
          "SELECT probe, count, sequence, sample_time, position, orientation, buttons, status, read_ok, force_device, "
          "flags, world, force_world, contact_point, depth, state FROM probe_chunks WHERE first_tick = ? ORDER BY probe");
  TickChunk c;
  std::uint64_t expect = from;
  bool first = true;
  while (tc.step()) {
    const auto first_tick = static_cast<std::uint64_t>(tc.integer(0));
    const auto n = static_cast<std::size_t>(tc.integer(1));
    const auto probes = static_cast<std::size_t>(tc.integer(2));
    if (n == 0 || n > 65536 || probes > haptics::kMaxProbes) m.damaged("tick chunk " + std::to_string(first_tick));
    // The ticks are consecutive (the recorder never leaves a hole but for dropped ticks).
    if (!first && first_tick != expect) break;
    first = false;
    c.clear();
    m.column(tc, 3, n, c.time, "tick times");
    m.column(tc, 4, n, c.model_generation, "model generations");
    m.column(tc, 5, n, c.model_time, "model times");
    m.column(tc, 6, n, c.probe_count, "probe counts");
    pc.bind(1, static_cast<std::int64_t>(first_tick));
    bool results = false;
    std::size_t rows = 0;
    while (pc.step()) {
      const auto j = static_cast<std::size_t>(pc.integer(0));
      if (j >= probes || static_cast<std::size_t>(pc.integer(1)) != n) m.damaged("probe chunk at tick " + std::to_string(first_tick));
      ProbeColumns& p = c.probe[j];
      m.column(pc, 2, n, p.sequence, "sequence");
      m.column(pc, 3, n, p.sample_time, "sample time");
      m.column(pc, 4, 3 * n, p.position, "position");
      m.column(pc, 5, 4 * n, p.orientation, "orientation");
      m.column(pc, 6, n, p.buttons, "buttons");
      m.column(pc, 7, n, p.status, "status");
      m.column(pc, 8, n, p.read_ok, "read_ok");
      m.column(pc, 9, 3 * n, p.force_device, "force_device");
      m.column(pc, 10, n, p.flags, "flags");
      results = !pc.is_null(11);
      if (results) {
        m.column(pc, 11, 3 * n, p.world, "world", &p.position);
        m.column(pc, 12, 3 * n, p.force_world, "force_world");
        m.column(pc, 13, 3 * n, p.contact_point, "contact_point");
        m.column(pc, 14, n, p.depth, "depth");
        m.column(pc, 15, n, p.state, "state");
      }
      ++rows;
    }
    pc.reset();
    if (rows != probes) m.damaged("tick chunk " + std::to_string(first_tick) + " lacks probe rows");
    if (out.ticks.empty() && results) out.results.reserve(1024);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint64_t tick = first_tick + i;
      if (tick < from || tick >= to) continue;
      haptics::TickRecord t;
      t.tick = tick;
      t.time = c.time[i];
      t.model_generation = c.model_generation[i];
      t.model_time = c.model_time[i];
      t.probe_count = c.probe_count[i];
      if (t.probe_count > probes) m.damaged("tick " + std::to_string(tick) + " has more probes than its chunk");
      std::array<haptics::ProbeTickResult, haptics::kMaxProbes> r{};
      for (std::size_t j = 0; j < probes; ++j) {
        const ProbeColumns& p = c.probe[j];
        PalpaDeviceSample& s = t.inputs[j].sample;
        s.sequence = p.sequence[i];
        s.time = p.sample_time[i];
        for (int k = 0; k < 3; ++k) s.position[k] = p.position[3 * i + k];
        for (int k = 0; k < 4; ++k) s.orientation[k] = p.orientation[4 * i + k];
        s.buttons = p.buttons[i];
        s.status = p.status[i];
        t.inputs[j].read_ok = p.read_ok[i] != 0;
        for (int k = 0; k < 3; ++k) t.force_device[j][k] = p.force_device[3 * i + k];
        t.flags[j] = p.flags[i];
        if (results) {
          haptics::ProbeTickResult& q = r[j];
          q.sample = s;
          q.force_device = t.force_device[j];
          q.flags = t.flags[j];
          for (int k = 0; k < 3; ++k) {
            q.world[k] = p.world[3 * i + k];
            q.force_world[k] = p.force_world[3 * i + k];
            q.contact_point[k] = p.contact_point[3 * i + k];
          }
          q.depth = p.depth[i];
          unpack_state(p.state[i], q);
        }
      }
      out.ticks.push_back(t);
      if (results) out.results.push_back(r);
    }
    expect = first_tick + n;
    if (!results && !out.results.empty()) out.results.clear();
  }
  if (out.results.size() != out.ticks.size()) out.results.clear();
  return out;
}

std::vector<haptics::CommandRecord> SessionFile::commands(
    std::vector<std::shared_ptr<const deform::MaterialArrays>>& keep) const {
  const Impl& m = *impl_;
  std::vector<haptics::CommandRecord> out;
  Stmt s(m.db, "SELECT tick, time, immediate, payload FROM commands ORDER BY seq");
  while (s.step()) {
    if (!same_layout())
      throw RecordError(m.file, "its commands were recorded by a build of another layout (" + m.header.layout + ")");
    haptics::CommandRecord c;
    c.tick = static_cast<std::uint64_t>(s.integer(0));
    c.time = s.real(1);
    c.immediate = s.integer(2) != 0;
    try {
      c.command = decode_command(s.blob(3), m.vertices, keep);
    } catch (const DecodeError& e) {
      m.damaged(std::string("command at tick ") + std::to_string(c.tick) + ": " + e.what());
    }
    out.push_back(c);
  }
  return out;
}

std::vector<haptics::DeformRecord> SessionFile::deforms(std::uint64_t from, std::uint64_t to) const {
  const Impl& m = *impl_;
  std::vector<haptics::DeformRecord> out;
  const auto lim = [](std::uint64_t v) { return static_cast<std::int64_t>(std::min<std::uint64_t>(v, INT64_MAX)); };
  (void)lim;
  // Chunks of consecutive generations; the ticks that asked for them grow with the generation.
  Stmt s(m.db, "SELECT first_generation, count, contacts_tick, time, dt FROM deform_chunks ORDER BY first_generation");
  std::vector<std::uint64_t> tick;
  std::vector<double> time, dt;
  while (s.step()) {
    const auto first = static_cast<std::uint64_t>(s.integer(0));
    const auto n = static_cast<std::size_t>(s.integer(1));
    if (n == 0 || n > 65536) m.damaged("deformation chunk " + std::to_string(first));
    m.column(s, 2, n, tick, "deformation ticks");
    if (tick.back() < from) continue;
    if (tick.front() >= to) break;
    m.column(s, 3, n, time, "deformation times");
    m.column(s, 4, n, dt, "deformation steps");
    for (std::size_t i = 0; i < n; ++i) {
      if (tick[i] < from || tick[i] >= to) continue;
      haptics::DeformRecord d;
      d.generation = first + i;
      d.contacts_tick = tick[i];
      d.time = time[i];
      d.dt = dt[i];
      out.push_back(d);
    }
  }
  return out;
}

std::vector<EventRecord> SessionFile::events() const {
  const Impl& m = *impl_;
  std::vector<EventRecord> out;
  Stmt s(m.db, "SELECT tick, time, kind, probe, x, y, z, value, text FROM events ORDER BY seq");
  while (s.step()) {
    EventRecord e = EventRecord::make(event_kind_of(s.text(2)), static_cast<std::uint64_t>(s.integer(0)), s.real(1),
                                      s.text(8));
    e.probe = static_cast<std::int32_t>(s.integer(3));
    e.point = {s.real(4), s.real(5), s.real(6)};
    e.value = s.real(7);
    out.push_back(e);
  }
  return out;
}

std::vector<SnapshotInfo> SessionFile::snapshots() const {
  std::vector<SnapshotInfo> out;
  Stmt s(impl_->db, "SELECT tick, time FROM snapshots ORDER BY tick");
  while (s.step()) out.push_back({static_cast<std::uint64_t>(s.integer(0)), s.real(1)});
  return out;
}

DecodedState SessionFile::snapshot(std::uint64_t tick, const haptics::SessionModel& model) const {
  const Impl& m = *impl_;
  if (!same_layout())
    throw RecordError(m.file, "its snapshots were recorded by a build of another layout (" + m.header.layout + ")");
  Stmt s(m.db, "SELECT state FROM snapshots WHERE tick = ?");
  s.bind(1, static_cast<std::int64_t>(tick));
  if (!s.step()) throw RecordError(m.file, "no snapshot at tick " + std::to_string(tick));
  try {
    return decode_state(s.blob(0), model);
  } catch (const DecodeError& e) {
    m.damaged("snapshot at tick " + std::to_string(tick) + ": " + e.what());
  }
}

std::array<std::int64_t, 6> SessionFile::row_counts() const {
  Db& db = const_cast<Db&>(impl_->db);
  return {db.integer("SELECT count(*) FROM tick_chunks"), db.integer("SELECT count(*) FROM probe_chunks"),
          db.integer("SELECT count(*) FROM commands"),    db.integer("SELECT count(*) FROM deform_chunks"),
          db.integer("SELECT count(*) FROM events"),      db.integer("SELECT count(*) FROM snapshots")};
}

StorageFigures SessionFile::storage() const {
  Db& db = const_cast<Db&>(impl_->db);
  StorageFigures s;
  std::error_code ec;
  s.file_bytes = static_cast<std::int64_t>(std::filesystem::file_size(impl_->file, ec));
  const auto wal = std::filesystem::file_size(impl_->file.string() + "-wal", ec);
  if (!ec) s.file_bytes += static_cast<std::int64_t>(wal);
  s.tick_bytes = db.integer(
      "SELECT (SELECT coalesce(sum(length(time) + length(model_generation) + length(model_time) + "
      "length(probe_count)), 0) FROM tick_chunks) + (SELECT coalesce(sum(length(sequence) + length(sample_time) + "
      "length(position) + length(orientation) + length(buttons) + length(status) + length(read_ok) + "
      "length(force_device) + length(flags) + coalesce(length(world), 0) + coalesce(length(force_world), 0) + "
      "coalesce(length(contact_point), 0) + coalesce(length(depth), 0) + coalesce(length(state), 0)), 0) FROM "
      "probe_chunks)");
  s.mesh_bytes = db.integer(
      "SELECT (SELECT coalesce(sum(length(positions) + length(triangles)), 0) FROM mesh) + "
      "(SELECT coalesce(sum(length(value)), 0) FROM meta WHERE key = 'initial_materials')");
  s.snapshot_bytes = db.integer("SELECT coalesce(sum(length(state)), 0) FROM snapshots");
  return s;
}

struct SnapshotAppender::Impl {
  Db db;
};

SnapshotAppender::SnapshotAppender(const std::filesystem::path& file) : impl_(std::make_unique<Impl>()) {
  // The checks of a reader first: a file that is not a session says so.
  const SessionFile f = SessionFile::open(file, false);
  if (!f.same_layout())
    throw RecordError(file, "cannot add snapshots: recorded by a build of another layout (" + f.header().layout + ")");
  if (f.header().status == SessionStatus::Recording)
    throw RecordError(file, "cannot add snapshots: still being recorded (by process " +
                                std::to_string(f.header().writer_pid) + ")");
  impl_->db = Db(file, SQLITE_OPEN_READWRITE);
  if (sqlite3_db_readonly(impl_->db.get(), "main") != 0)
    throw RecordError(file, "cannot add snapshots: the file is read-only");
}

SnapshotAppender::~SnapshotAppender() = default;

void SnapshotAppender::add(const haptics::SessionState& s, const std::deque<haptics::DeformRequest>& pending) {
  const std::vector<std::uint8_t> blob = encode_state(s, pending);
  Db& db = impl_->db;
  db.exec("BEGIN IMMEDIATE", "cannot begin a transaction");
  try {
    Stmt st(db, kInsertSnapshot);
    bind_snapshot(st, SnapshotInfo{s.tick, s.core.last_tick_time}, blob);
    st.run();
    db.exec("COMMIT", "cannot commit");
  } catch (...) {
    sqlite3_exec(db.get(), "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

}  // namespace palpa::record
