// The recorder: a scripted session written and read back (every tick's
// inputs, results, commands, deformation steps, snapshots, the mesh and
// the materials), replayed bit for bit from the file, from tick 0 and from
// each snapshot; dropped records counted when the writer cannot keep up.

#include "record_rig.h"
#include "record/internal_codec.h"
#include "record/state_io.h"
#include "tissue/field.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <deque>
#include <fstream>
#include <functional>
#include <limits>
#include <tuple>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

namespace palpa::record {
namespace {

using test::Rig;

bool same_bits(const haptics::Triple& a, const haptics::Triple& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

class Recorded : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    file_ = test::temp_dir() / "recorded.palpa";
    std::filesystem::remove(file_);
    RecorderOptions o;
    o.block_when_full = true;
    o.snapshot_interval_s = 0.4;
    o.chunk_ticks = 100;
    results_.clear();
    Rig().record(file_, kTicks, o, [](Recorder&, std::uint64_t, std::span<const haptics::ProbeTickResult> r) {
      results_.push_back({r[0], r[1]});
    });
  }
  static constexpr std::uint64_t kTicks = 1500;
  static inline std::filesystem::path file_;
  static inline std::vector<std::array<haptics::ProbeTickResult, 2>> results_;
};

TEST_F(Recorded, HeaderSaysFinishedWithEveryTick) {
  EXPECT_FALSE(std::filesystem::exists(file_.string() + "-wal")) << "finish() checkpoints the WAL into the file";
  const auto f = SessionFile::open(file_);
  const auto& h = f.header();
  EXPECT_EQ(h.status, SessionStatus::Finished);
  EXPECT_EQ(h.ticks, kTicks);
  EXPECT_EQ(h.dropped, 0u);
  EXPECT_EQ(h.info.trainee, "test");
  EXPECT_EQ(h.setups.size(), 2u);
  EXPECT_EQ(h.setups[1].name, "probe 1");
  EXPECT_EQ(h.config.deform_rate_hz, 300);
  EXPECT_TRUE(f.same_layout());
  EXPECT_FALSE(h.build.empty());
}

TEST_F(Recorded, MeshAndMaterialsRoundTrip) {
  const Rig rig;
  const auto f = SessionFile::open(file_);
  const auto m = f.mesh();
  ASSERT_EQ(m->vertex_count(), rig.model->mesh->vertex_count());
  ASSERT_EQ(m->triangle_count(), rig.model->mesh->triangle_count());
  for (std::size_t i = 0; i < m->vertex_count(); ++i) {
    ASSERT_EQ(m->positions[i], rig.model->mesh->positions[i]);
    ASSERT_EQ(m->normals[i], rig.model->mesh->normals[i]) << "normals rebuilt by finalize() are the same bits";
  }
  EXPECT_EQ(m->triangles, rig.model->mesh->triangles);
  const auto mat = f.initial_materials();
  EXPECT_EQ(mat.stiffness, rig.initial.stiffness);
  EXPECT_EQ(mat.mass, rig.initial.mass);
}

TEST_F(Recorded, TicksHoldInputsAndResultsBitForBit) {
  const auto f = SessionFile::open(file_);
  const auto span = f.ticks();
  ASSERT_EQ(span.ticks.size(), kTicks);
  ASSERT_EQ(span.results.size(), kTicks);
  for (std::uint64_t n = 0; n < kTicks; ++n) {
    const auto& t = span.ticks[n];
    ASSERT_EQ(t.tick, n);
    ASSERT_EQ(t.probe_count, 2u);
    for (std::size_t j = 0; j < 2; ++j) {
      const auto in = test::input(j, n);
      ASSERT_EQ(std::memcmp(&t.inputs[j].sample, &in.sample, sizeof in.sample), 0) << "tick " << n;
      const auto& r = span.results[n][j];
      const auto& want = results_[n][j];
      ASSERT_TRUE(same_bits(t.force_device[j], want.force_device)) << "tick " << n;
      ASSERT_TRUE(same_bits(r.force_world, want.force_world)) << "tick " << n;
      ASSERT_TRUE(same_bits(r.world, want.world));
      ASSERT_TRUE(same_bits(r.contact_point, want.contact_point));
      ASSERT_EQ(r.depth, want.depth);
      ASSERT_EQ(r.in_contact, want.in_contact);
      ASSERT_EQ(r.enabled, want.enabled);
      ASSERT_EQ(r.clutched, want.clutched);
      ASSERT_EQ(t.flags[j], want.flags);
    }
  }
  // A window reads the same ticks.
  const auto w = f.ticks(250, 333);
  ASSERT_EQ(w.ticks.size(), 83u);
  EXPECT_EQ(w.ticks.front().tick, 250u);
  EXPECT_EQ(std::memcmp(&w.ticks[10], &span.ticks[260], sizeof(haptics::TickRecord)), 0);
}

TEST_F(Recorded, CommandsDeformsAndSnapshots) {
  const auto f = SessionFile::open(file_);
  std::vector<std::shared_ptr<const deform::MaterialArrays>> keep;
  const auto c = f.commands(keep);
  ASSERT_EQ(c.size(), 9u);
  EXPECT_EQ(c[2].tick, 200u);
  EXPECT_EQ(c[2].command.kind, haptics::LoopCommandKind::ClutchOn);
  EXPECT_EQ(c[5].command.shape.radius, 0.004);
  ASSERT_EQ(keep.size(), 3u);  // the map, and the two tissues (kept, pointing to no map)
  EXPECT_EQ(c[6].command.materials, keep[0].get());
  EXPECT_EQ(keep[0]->stiffness, Rig().stiffness_map().stiffness);
  EXPECT_EQ(c[7].tick, Rig::kLesionTick);
  EXPECT_EQ(c[7].command.kind, haptics::LoopCommandKind::SetTissue);
  ASSERT_NE(c[7].command.tissue, nullptr);
  EXPECT_EQ(c[7].command.tissue->field->lesion_count, 1u);
  EXPECT_EQ(c[8].command.tissue->map, nullptr);
  EXPECT_EQ(keep[1].get(), nullptr);
  const auto d = f.deforms();
  EXPECT_GE(d.size(), 440u);  // 300 Hz for 1.5 s, plus the edits-only steps
  for (std::size_t k = 1; k < d.size(); ++k) ASSERT_EQ(d[k].generation, d[k - 1].generation + 1);
  const auto s = f.snapshots();
  ASSERT_EQ(s.size(), 3u);  // at 0.4, 0.8, 1.2 s
  EXPECT_EQ(s[0].tick, 401u);
  // The last holds the tissue in force: the vessel's field, the lesion tissue's map.
  const Rig rig;
  const DecodedState last = f.snapshot(s[2].tick, *rig.model);
  ASSERT_NE(last.state.tissue, nullptr);
  EXPECT_EQ(last.state.core.tissue, last.state.tissue.get());
  EXPECT_EQ(last.state.surface_tissue, last.state.tissue);
  EXPECT_EQ(last.state.tissue->field->pulse_count, 1u);
  EXPECT_EQ(last.state.tissue->field->pulses[0].rate_hz, rig.vessel_tissue->field->pulses[0].rate_hz);
  ASSERT_TRUE(last.state.materials.edited_tissue_map);
  EXPECT_EQ(last.state.materials.tissue_map->tissue_of, rig.lesion_tissue->map->tissue_of);
  EXPECT_EQ(last.state.materials.tissue_map->scale, rig.lesion_tissue->map->scale);
}

// The file alone is enough to re-run the session bit for bit.
haptics::LoopRecording recording_of(const SessionFile& f, std::vector<std::shared_ptr<const deform::MaterialArrays>>& keep) {
  haptics::LoopRecording rec;
  rec.ticks = f.ticks().ticks;
  rec.commands = f.commands(keep);
  rec.deforms = f.deforms();
  return rec;
}

TEST_F(Recorded, ReplaysBitIdenticalFromTheFileAlone) {
  const auto f = SessionFile::open(file_);
  std::vector<std::shared_ptr<const deform::MaterialArrays>> keep;
  const auto rec = recording_of(f, keep);
  const auto& h = f.header();
  haptics::LoopReplay replay(f.mesh(), f.initial_materials(), h.options, h.config, h.setups);
  std::uint64_t checked = 0;
  replay.run(rec, [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r) {
    for (std::size_t j = 0; j < 2; ++j) {
      ASSERT_TRUE(same_bits(r[j].force_device, t.force_device[j])) << "tick " << t.tick;
      ASSERT_TRUE(same_bits(r[j].force_world, results_[t.tick][j].force_world)) << "tick " << t.tick;
    }
    ++checked;
  });
  EXPECT_EQ(checked, kTicks);
  // The session had the tissue edits in it: the lesion under the still probe was felt.
  EXPECT_GT(results_[Rig::kLesionTick + 50][1].normal_reaction, 1.5 * results_[Rig::kLesionTick - 1][1].normal_reaction);
}

TEST_F(Recorded, SeeksThroughEverySnapshot) {
  const auto f = SessionFile::open(file_);
  std::vector<std::shared_ptr<const deform::MaterialArrays>> keep;
  const auto rec = recording_of(f, keep);
  const auto& h = f.header();
  const auto model = haptics::SessionModel::make(f.mesh(), h.options, h.config);
  for (const auto& s : f.snapshots()) {
    haptics::LoopReplay replay(model->mesh, f.initial_materials(), h.options, h.config, h.setups);
    const DecodedState d = f.snapshot(s.tick, *model);
    replay.restore({d.state, {}});
    ASSERT_EQ(replay.tick(), s.tick);
    std::uint64_t checked = 0;
    replay.run(rec, [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r) {
      for (std::size_t j = 0; j < 2; ++j)
        ASSERT_TRUE(same_bits(r[j].force_world, results_[t.tick][j].force_world)) << "from " << s.tick << ", tick " << t.tick;
      ++checked;
    });
    EXPECT_EQ(checked, kTicks - s.tick);
  }
}

// Two tissues hold the same values (every array and every fixed part).
void expect_same_tissue(const haptics::TissueModel& a, const haptics::TissueModel& b) {
  ASSERT_EQ(a.map == nullptr, b.map == nullptr);
  if (a.map) {
    EXPECT_EQ(a.map->tissues, b.map->tissues);
    EXPECT_EQ(a.map->tissue_of, b.map->tissue_of);
    EXPECT_EQ(a.map->scale, b.map->scale);
  }
  ASSERT_EQ(a.field == nullptr, b.field == nullptr);
  if (!a.field) return;
  const tissue::TissueField& f = *a.field;
  const tissue::TissueField& g = *b.field;
  EXPECT_EQ(f.tip_radius, g.tip_radius);
  ASSERT_EQ(f.lesion_count, g.lesion_count);
  for (std::size_t k = 0; k < f.lesion_count; ++k) {
    EXPECT_EQ(f.lesions[k].centre, g.lesions[k].centre);
    EXPECT_EQ(f.lesions[k].inv_axes, g.lesions[k].inv_axes);
    EXPECT_EQ(f.lesions[k].size2, g.lesions[k].size2);
    EXPECT_EQ(f.lesions[k].excess, g.lesions[k].excess);
  }
  ASSERT_EQ(f.pulse_count, g.pulse_count);
  for (std::size_t p = 0; p < f.pulse_count; ++p) {
    EXPECT_EQ(f.pulses[p].rate_hz, g.pulses[p].rate_hz);
    EXPECT_EQ(f.pulses[p].amplitude, g.pulses[p].amplitude);
    EXPECT_EQ(f.pulse_weight[p], g.pulse_weight[p]);
  }
  EXPECT_EQ(f.pulse_vertices, g.pulse_vertices);
  EXPECT_EQ(f.breathing, g.breathing);
  ASSERT_EQ(f.dynamic_count, g.dynamic_count);
  for (std::size_t r = 0; r < f.dynamic_count; ++r) {
    EXPECT_EQ(f.dynamic[r].keyframe_count, g.dynamic[r].keyframe_count);
    for (std::size_t k = 0; k < f.dynamic[r].keyframe_count; ++k) EXPECT_EQ(f.dynamic[r].keyframes[k], g.dynamic[r].keyframes[k]);
    EXPECT_EQ(f.dynamic[r].guarding, g.dynamic[r].guarding);
    EXPECT_EQ(f.dynamic_weight[r], g.dynamic_weight[r]);
  }
}

// A tissue with every part of the field in use: lesions, a pulse,
// breathing, a dynamic region with keyframes and guarding, a scaled map.
std::shared_ptr<const haptics::TissueModel> full_tissue(const mesh::SurfaceMesh& m) {
  tissue::Lesion l;
  l.centre = Vec3(0.003, -0.002, -0.005);
  l.semi_axes = Vec3(0.002, 0.003, 0.004);
  tissue::Pulse p;
  p.path = {Vec3(-0.02, 0, 0), Vec3(0.02, 0.001, 0)};
  p.radius = 0.003;
  tissue::Breathing b;
  b.enabled = true;
  b.rate_bpm = 12;
  b.scale = 0.02;
  tissue::DynamicRegion d;
  d.region = "all";
  d.keyframes = {{0.5, 1.5, 0.2}, {2.0, 0.8, 0.0}};
  d.guarding.enabled = true;
  d.guarding.threshold = 2.5;
  std::vector<float> weights(m.vertex_count());
  for (std::size_t i = 0; i < weights.size(); ++i) weights[i] = static_cast<float>(i % 7) / 6.0f;
  auto t = std::make_shared<haptics::TissueModel>();
  t->field = std::make_shared<tissue::TissueField>(tissue::make_field(m, 0.007, {l, l}, {p}, b, {d}, {weights}));
  auto map = std::make_shared<deform::MaterialMap>();
  map->tissues = {test::material(300), test::material(900), test::material(1500)};
  for (std::size_t i = 0; i < m.vertex_count(); ++i) {
    map->tissue_of.push_back(static_cast<std::uint16_t>(i % 3));
    map->scale.push_back(1.0f + static_cast<float>(i % 5) * 0.25f);
  }
  t->map = map;
  return t;
}

TEST(StateIo, ASetTissueCommandRoundTrips) {
  const Rig rig;
  const std::size_t n = rig.model->mesh->vertex_count();
  const auto t = full_tissue(*rig.model->mesh);
  auto c = haptics::LoopCommand::of(haptics::LoopCommandKind::SetTissue);
  c.tissue = t.get();
  std::vector<std::shared_ptr<const deform::MaterialArrays>> keep;
  const haptics::LoopCommand back = decode_command(encode_command(c), n, keep);
  EXPECT_EQ(back.kind, haptics::LoopCommandKind::SetTissue);
  ASSERT_NE(back.tissue, nullptr);
  EXPECT_NE(back.tissue, t.get());
  ASSERT_EQ(keep.size(), 1u);
  expect_same_tissue(*back.tissue, *t);
  // No field, no map: both come back null.
  const auto empty = std::make_shared<haptics::TissueModel>();
  c.tissue = empty.get();
  const haptics::LoopCommand none = decode_command(encode_command(c), n, keep);
  ASSERT_NE(none.tissue, nullptr);
  EXPECT_EQ(none.tissue->map, nullptr);
  EXPECT_EQ(none.tissue->field, nullptr);
}

// The command's bytes before packing, changed by `edit`, packed again.
std::vector<std::uint8_t> repacked(const haptics::LoopCommand& c,
                                   const std::function<void(std::vector<std::uint8_t>&)>& edit) {
  constexpr std::uint32_t kCommandMagic = 0x31435350;  // "PSC1", state_io.cpp
  auto bytes = internal::unpack(encode_command(c), kCommandMagic, "command");
  edit(bytes);
  return internal::pack(bytes, kCommandMagic);
}

TEST(StateIo, ABadSetTissuePayloadIsNamed) {
  const Rig rig;
  const std::size_t n = rig.model->mesh->vertex_count();
  const auto t = full_tissue(*rig.model->mesh);
  auto c = haptics::LoopCommand::of(haptics::LoopCommandKind::SetTissue);
  c.tissue = t.get();
  std::vector<std::shared_ptr<const deform::MaterialArrays>> keep;
  auto message = [&](const std::vector<std::uint8_t>& blob, std::size_t vertices) -> std::string {
    try {
      decode_command(blob, vertices, keep);
    } catch (const DecodeError& e) {
      return e.what();
    }
    return "no error";
  };
  // Cut short (in its last array, and in its first fixed part), and one
  // vertex more than the tissue was made for.
  EXPECT_EQ(message(repacked(c, [](auto& b) { b.resize(b.size() - 9); }), n),
            "SetTissue command: the field's dynamic region 0 weights end early (" + std::to_string(n) + " entries, " +
                std::to_string(4 * n - 9) + " bytes left)");
  EXPECT_EQ(message(repacked(c, [](auto& b) { b.resize(sizeof(haptics::LoopCommand) + 5); }), n), "command ends early");
  EXPECT_EQ(message(encode_command(c), n + 1),
            "SetTissue command: a tissue map has " + std::to_string(n) + " tissue indices, the mesh " +
                std::to_string(n + 1) + " vertices");
  // Counts over their limits, as a damaged file would hold them.
  auto many = std::make_shared<tissue::TissueField>(*t->field);
  many->lesion_count = 33;
  auto bad = std::make_shared<haptics::TissueModel>(haptics::TissueModel{t->map, many});
  c.tissue = bad.get();
  EXPECT_EQ(message(encode_command(c), n), "SetTissue command: the field has 33 lesions, at most 32");
  auto pulses = std::make_shared<tissue::TissueField>(*t->field);
  pulses->pulse_count = 5;
  bad = std::make_shared<haptics::TissueModel>(haptics::TissueModel{nullptr, pulses});
  c.tissue = bad.get();
  EXPECT_EQ(message(encode_command(c), n), "SetTissue command: the field has 5 pulses, at most 4");
  // A tissue index past the map's tissues: what validate_tissue says, named.
  auto map = std::make_shared<deform::MaterialMap>(*t->map);
  map->tissue_of[7] = 3;
  bad = std::make_shared<haptics::TissueModel>(haptics::TissueModel{map, nullptr});
  c.tissue = bad.get();
  EXPECT_EQ(message(encode_command(c), n),
            "SetTissue command: tissue: the map's tissue of vertex 7 is 3, but there are 3 tissues");
  // A flag that is neither 0 nor 1, and a SetTissue without its tissue.
  c.tissue = t.get();
  EXPECT_EQ(message(repacked(c, [](auto& b) { b[sizeof(haptics::LoopCommand) + 1] = 7; }), n),
            "command: the tissue flag is 7, not 0 or 1");
  EXPECT_EQ(message(repacked(c, [](auto& b) {
                      b.resize(sizeof(haptics::LoopCommand) + 2);
                      b.back() = 0;
                    }), n),
            "a SetTissue command without its tissue");
}

TEST(StateIo, ASnapshotWithATissueEditPendingOrInForceRoundTripsAndStepsOnAlike) {
  const Rig rig;
  const auto t = full_tissue(*rig.model->mesh);
  auto s = rig.session();
  std::array<haptics::ProbeTickInput, 2> in;
  std::array<haptics::ProbeTickResult, 2> out, again_out;
  auto step = [&](haptics::Session& session, std::uint64_t n, std::array<haptics::ProbeTickResult, 2>& o) {
    for (std::size_t j = 0; j < 2; ++j) in[j] = test::input(j, n);
    session.step(static_cast<double>(n) * 1e-3, in, o);
  };
  for (std::uint64_t n = 0; n < 300; ++n) {
    if (n == 0) {
      s->apply(haptics::LoopCommand::of(haptics::LoopCommandKind::Enable, 0), 0);
      s->apply(haptics::LoopCommand::of(haptics::LoopCommandKind::Enable, 1), 0);
    }
    step(*s, n, out);
  }
  s->set_tissue(t, 0.3);
  std::vector<haptics::SessionState> snaps{s->snapshot()};  // the edit pending
  for (std::uint64_t n = 300; n < 400; ++n) step(*s, n, out);
  snaps.push_back(s->snapshot());  // in force
  for (const auto& snap : snaps) {
    const DecodedState d = decode_state(encode_state(snap), *rig.model);
    ASSERT_NE(d.state.tissue, nullptr);
    expect_same_tissue(*d.state.tissue, *t);
    EXPECT_EQ(d.state.core.tissue, d.state.tissue.get());
    if (snap.core.pending.any()) {
      EXPECT_EQ(d.state.core.pending.tissue, d.state.tissue.get());
      EXPECT_EQ(d.state.pending_tissue_map, d.state.tissue->map) << "one copy of the map";
    } else {
      EXPECT_EQ(d.state.surface_tissue, d.state.tissue);
      EXPECT_EQ(d.state.materials.tissue_map, d.state.tissue->map);
    }
    // A fresh session (built without the tissue) restored from the bytes
    // steps on with the same bits as the original from the same state.
    auto original = rig.session();
    original->restore(snap);
    auto again = rig.session();
    again->restore(d.state);
    for (std::uint64_t n = snap.tick; n < 700; ++n) {
      step(*original, n, out);
      step(*again, n, again_out);
      for (std::size_t j = 0; j < 2; ++j)
        ASSERT_TRUE(same_bits(out[j].force_world, again_out[j].force_world)) << "tick " << n;
    }
    EXPECT_EQ(original->field(), t->field.get());
    EXPECT_EQ(again->field(), d.state.tissue->field.get());
  }
}

// A replay's pending deformation steps go with a snapshot and come back the
// same; a state without them keeps the bytes it always had; a step with a
// map edit cannot be stored and says so.
// The walks' prepared triangles (collision::FrameCache) are a cache of this
// process's mesh, holding its address: a snapshot carries none of them
// (the address is nowhere in its bytes), and a decoded state has none,
// whatever the file holds.
TEST(StateIo, ASnapshotCarriesNoPreparedTriangles) {
  const Rig rig;
  auto s = rig.session();
  std::array<haptics::ProbeTickInput, 2> in;
  std::array<haptics::ProbeTickResult, 2> out;
  s->apply(haptics::LoopCommand::of(haptics::LoopCommandKind::Enable, 0), 0);
  s->apply(haptics::LoopCommand::of(haptics::LoopCommandKind::Enable, 1), 0);
  for (std::uint64_t n = 0; n < 300; ++n) {
    for (std::size_t j = 0; j < 2; ++j) in[j] = test::input(j, n);
    s->step(static_cast<double>(n) * 1e-3, in, out);
  }
  const haptics::SessionState snap = s->snapshot();
  auto prepared = [](const haptics::CoreState& core) {
    std::size_t k = 0;
    for (const haptics::ProbeMemory& m : core.memory) k += static_cast<std::size_t>(m.cursor.frames.held());
    return k;
  };
  ASSERT_GT(prepared(snap.core), 0u) << "the probes walked no triangle: nothing to check";
  const mesh::SurfaceMesh* owner = nullptr;
  for (const haptics::ProbeMemory& m : snap.core.memory)
    if (m.cursor.frames.held() > 0) owner = m.cursor.frames.owner;
  ASSERT_NE(owner, nullptr);
  std::array<std::uint8_t, sizeof(owner)> address{};
  std::memcpy(address.data(), &owner, sizeof(owner));
  const std::uint32_t magic = 0x31535350;  // "PSS1", state_io.cpp's kStateMagic
  const std::vector<std::uint8_t> bytes = encode_state(snap);
  auto raw = internal::unpack(bytes, magic, "snapshot");
  EXPECT_EQ(std::search(raw.begin(), raw.end(), address.begin(), address.end()), raw.end())
      << "the mesh's address is in the snapshot";
  EXPECT_EQ(prepared(decode_state(bytes, *rig.model).state.core), 0u);
  // A file whose state holds prepared triangles (the cursors' bytes as they
  // are in memory, after the tick, the generation and the model time).
  const std::size_t at = 2 * sizeof(std::uint64_t) + sizeof(double);
  ASSERT_GE(raw.size(), at + sizeof(haptics::CoreState));
  std::memcpy(raw.data() + at, static_cast<const void*>(&snap.core), sizeof(haptics::CoreState));
  const DecodedState forged = decode_state(internal::pack(raw, magic), *rig.model);
  EXPECT_EQ(prepared(forged.state.core), 0u);
}

TEST(StateIo, PendingStepsRoundTripWithASnapshot) {
  const Rig rig;
  auto s = rig.session();
  const haptics::SessionState snap = s->snapshot();
  std::deque<haptics::DeformRequest> pending(2);
  pending[0].generation = 7;
  pending[0].tick = 41;
  pending[0].time = 0.041;
  pending[0].dt = 1.0 / 300;
  pending[0].contacts.tick = 41;
  pending[0].contacts.count = 1;
  pending[0].contacts.contacts[0].depth = 0.0025;
  pending[1].generation = 8;
  pending[1].tick = 44;
  pending[1].edits.reset = true;
  pending[1].edits.material = 1;
  pending[1].edits.uniform = test::material(900);
  EXPECT_EQ(encode_state(snap, {}), encode_state(snap)) << "no pending steps: the bytes of before";
  const DecodedState d = decode_state(encode_state(snap, pending), *rig.model);
  ASSERT_EQ(d.pending.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(d.pending[k].generation, pending[k].generation);
    EXPECT_EQ(d.pending[k].tick, pending[k].tick);
    EXPECT_EQ(d.pending[k].time, pending[k].time);
    EXPECT_EQ(d.pending[k].dt, pending[k].dt);
    EXPECT_EQ(d.pending[k].contacts.count, pending[k].contacts.count);
    EXPECT_EQ(d.pending[k].contacts.contacts[0].depth, pending[k].contacts.contacts[0].depth);
    EXPECT_EQ(d.pending[k].edits.reset, pending[k].edits.reset);
    EXPECT_EQ(d.pending[k].edits.material, pending[k].edits.material);
    EXPECT_EQ(d.pending[k].edits.uniform.stiffness, pending[k].edits.uniform.stiffness);
  }
  EXPECT_TRUE(decode_state(encode_state(snap), *rig.model).pending.empty());

  const deform::MaterialArrays map = rig.initial;
  pending[1].edits.material = 2;
  pending[1].edits.map = &map;
  EXPECT_FALSE(storable(pending));
  try {
    encode_state(snap, pending);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "snapshot: a pending deformation step with a material map or tissue edit");
  }
}

// Damaged pending steps are refused with a message that names the fault,
// before a deformation step could use them: a contact off the mesh, not
// finite, of an unknown shape; a bad material; a count of steps out of
// range or steps that end early (bytes edited after the state).
TEST(StateIo, DamagedPendingStepsGiveAnError) {
  const Rig rig;
  auto s = rig.session();
  const haptics::SessionState snap = s->snapshot();
  const std::size_t n = rig.model->mesh->vertex_count();
  const auto refused = [&](const std::deque<haptics::DeformRequest>& pending, const std::string& expected) {
    try {
      decode_state(encode_state(snap, pending), *rig.model);
      ADD_FAILURE() << "no error; expected " << expected;
    } catch (const DecodeError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  haptics::DeformRequest good;
  good.tick = 3;
  good.contacts.count = 1;
  good.contacts.contacts[0].vertex = static_cast<Index>(n - 1);
  good.contacts.contacts[0].depth = 0.002;
  EXPECT_EQ(decode_state(encode_state(snap, {good}), *rig.model).pending.size(), 1u) << "the unedited step reads";

  auto q = good;
  q.contacts.contacts[0].vertex = static_cast<Index>(n);
  refused({q}, "pending step whose contact 0 is at vertex " + std::to_string(n) + " of " + std::to_string(n));
  q = good;
  q.contacts.count = haptics::kMaxProbes + 1;
  refused({q}, "pending step with " + std::to_string(haptics::kMaxProbes + 1) + " contacts");
  q = good;
  q.contacts.contacts[0].depth = std::numeric_limits<double>::quiet_NaN();
  refused({q}, "not finite");
  q = good;
  q.contacts.contacts[0].shape.radius = 0;
  refused({q}, "radius that is not > 0 m");
  q = good;
  q.contacts.contacts[0].shape.kind = static_cast<deform::ShapeKind>(7);
  refused({q}, "unknown shape");
  q = good;
  q.edits.material = 1;
  q.edits.uniform = test::material(400);
  q.edits.uniform.mass = 0;
  refused({q}, "snapshot: a pending step's material: mass");

  // Counts and lengths, edited in the unpacked bytes: the count is the
  // 4 bytes after the state; each step after it has a fixed size.
  const std::uint32_t magic = 0x31535350;  // "PSS1", state_io.cpp's kStateMagic
  const auto plain = internal::unpack(encode_state(snap), magic, "snapshot");
  const auto with_one = internal::unpack(encode_state(snap, {good}), magic, "snapshot");
  ASSERT_GT(with_one.size(), plain.size() + 4);
  const auto edited = [&](std::uint32_t count, std::size_t cut) {
    auto b = with_one;
    std::memcpy(b.data() + plain.size(), &count, 4);
    b.resize(b.size() - cut);
    return internal::pack(b, magic);
  };
  for (const auto& [count, cut, expected] :
       {std::tuple<std::uint32_t, std::size_t, std::string>{0, 0, "snapshot has 0 pending deformation steps"},
        {kMaxPendingSteps + 1, 0, "snapshot has 4097 pending deformation steps (1 to 4096 expected)"},
        {2, 0, "snapshot"},
        {1, 1, "snapshot"}}) {
    try {
      decode_state(edited(count, cut), *rig.model);
      ADD_FAILURE() << "no error for " << count << " steps, " << cut << " bytes cut";
    } catch (const DecodeError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
  // More steps than a reader takes are not stored at all.
  const std::deque<haptics::DeformRequest> many(kMaxPendingSteps + 1, good);
  EXPECT_FALSE(storable(many));
  EXPECT_THROW(encode_state(snap, many), std::invalid_argument);
  EXPECT_TRUE(storable(std::deque<haptics::DeformRequest>(kMaxPendingSteps, good)));
}

// Snapshots are added only to a finished (or interrupted) session: never
// beside a writer that is still recording it (another process, alive; once
// it is killed the file is interrupted and takes them).
TEST(SnapshotAppender, RefusesASessionStillBeingRecorded) {
  const auto file = test::temp_dir() / "still_recording.palpa";
  std::filesystem::remove(file);
  const Rig rig;
  int ready[2], hold[2];
  ASSERT_EQ(pipe(ready), 0);
  ASSERT_EQ(pipe(hold), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    Recorder r(file, *rig.model, rig.initial, rig.setups, {});
    char c = 1;
    if (write(ready[1], &c, 1) != 1) _exit(2);
    while (read(hold[0], &c, 1) < 0) {
    }
    _exit(0);  // never reached: the parent kills it
  }
  char c = 0;
  ASSERT_EQ(read(ready[0], &c, 1), 1);
  try {
    SnapshotAppender a(file);
    ADD_FAILURE() << "no error";
  } catch (const RecordError& e) {
    EXPECT_EQ(std::string(e.what()),
              file.string() + ": cannot add snapshots: still being recorded (by process " + std::to_string(child) + ")");
  }
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  for (int fd : {ready[0], ready[1], hold[0], hold[1]}) close(fd);
  EXPECT_NO_THROW(SnapshotAppender a(file)) << "an interrupted session takes snapshots";
}

TEST(Recorder, RefusesToOverwriteASession) {
  const auto file = test::temp_dir() / "exists.palpa";
  { std::ofstream(file) << "keep me"; }
  const Rig rig;
  try {
    Recorder r(file, *rig.model, rig.initial, rig.setups, {});
    FAIL() << "no error";
  } catch (const RecordError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": exists; a recorder never overwrites a session");
  }
  std::ifstream in(file);
  std::string s;
  std::getline(in, s);
  EXPECT_EQ(s, "keep me");
}

TEST(Recorder, CountsDroppedRecordsWhenTheWriterFallsBehind) {
  const auto file = test::temp_dir() / "drops.palpa";
  std::filesystem::remove(file);
  const Rig rig;
  RecorderOptions o;
  o.queue_capacity = 16;  // far too small for a producer that never waits
  std::uint64_t refused = 0;
  {
    Recorder r(file, *rig.model, rig.initial, rig.setups, {}, o);
    haptics::TickRecord t;
    t.probe_count = 2;
    for (std::uint64_t n = 0; n < 20000; ++n) {
      t.tick = n;
      refused += r.push_tick(t) ? 0 : 1;
    }
    r.finish();
    EXPECT_EQ(r.stats().dropped, refused);
  }
  ASSERT_GT(refused, 0u);
  const auto f = SessionFile::open(file);
  EXPECT_EQ(f.header().dropped, refused);
  EXPECT_EQ(f.header().ticks, 20000 - refused);
}

}  // namespace
}  // namespace palpa::record

namespace palpa::record {
namespace {

// A guarding region that reacts to 0.05 N: the press triggers it, and
// record_step writes the reaction as an event.
TEST(Recorder, WritesGuardingReactionsAsEvents) {
  const auto file = test::temp_dir() / "guarding.palpa";
  std::filesystem::remove(file);
  const Rig rig;
  tissue::DynamicRegion d;
  d.region = "all";
  d.guarding.enabled = true;
  d.guarding.threshold = 0.05;
  d.guarding.duration = 0.1;
  auto field = std::make_shared<tissue::TissueField>(tissue::make_field(
      *rig.model->mesh, 0.008, {}, {}, {}, {d}, {std::vector<float>(rig.model->mesh->vertex_count(), 1.0f)}));
  const auto model = haptics::SessionModel::make(rig.model->mesh, {}, rig.model->config, field);
  haptics::Session s(model, rig.initial, rig.setups);
  RecorderOptions o;
  o.block_when_full = true;
  {
    Recorder r(file, *model, rig.initial, rig.setups, Rig::info(), o);
    std::array<haptics::ProbeTickInput, 2> in;
    std::array<haptics::ProbeTickResult, 2> out;
    record_apply(r, s, haptics::LoopCommand::of(haptics::LoopCommandKind::Enable, 0), 0);
    for (std::uint64_t n = 0; n < 300; ++n) {
      for (std::size_t j = 0; j < 2; ++j) in[j] = test::input(j, n);
      record_step(r, s, static_cast<double>(n) * 1e-3, in, out);
    }
    r.finish();
  }
  const auto f = SessionFile::open(file);
  std::size_t reactions = 0;
  for (const auto& e : f.events()) reactions += e.kind == EventKind::Reaction;
  EXPECT_GE(reactions, 1u);
  EXPECT_EQ(f.events().front().value, 0.0);
  EXPECT_STREQ(f.events().front().text, "guarding triggered");
}

}  // namespace
}  // namespace palpa::record
