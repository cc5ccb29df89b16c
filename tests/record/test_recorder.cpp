// The recorder: a scripted session written and read back (every tick's
// inputs, results, commands, deformation steps, snapshots, the mesh and
// the materials), replayed bit for bit from the file, from tick 0 and from
// each snapshot; dropped records counted when the writer cannot keep up.

#include "record_rig.h"
#include "tissue/field.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

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
  ASSERT_EQ(c.size(), 7u);
  EXPECT_EQ(c[2].tick, 200u);
  EXPECT_EQ(c[2].command.kind, haptics::LoopCommandKind::ClutchOn);
  EXPECT_EQ(c[5].command.shape.radius, 0.004);
  ASSERT_EQ(keep.size(), 1u);
  EXPECT_EQ(c[6].command.materials, keep[0].get());
  EXPECT_EQ(keep[0]->stiffness, Rig().stiffness_map().stiffness);
  const auto d = f.deforms();
  EXPECT_GE(d.size(), 440u);  // 300 Hz for 1.5 s, plus the edits-only steps
  for (std::size_t k = 1; k < d.size(); ++k) ASSERT_EQ(d[k].generation, d[k - 1].generation + 1);
  const auto s = f.snapshots();
  ASSERT_EQ(s.size(), 3u);  // at 0.4, 0.8, 1.2 s
  EXPECT_EQ(s[0].tick, 401u);
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
