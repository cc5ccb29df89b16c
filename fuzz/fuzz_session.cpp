// libFuzzer target: the session file reader (docs/RECORDING.md, "Reading").
// Two kinds of input:
//  - one that starts with SQLite's magic ("SQLite format 3") is the whole
//    file: the file checks and SQLite's own page checks run;
//  - any other is an edit of a valid session (fuzz/templates/sphere_6s.palpa,
//    6 s, one probe, a snapshot): its first byte picks a column or row and the
//    rest becomes that BLOB (or an inserted command or event), so the
//    decoders of our column codecs, state and command payloads get inputs
//    that SQLite accepts.
// Then every part is read: header, mesh, initial materials, ticks, commands,
// deformation steps, events, snapshots (the first decoded against a model
// built from the file). RecordError is the expected answer to bad input;
// anything else (a crash, a sanitizer report, another exception, a hang,
// unbounded memory) is a finding.

#include "haptics/session.h"
#include "record/session_file.h"
#include "record/state_io.h"
#include "tissue/field.h"

#include <sqlite3.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#ifndef PALPA_FUZZ_SESSION_TEMPLATE
#error "PALPA_FUZZ_SESSION_TEMPLATE must name the template session file"
#endif

namespace {

const std::filesystem::path& folder() {
  static const std::filesystem::path dir = [] {
    std::string base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : "/tmp";
    std::string tmpl = base + "/palpa-fuzz-session-XXXXXX";
    if (!::mkdtemp(tmpl.data())) std::abort();
    return std::filesystem::path(tmpl);
  }();
  return dir;
}

std::string& template_bytes() {
  static std::string bytes;
  return bytes;
}

// What the edit byte picks: an UPDATE of one BLOB (the first row), or an INSERT.
const char* const kEdits[] = {
    "UPDATE mesh SET positions = ?1",
    "UPDATE mesh SET triangles = ?1",
    "UPDATE meta SET value = ?1 WHERE key = 'setup'",
    "UPDATE meta SET value = ?1 WHERE key = 'initial_materials'",
    "UPDATE tick_chunks SET time = ?1 WHERE first_tick = (SELECT min(first_tick) FROM tick_chunks)",
    "UPDATE tick_chunks SET model_generation = ?1 WHERE first_tick = (SELECT min(first_tick) FROM tick_chunks)",
    "UPDATE tick_chunks SET probe_count = ?1 WHERE first_tick = (SELECT min(first_tick) FROM tick_chunks)",
    "UPDATE probe_chunks SET position = ?1 WHERE first_tick = (SELECT min(first_tick) FROM probe_chunks) AND probe = 0",
    "UPDATE probe_chunks SET orientation = ?1 WHERE first_tick = (SELECT min(first_tick) FROM probe_chunks) AND probe = 0",
    "UPDATE probe_chunks SET force_device = ?1 WHERE first_tick = (SELECT min(first_tick) FROM probe_chunks) AND probe = 0",
    "UPDATE probe_chunks SET flags = ?1 WHERE first_tick = (SELECT min(first_tick) FROM probe_chunks) AND probe = 0",
    "UPDATE probe_chunks SET contact_point = ?1 WHERE first_tick = (SELECT min(first_tick) FROM probe_chunks) AND probe = 0",
    "UPDATE probe_chunks SET state = ?1 WHERE first_tick = (SELECT min(first_tick) FROM probe_chunks) AND probe = 0",
    "UPDATE deform_chunks SET time = ?1 WHERE first_generation = (SELECT min(first_generation) FROM deform_chunks)",
    "UPDATE deform_chunks SET contacts_tick = ?1 WHERE first_generation = (SELECT min(first_generation) FROM deform_chunks)",
    "UPDATE snapshots SET state = ?1 WHERE tick = (SELECT min(tick) FROM snapshots)",
    "INSERT INTO commands(tick, time, kind, probe, immediate, payload) VALUES (10, 0.01, 1, 0, 1, ?1)",
    "INSERT INTO commands(tick, time, kind, probe, immediate, payload) VALUES (10, 0.01, 7, 0, 0, ?1)",
    "INSERT INTO events(tick, time, kind, probe, x, y, z, value, text) VALUES (5, 0.005, 'mark', 0, 0, 0, 0, 0.01, ?1)",
    "UPDATE meta SET value = ?1 WHERE key = 'layout'",
    // A new tissue (map and field) as a recorded command: the largest payload decoder.
    "INSERT INTO commands(tick, time, kind, probe, immediate, payload) VALUES (10, 0.01, 12, 0, 0, ?1)",
};
constexpr std::uint8_t kInsertSetTissue = 20;  // its index in kEdits

// PALPA_FUZZ_WRITE_SEEDS=DIR: writes the seeds that need our encoders (a
// SetTissue command with every part of the tissue in use, for the
// template's mesh) into DIR and exits; fuzz/corpus/session holds them.
void write_seeds(const char* dir) {
  const std::filesystem::path path = folder() / "seed.palpa";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << template_bytes();
  }
  const auto f = palpa::record::SessionFile::open(path);
  const auto mesh = f.mesh();
  using namespace palpa;
  tissue::Lesion l;
  l.centre = mesh->positions[0] * 0.8;
  l.semi_axes = Vec3(0.004, 0.005, 0.006);
  tissue::Pulse p;
  p.path = {mesh->positions[0], mesh->positions[mesh->vertex_count() / 2]};
  p.radius = 0.02;
  tissue::Breathing b;
  b.enabled = true;
  b.scale = 0.02;
  tissue::DynamicRegion d;
  d.region = "all";
  d.keyframes = {{0.5, 1.5, 0.2}, {2.0, 0.8, 0.0}};
  d.guarding.enabled = true;
  std::vector<float> weights(mesh->vertex_count(), 0.5f);
  auto t = std::make_shared<haptics::TissueModel>();
  t->field = std::make_shared<tissue::TissueField>(tissue::make_field(*mesh, 0.007, {l}, {p}, b, {d}, {weights}));
  auto map = std::make_shared<deform::MaterialMap>();
  map->tissues = {f.initial_materials().at(0), f.initial_materials().at(0)};
  map->tissues[1].stiffness *= 3;
  for (std::size_t i = 0; i < mesh->vertex_count(); ++i) {
    map->tissue_of.push_back(static_cast<std::uint16_t>(i % 2));
    map->scale.push_back(1.0f + static_cast<float>(i % 3) * 0.5f);
  }
  t->map = map;
  auto c = haptics::LoopCommand::of(haptics::LoopCommandKind::SetTissue);
  c.tissue = t.get();
  const std::vector<std::uint8_t> payload = record::encode_command(c);
  std::ofstream out(std::filesystem::path(dir) / "edit_settissue", std::ios::binary | std::ios::trunc);
  out.put(static_cast<char>(kInsertSetTissue));
  out.write(reinterpret_cast<const char*>(payload.data()), static_cast<std::streamsize>(payload.size()));
}

bool apply_edit(const std::filesystem::path& path, const std::uint8_t* data, std::size_t size) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    sqlite3_close(db);
    return false;
  }
  const char* sql = kEdits[data[0] % (sizeof kEdits / sizeof *kEdits)];
  sqlite3_stmt* st = nullptr;
  bool ok = sqlite3_prepare_v2(db, sql, -1, &st, nullptr) == SQLITE_OK;
  if (ok) {
    sqlite3_bind_blob(st, 1, data + 1, static_cast<int>(size - 1), SQLITE_TRANSIENT);
    ok = sqlite3_step(st) == SQLITE_DONE;
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  return ok;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  std::ifstream in(PALPA_FUZZ_SESSION_TEMPLATE, std::ios::binary);
  template_bytes().assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (template_bytes().size() < 100) std::abort();
  if (const char* dir = std::getenv("PALPA_FUZZ_WRITE_SEEDS"); dir && *dir) {
    write_seeds(dir);
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::filesystem::path path = folder() / "input.palpa";
  for (const char* suffix : {"", "-wal", "-shm", "-journal"}) std::filesystem::remove(path.string() + suffix);
  const bool whole_file = size >= 15 && std::memcmp(data, "SQLite format 3", 15) == 0;
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (whole_file)
      out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    else
      out << template_bytes();
  }
  if (!whole_file && !apply_edit(path, data, size)) return 0;
  try {
    const auto f = palpa::record::SessionFile::open(path);
    const auto& h = f.header();
    const auto mesh = f.mesh();
    (void)f.initial_materials();
    (void)f.ticks();
    std::vector<std::shared_ptr<const palpa::deform::MaterialArrays>> keep;
    (void)f.commands(keep);
    (void)f.deforms();
    (void)f.events();
    (void)f.row_counts();
    (void)f.storage();
    const auto snaps = f.snapshots();
    if (!snaps.empty() && f.same_layout()) {
      // Every snapshot (an added seek snapshot holds pending steps the first,
      // the recording's start, never has), at most 8.
      const auto model = palpa::haptics::SessionModel::make(mesh, h.options, h.config);
      for (std::size_t k = 0; k < snaps.size() && k < 8; ++k) {
        try {
          (void)f.snapshot(snaps[k].tick, *model);
        } catch (const palpa::record::RecordError&) {
        }
      }
    }
  } catch (const palpa::record::RecordError&) {
  }
  return 0;
}
