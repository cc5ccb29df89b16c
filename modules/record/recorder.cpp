// The session recorder (recorder.h).

#include "record/recorder.h"

#include "record/internal_chunk.h"
#include "record/internal_codec.h"
#include "record/internal_sql.h"
#include "record/state_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#ifndef PALPA_BUILD_ID
#define PALPA_BUILD_ID "palpa (unknown build)"
#endif

namespace palpa::record {

using namespace internal;

// ---- column chunks -------------------------------------------------------

namespace internal {

void ProbeColumns::clear() { resize(0, false); }

void ProbeColumns::resize(std::size_t n, bool results) {
  sequence.resize(n);
  sample_time.resize(n);
  position.resize(3 * n);
  orientation.resize(4 * n);
  buttons.resize(n);
  status.resize(n);
  read_ok.resize(n);
  force_device.resize(3 * n);
  flags.resize(n);
  const std::size_t r = results ? n : 0;
  world.resize(3 * r);
  force_world.resize(3 * r);
  contact_point.resize(3 * r);
  depth.resize(r);
  state.resize(r);
}

std::uint8_t pack_state(const haptics::ProbeTickResult& r) {
  return static_cast<std::uint8_t>((r.in_contact ? 1 : 0) | (r.enabled ? 2 : 0) | (r.clutched ? 4 : 0) |
                                   ((r.fault & 31) << 3));
}

void unpack_state(std::uint8_t s, haptics::ProbeTickResult& r) {
  r.in_contact = s & 1;
  r.enabled = (s >> 1) & 1;
  r.clutched = (s >> 2) & 1;
  r.fault = static_cast<std::uint8_t>(s >> 3);
}

void TickChunk::clear() {
  time.clear();
  model_time.clear();
  model_generation.clear();
  probe_count.clear();
  for (auto& p : probe) p.clear();
  probes = 0;
  results = false;
}

void TickChunk::append(const haptics::TickRecord& t, const haptics::ProbeTickResult* r) {
  if (time.empty()) {
    first_tick = t.tick;
    results = r != nullptr;
  }
  time.push_back(t.time);
  model_time.push_back(t.model_time);
  model_generation.push_back(t.model_generation);
  probe_count.push_back(static_cast<std::uint8_t>(t.probe_count));
  probes = std::max<std::uint32_t>(probes, t.probe_count);
  for (std::size_t j = 0; j < haptics::kMaxProbes; ++j) {
    ProbeColumns& c = probe[j];
    const PalpaDeviceSample& s = t.inputs[j].sample;
    c.sequence.push_back(s.sequence);
    c.sample_time.push_back(s.time);
    c.position.insert(c.position.end(), s.position, s.position + 3);
    c.orientation.insert(c.orientation.end(), s.orientation, s.orientation + 4);
    c.buttons.push_back(s.buttons);
    c.status.push_back(s.status);
    c.read_ok.push_back(t.inputs[j].read_ok ? 1 : 0);
    c.force_device.insert(c.force_device.end(), t.force_device[j].begin(), t.force_device[j].end());
    c.flags.push_back(t.flags[j]);
    if (results) {
      const haptics::ProbeTickResult zero{};
      const haptics::ProbeTickResult& pr = (r && j < t.probe_count) ? r[j] : zero;
      c.world.insert(c.world.end(), pr.world.begin(), pr.world.end());
      c.force_world.insert(c.force_world.end(), pr.force_world.begin(), pr.force_world.end());
      c.contact_point.insert(c.contact_point.end(), pr.contact_point.begin(), pr.contact_point.end());
      c.depth.push_back(pr.depth);
      c.state.push_back(pack_state(pr));
    }
  }
}

}  // namespace internal

// ---- the recorder ----------------------------------------------------------

namespace {

template <class T>
std::vector<std::uint8_t> col(const std::vector<T>& v, std::size_t per, Codec codec) {
  return encode_column(v.data(), v.size() / per * per == v.size() ? v.size() : 0, sizeof(T), codec);
}

std::string json_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '"' || c == '\\') {
      o += '\\';
      o += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char b[8];
      std::snprintf(b, sizeof b, "\\u%04x", c);
      o += b;
    } else {
      o += c;
    }
  }
  return o;
}

std::string device_setup_json(const std::vector<haptics::ProbeSetup>& setups) {
  std::ostringstream j;
  j.precision(17);
  j << "[";
  for (std::size_t k = 0; k < setups.size(); ++k) {
    const auto& s = setups[k];
    const auto& m = s.mapping;
    j << (k ? ", " : "") << "{\"slot\": " << k << ", \"name\": \"" << json_escape(s.name) << "\", \"device\": \""
      << json_escape(std::string(s.spec.name, strnlen(s.spec.name, sizeof s.spec.name))) << "\", \"position_dof\": "
      << s.spec.position_dof << ", \"force_dof\": " << s.spec.force_dof << ", \"max_force_n\": " << s.spec.max_force
      << ", \"mapping\": {\"scale\": " << m.scale << ", \"offset_m\": [" << m.offset[0] << ", " << m.offset[1] << ", "
      << m.offset[2] << "], \"force_scale\": " << m.force_scale << ", \"clutch_button\": " << m.clutch_button
      << "}, \"safety\": {\"max_force_n\": " << s.safety.max_force << ", \"max_force_rate_n_per_s\": "
      << s.safety.max_force_rate << ", \"ramp_time_s\": " << s.safety.ramp_time << ", \"max_jump_m\": "
      << s.safety.max_jump << "}}";
  }
  j << "]";
  return j.str();
}

std::string host_name() {
  char b[256] = {};
  gethostname(b, sizeof b - 1);
  return b;
}

}  // namespace

struct Recorder::Impl {
  std::pair<dev_t, ino_t> live_id{};  // the file, in recording_in_this_process's set while live
  bool live = false;
  std::filesystem::path file;
  RecorderOptions options;
  Db db;
  std::size_t vertices = 0;

  // Producer -> writer.
  struct TickItem {
    haptics::TickRecord tick;
    std::array<haptics::ProbeTickResult, haptics::kMaxProbes> results{};
    bool has_results = false;
  };
  std::unique_ptr<SpscQueue<TickItem>> ticks;
  std::unique_ptr<SpscQueue<haptics::CommandRecord>> commands;
  std::unique_ptr<SpscQueue<haptics::DeformRecord>> deforms;
  std::unique_ptr<SpscQueue<EventRecord>> events;
  TickItem scratch;  // producer's staging item (no allocation per push)
  std::mutex snap_mutex;
  std::vector<std::pair<SnapshotInfo, std::vector<std::uint8_t>>> snaps;
  std::atomic<haptics::HapticLoop*> loop{nullptr};
  double next_snapshot = 0;
  std::array<std::uint8_t, haptics::kMaxProbes> last_fault{};

  // Writer.
  std::thread writer;
  std::atomic<bool> stop{false}, failed{false}, done{false};
  std::string error;
  std::atomic<std::uint64_t> dropped{0}, ticks_committed{0}, commits{0}, bytes{0};
  std::uint64_t ticks_written = 0;
  TickChunk chunk;
  std::unique_ptr<Stmt> ins_tick, ins_probe, ins_probe_nores, ins_cmd, ins_def, ins_evt, ins_snap, upd_status;
  std::int64_t command_seq = 0;
  std::uint64_t loop_dropped = 0;  // the attached loop's record_drops at the last commit

  template <class Q, class T>
  bool push(Q& q, const T& v) noexcept {
    if (q.push(v)) return true;
    if (options.block_when_full) {
      while (!failed.load(std::memory_order_relaxed) && !done.load(std::memory_order_relaxed)) {
        std::this_thread::yield();
        if (q.push(v)) return true;
      }
    }
    dropped.fetch_add(1, std::memory_order_relaxed);
    return false;
  }

  void write_chunk();
  void write_item(const haptics::TickRecord& t, const haptics::ProbeTickResult* r);
  void write_command(const haptics::CommandRecord& c);
  void write_deform(const haptics::DeformRecord& d);
  void write_deform_chunk();
  std::uint64_t def_first = 0;
  std::vector<std::uint64_t> def_tick;
  std::vector<double> def_time, def_dt;
  void write_event(const EventRecord& e);
  std::size_t drain(std::size_t limit);
  void commit(const char* state);
  void writer_main();
};

void Recorder::Impl::write_chunk() {
  if (chunk.size() == 0) return;
  const std::size_t n = chunk.size();
  Stmt& t = *ins_tick;
  t.bind(1, static_cast<std::int64_t>(chunk.first_tick));
  t.bind(2, static_cast<std::int64_t>(n));
  t.bind(3, static_cast<std::int64_t>(chunk.probes));
  t.bind(4, col(chunk.time, 1, Codec::XorFloat));
  t.bind(5, col(chunk.model_generation, 1, Codec::DeltaInt));
  t.bind(6, col(chunk.model_time, 1, Codec::XorFloat));
  t.bind(7, col(chunk.probe_count, 1, Codec::DeltaInt));
  t.run();
  for (std::uint32_t j = 0; j < chunk.probes; ++j) {
    const ProbeColumns& c = chunk.probe[j];
    Stmt& p = *ins_probe;
    p.bind(1, static_cast<std::int64_t>(chunk.first_tick));
    p.bind(2, static_cast<std::int64_t>(j));
    p.bind(3, static_cast<std::int64_t>(n));
    p.bind(4, col(c.sequence, 1, Codec::DeltaInt));
    p.bind(5, col(c.sample_time, 1, Codec::XorFloat));
    p.bind(6, col(c.position, 1, Codec::XorFloat));
    p.bind(7, col(c.orientation, 1, Codec::XorFloat));
    p.bind(8, col(c.buttons, 1, Codec::DeltaInt));
    p.bind(9, col(c.status, 1, Codec::DeltaInt));
    p.bind(10, col(c.read_ok, 1, Codec::DeltaInt));
    p.bind(11, col(c.force_device, 1, Codec::XorFloat));
    p.bind(12, col(c.flags, 1, Codec::DeltaInt));
    if (chunk.results) {
      if (c.world.size() == c.position.size() &&
          std::memcmp(c.world.data(), c.position.data(), c.world.size() * sizeof(double)) == 0)
        p.bind(13, same_as_position_column(c.world.size(), sizeof(double)));
      else
        p.bind(13, col(c.world, 1, Codec::XorFloat));
      p.bind(14, col(c.force_world, 1, Codec::XorFloat));
      p.bind(15, col(c.contact_point, 1, Codec::XorFloat));
      p.bind(16, col(c.depth, 1, Codec::XorFloat));
      p.bind(17, col(c.state, 1, Codec::DeltaInt));
    } else {
      for (int k = 13; k <= 17; ++k) p.bind_null(k);
    }
    p.run();
  }
  ticks_written += n;
  chunk.clear();
}

void Recorder::Impl::write_item(const haptics::TickRecord& t, const haptics::ProbeTickResult* r) {
  // A chunk holds consecutive ticks, all with results or all without.
  if (chunk.size() > 0 && (t.tick != chunk.first_tick + chunk.size() || (r != nullptr) != chunk.results))
    write_chunk();
  chunk.append(t, r);
  if (chunk.size() >= options.chunk_ticks) write_chunk();
}

void Recorder::Impl::write_command(const haptics::CommandRecord& c) {
  Stmt& s = *ins_cmd;
  s.bind(1, ++command_seq);
  s.bind(2, static_cast<std::int64_t>(c.tick));
  s.bind(3, c.time);
  s.bind(4, static_cast<std::int64_t>(c.command.kind));
  s.bind(5, static_cast<std::int64_t>(c.command.probe));
  s.bind(6, static_cast<std::int64_t>(c.immediate ? 1 : 0));
  s.bind(7, encode_command(c.command));
  s.run();
}

// Deformation steps go in chunks of consecutive generations: the replay
// needs each step's generation, the tick that asked for it, its time and
// its dt (it re-makes the contacts from the ticks).
void Recorder::Impl::write_deform_chunk() {
  if (def_tick.empty()) return;
  Stmt& s = *ins_def;
  s.bind(1, static_cast<std::int64_t>(def_first));
  s.bind(2, static_cast<std::int64_t>(def_tick.size()));
  s.bind(3, col(def_tick, 1, Codec::DeltaInt));
  s.bind(4, col(def_time, 1, Codec::XorFloat));
  s.bind(5, col(def_dt, 1, Codec::XorFloat));
  s.run();
  def_tick.clear();
  def_time.clear();
  def_dt.clear();
}

void Recorder::Impl::write_deform(const haptics::DeformRecord& d) {
  if (!def_tick.empty() && d.generation != def_first + def_tick.size()) write_deform_chunk();
  if (def_tick.empty()) def_first = d.generation;
  def_tick.push_back(d.contacts_tick);
  def_time.push_back(d.time);
  def_dt.push_back(d.dt);
  if (def_tick.size() >= options.chunk_ticks) write_deform_chunk();
}

void Recorder::Impl::write_event(const EventRecord& e) {
  Stmt& s = *ins_evt;
  s.bind(1, static_cast<std::int64_t>(e.tick));
  s.bind(2, e.time);
  s.bind(3, std::string(event_kind_name(e.kind)));
  s.bind(4, static_cast<std::int64_t>(e.probe));
  s.bind(5, e.point[0]);
  s.bind(6, e.point[1]);
  s.bind(7, e.point[2]);
  s.bind(8, e.value);
  s.bind(9, std::string(e.text, strnlen(e.text, sizeof e.text)));
  s.run();
}

// Moves up to `limit` items of each queue into the open transaction.
std::size_t Recorder::Impl::drain(std::size_t limit) {
  std::size_t moved = 0;
  static thread_local TickItem item;
  for (std::size_t k = 0; k < limit && ticks->pop(item); ++k, ++moved)
    write_item(item.tick, item.has_results ? item.results.data() : nullptr);
  haptics::CommandRecord c;
  for (std::size_t k = 0; k < limit && commands->pop(c); ++k, ++moved) write_command(c);
  haptics::DeformRecord d;
  for (std::size_t k = 0; k < limit && deforms->pop(d); ++k, ++moved) write_deform(d);
  EventRecord e;
  for (std::size_t k = 0; k < limit && events->pop(e); ++k, ++moved) write_event(e);
  if (haptics::HapticLoop* l = loop.load()) {
    if (auto* q = l->tick_records()) {
      haptics::TickRecord t;
      for (std::size_t k = 0; k < limit && q->pop(t); ++k, ++moved) write_item(t, nullptr);
    }
    if (auto* q = l->command_records())
      for (std::size_t k = 0; k < limit && q->pop(c); ++k, ++moved) write_command(c);
    if (auto* q = l->deform_records())
      for (std::size_t k = 0; k < limit && q->pop(d); ++k, ++moved) write_deform(d);
  }
  return moved;
}

// Writes the partial chunk and the snapshots, updates the status row and commits.
void Recorder::Impl::commit(const char* state) {
  write_chunk();
  write_deform_chunk();
  std::vector<std::pair<SnapshotInfo, std::vector<std::uint8_t>>> s;
  {
    std::lock_guard<std::mutex> lock(snap_mutex);
    s.swap(snaps);
  }
  for (const auto& [info, blob] : s) {
    bind_snapshot(*ins_snap, info, blob);
    ins_snap->run();
  }
  Stmt& u = *upd_status;
  u.bind(1, std::string(state));
  u.bind(2, utc_now());
  u.bind(3, static_cast<std::int64_t>(ticks_written));
  // With a live loop attached, the records its own queues lost count too.
  haptics::HapticLoop* l = loop.load();
  if (l) loop_dropped = l->statistics().record_drops;
  u.bind(4, static_cast<std::int64_t>(dropped.load() + loop_dropped));
  u.bind(5, static_cast<std::int64_t>(commits.load() + 1));
  if (std::string(state) == "finished")
    u.bind(6, utc_now());
  else
    u.bind_null(6);
  u.run();
  db.exec("COMMIT", "cannot commit");
  ticks_committed.store(ticks_written);
  commits.fetch_add(1);
  std::error_code ec;
  std::uint64_t b = std::filesystem::file_size(file, ec);
  const auto wal = std::filesystem::file_size(file.string() + "-wal", ec);
  if (!ec) b += wal;
  bytes.store(b);
}

void Recorder::Impl::writer_main() {
  using Clock = std::chrono::steady_clock;
  try {
    db.exec("BEGIN", "cannot begin a transaction");
    auto last = Clock::now();
    const auto interval = std::chrono::duration<double>(options.commit_interval_s);
    for (;;) {
      const bool stopping = stop.load(std::memory_order_acquire);
      const std::size_t moved = drain(4096);
      if (stopping && moved == 0) {
        commit("finished");
        break;
      }
      if (Clock::now() - last >= interval) {
        commit("recording");
        db.exec("BEGIN", "cannot begin a transaction");
        last = Clock::now();
      }
      if (moved == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  } catch (const std::exception& e) {
    error = e.what();
    failed.store(true);
  }
}

namespace {

// The files this process's recorders are writing, by device and inode.
std::mutex g_live_mutex;
std::set<std::pair<dev_t, ino_t>> g_live_files;

bool file_id(const std::filesystem::path& file, std::pair<dev_t, ino_t>& id) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) return false;
  id = {st.st_dev, st.st_ino};
  return true;
}

}  // namespace

bool recording_in_this_process(const std::filesystem::path& file) {
  std::pair<dev_t, ino_t> id;
  if (!file_id(file, id)) return false;
  std::lock_guard<std::mutex> lock(g_live_mutex);
  return g_live_files.count(id) > 0;
}

Recorder::Recorder(const std::filesystem::path& file, const haptics::SessionModel& model,
                   const deform::MaterialArrays& initial_materials, const std::vector<haptics::ProbeSetup>& setups,
                   const SessionInfo& info, RecorderOptions options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.file = file;
  if (!(options.chunk_ticks >= 1 && options.chunk_ticks <= 65536))
    throw RecordError(file, "chunk_ticks must be in [1, 65536], got " + std::to_string(options.chunk_ticks));
  if (!(options.commit_interval_s > 0 && options.commit_interval_s <= 0.25))
    throw RecordError(file, "commit_interval_s must be in (0, 0.25] s");
  if (options.queue_capacity < 16) options.queue_capacity = 16;
  m.options = options;
  m.vertices = model.mesh->vertex_count();

  // Never over an existing file. The session is set up in a hidden sibling
  // (schema, meta, mesh, status in one transaction) and linked to its name
  // only when complete, so a file of that name is always a whole session;
  // a writer killed during the set-up leaves at most ".NAME.creating-PID".
  std::error_code exists_ec;
  if (std::filesystem::exists(std::filesystem::symlink_status(file, exists_ec)))
    throw RecordError(file, "exists; a recorder never overwrites a session");
  const std::filesystem::path tmp =
      file.parent_path() / ("." + file.filename().string() + ".creating-" + std::to_string(getpid()));
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) throw RecordError(file, std::string("cannot create (") + std::strerror(errno) + ")");
  ::close(fd);

  auto remove_tmp = [&] {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    std::filesystem::remove(tmp.string() + "-journal", ec);
  };
  try {
    m.db = Db(tmp, SQLITE_OPEN_READWRITE);
    m.db.exec("PRAGMA page_size = 16384", "cannot set up");
    m.db.exec(("PRAGMA application_id = " + std::to_string(kApplicationId)).c_str(), "cannot set up");
    m.db.exec(("PRAGMA user_version = " + std::to_string(kSchemaVersion)).c_str(), "cannot set up");
    m.db.exec("BEGIN", "cannot set up");
    m.db.exec(kSchema, "cannot create the tables");
    {

    // Meta: who, what, which build.
    Stmt meta(m.db, "INSERT INTO meta(key, value) VALUES (?, ?)");
    auto put = [&](const char* k, const std::string& v) {
      meta.bind(1, std::string(k));
      meta.bind(2, v);
      meta.run();
    };
    auto put_blob = [&](const char* k, const std::vector<std::uint8_t>& v) {
      meta.bind(1, std::string(k));
      meta.bind(2, v);
      meta.run();
    };
    const std::string now = utc_now();
    put("build", PALPA_BUILD_ID);
    put("layout", layout_tag());
    put("created_utc", now);
    put("trainee", info.trainee);
    put("organ", info.organ);
    put("scenario_file", info.scenario_file);
    put("scenario_json", info.scenario_json);
    put("scenario_sha256", info.scenario_json.empty() ? std::string() : sha256_hex(info.scenario_json.data(), info.scenario_json.size()));
    put("device_setup", device_setup_json(setups));
    put("force_limit_n", std::to_string(info.force_limit));
    put("note", info.note);
    put_blob("setup", encode_setup(setups, model.config, model.options));
    put_blob("initial_materials", encode_materials(initial_materials));
    put("has_tissue_map", model.tissue_map ? "1" : "0");
    put("has_field", model.field ? "1" : "0");

    // The prepared mesh.
    const mesh::SurfaceMesh& mesh = *model.mesh;
    std::vector<double> pos(3 * mesh.vertex_count());
    for (std::size_t i = 0; i < mesh.vertex_count(); ++i)
      for (int k = 0; k < 3; ++k) pos[3 * i + k] = mesh.positions[i][k];
    std::vector<std::uint32_t> tri(3 * mesh.triangle_count());
    for (std::size_t i = 0; i < mesh.triangle_count(); ++i)
      for (int k = 0; k < 3; ++k) tri[3 * i + k] = mesh.triangles[i][k];
    std::vector<std::uint8_t> both(pos.size() * 8 + tri.size() * 4);
    std::memcpy(both.data(), pos.data(), pos.size() * 8);
    std::memcpy(both.data() + pos.size() * 8, tri.data(), tri.size() * 4);
    Stmt ms(m.db, "INSERT INTO mesh VALUES (0, ?, ?, ?, ?, ?)");
    ms.bind(1, static_cast<std::int64_t>(mesh.vertex_count()));
    ms.bind(2, static_cast<std::int64_t>(mesh.triangle_count()));
    ms.bind(3, encode_column(pos.data(), pos.size(), 8, Codec::XorFloat));
    ms.bind(4, encode_column(tri.data(), tri.size(), 4, Codec::DeltaInt));
    ms.bind(5, sha256_hex(both.data(), both.size()));
    ms.run();

    Stmt st(m.db, "INSERT INTO status VALUES (0, 'recording', ?, ?, NULL, 0, 0, 0, ?, ?)");
    st.bind(1, now);
    st.bind(2, now);
    st.bind(3, static_cast<std::int64_t>(getpid()));
    st.bind(4, host_name());
    st.run();
    }
    m.db.exec("COMMIT", "cannot set up");
    m.db = Db();
    // The name appears only now, and never over a file made meanwhile.
    if (::link(tmp.c_str(), file.c_str()) != 0) {
      const int e = errno;
      remove_tmp();
      if (e == EEXIST) throw RecordError(file, "exists; a recorder never overwrites a session");
      throw RecordError(file, std::string("cannot create (") + std::strerror(e) + ")");
    }
    remove_tmp();
    m.db = Db(file, SQLITE_OPEN_READWRITE);
    m.db.exec("PRAGMA journal_mode = WAL", "cannot set up");
    m.db.exec("PRAGMA synchronous = NORMAL", "cannot set up");
  } catch (const RecordError&) {
    m.db = Db();
    remove_tmp();
    throw;
  }

  m.ins_tick = std::make_unique<Stmt>(m.db, "INSERT INTO tick_chunks VALUES (?, ?, ?, ?, ?, ?, ?)");
  m.ins_probe = std::make_unique<Stmt>(
      m.db, "INSERT INTO probe_chunks VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  m.ins_cmd = std::make_unique<Stmt>(m.db, "INSERT INTO commands VALUES (?, ?, ?, ?, ?, ?, ?)");
  m.ins_def = std::make_unique<Stmt>(m.db, "INSERT INTO deform_chunks VALUES (?, ?, ?, ?, ?)");
  m.ins_evt = std::make_unique<Stmt>(
      m.db, "INSERT INTO events(tick, time, kind, probe, x, y, z, value, text) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)");
  m.ins_snap = std::make_unique<Stmt>(m.db, kInsertSnapshot);
  m.upd_status = std::make_unique<Stmt>(
      m.db, "UPDATE status SET state = ?, updated_utc = ?, ticks = ?, dropped = ?, commits = ?, ended_utc = ? WHERE id = 0");
  m.ticks = std::make_unique<SpscQueue<Impl::TickItem>>(options.queue_capacity);
  m.commands = std::make_unique<SpscQueue<haptics::CommandRecord>>(std::max<std::size_t>(256, options.queue_capacity / 16));
  m.deforms = std::make_unique<SpscQueue<haptics::DeformRecord>>(options.queue_capacity);
  m.events = std::make_unique<SpscQueue<EventRecord>>(1024);
  m.next_snapshot = options.snapshot_interval_s;
  if (file_id(file, m.live_id)) {
    std::lock_guard<std::mutex> lock(g_live_mutex);
    m.live = g_live_files.insert(m.live_id).second;
  }
  m.writer = std::thread([this] { impl_->writer_main(); });
}

Recorder::~Recorder() {
  try {
    finish();
  } catch (...) {
  }
}

bool Recorder::push_tick(const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> results) noexcept {
  Impl& m = *impl_;
  m.scratch.tick = t;
  m.scratch.has_results = m.options.store_results && !results.empty();
  if (m.scratch.has_results)
    for (std::size_t j = 0; j < results.size() && j < haptics::kMaxProbes; ++j) m.scratch.results[j] = results[j];
  return m.push(*m.ticks, m.scratch);
}
bool Recorder::push_command(const haptics::CommandRecord& c) noexcept { return impl_->push(*impl_->commands, c); }
bool Recorder::push_deform(const haptics::DeformRecord& d) noexcept { return impl_->push(*impl_->deforms, d); }
bool Recorder::push_event(const EventRecord& e) noexcept { return impl_->push(*impl_->events, e); }

void Recorder::snapshot(const haptics::SessionState& s) {
  auto blob = encode_state(s);
  std::lock_guard<std::mutex> lock(impl_->snap_mutex);
  impl_->snaps.push_back({SnapshotInfo{s.tick, s.core.last_tick_time}, std::move(blob)});
}

bool Recorder::snapshot_due(double t) noexcept {
  if (impl_->options.snapshot_interval_s <= 0 || t < impl_->next_snapshot) return false;
  impl_->next_snapshot = t + impl_->options.snapshot_interval_s;
  return true;
}

void Recorder::attach(haptics::HapticLoop& loop) { impl_->loop.store(&loop); }
void Recorder::detach() { impl_->loop.store(nullptr); }

void Recorder::finish() {
  Impl& m = *impl_;
  if (m.done.load()) {
    if (m.failed.load()) throw RecordError(m.file, m.error);
    return;
  }
  m.stop.store(true, std::memory_order_release);
  if (m.writer.joinable()) m.writer.join();
  m.done.store(true);
  m.ins_tick.reset();
  m.ins_probe.reset();
  m.ins_cmd.reset();
  m.ins_def.reset();
  m.ins_evt.reset();
  m.ins_snap.reset();
  m.upd_status.reset();
  if (!m.failed.load()) {
    try {
      m.db.exec("PRAGMA wal_checkpoint(TRUNCATE)", "cannot checkpoint");
    } catch (const RecordError&) {
      // The WAL stays beside the file; SQLite reads it on the next open.
    }
  }
  m.db = Db();
  if (m.live) {
    std::lock_guard<std::mutex> lock(g_live_mutex);
    g_live_files.erase(m.live_id);
    m.live = false;
  }
  if (m.failed.load()) throw RecordError(m.file, m.error);
}

RecorderStats Recorder::stats() const {
  return {impl_->ticks_committed.load(), impl_->commits.load(), impl_->dropped.load(), impl_->bytes.load()};
}
const std::filesystem::path& Recorder::file() const { return impl_->file; }
const RecorderOptions& Recorder::options() const { return impl_->options; }

bool record_step(Recorder& r, haptics::Session& session, double t, std::span<const haptics::ProbeTickInput> inputs,
                 std::span<haptics::ProbeTickResult> results) {
  static thread_local haptics::TickRecord tr;
  tr.tick = session.tick_count();
  tr.time = t;
  const tissue::ReactionState before = session.core().state().reactions;
  const bool due = session.tick(t, inputs, results);
  // A guarding reaction the tick triggered is an event (value: the dynamic region).
  const tissue::ReactionState& after = session.core().state().reactions;
  for (std::size_t k = 0; k < after.triggered_at.size(); ++k)
    if (after.triggered_at[k] != before.triggered_at[k]) {
      EventRecord e = EventRecord::make(EventKind::Reaction, tr.tick, t, "guarding triggered");
      e.value = static_cast<double>(k);
      r.push_event(e);
    }
  tr.model_generation = session.generation();
  tr.model_time = session.model_time();
  const std::size_t n = session.core().probe_count();
  tr.probe_count = static_cast<std::uint32_t>(n);
  for (std::size_t j = 0; j < haptics::kMaxProbes; ++j) {
    tr.inputs[j] = j < n && j < inputs.size() ? inputs[j] : haptics::ProbeTickInput{};
    tr.force_device[j] = j < n ? results[j].force_device : haptics::Triple{};
    tr.flags[j] = j < n ? results[j].flags : 0;
  }
  r.push_tick(tr, results.first(std::min(n, results.size())));
  // A newly latched fault is an event.
  for (std::size_t j = 0; j < n; ++j) {
    if (results[j].fault != 0 && results[j].fault != r.impl_->last_fault[j]) {
      EventRecord e = EventRecord::make(EventKind::Fault, tr.tick, t, "safety fault latched");
      e.probe = static_cast<std::int32_t>(j);
      e.value = results[j].fault;
      r.push_event(e);
    }
    r.impl_->last_fault[j] = results[j].fault;
  }
  if (due) {
    const haptics::DeformRequest& q = session.core().request();
    haptics::DeformRecord d;
    d.generation = q.generation;
    d.contacts_tick = q.tick;
    d.time = q.time;
    d.dt = q.dt;
    d.contacts = q.contacts;
    session.deform(q);
    r.push_deform(d);
  }
  if (r.snapshot_due(t)) r.snapshot(session.snapshot());
  return due;
}

void record_apply(Recorder& r, haptics::Session& session, const haptics::LoopCommand& command, double t) {
  haptics::CommandRecord c;
  c.tick = session.tick_count();
  c.time = t;
  c.command = command;
  session.apply(command, t);
  r.push_command(c);
}

}  // namespace palpa::record
