// palpa-palpate --record, palpa-replay and palpa-assess end to end: a
// recorded scripted session replays bit-identical through the command line;
// an altered input is reported from the tick it changes; the video and
// frame outputs; the assessment files; every usage and file error by its
// exact message.

#include "record/internal_codec.h"

#include <sqlite3.h>
#include <sys/wait.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;

struct Result {
  int rc = -1;
  std::string out, err;
};

// Runs a command line, capturing stdout and stderr.
Result run(const std::string& cmd) {
  const fs::path dir = fs::temp_directory_path();
  const std::string out = (dir / ("palpa-replay-test-out-" + std::to_string(getpid()))).string();
  const std::string err = (dir / ("palpa-replay-test-err-" + std::to_string(getpid()))).string();
  Result r;
  const int status = std::system((cmd + " >" + out + " 2>" + err).c_str());
  r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  auto slurp = [](const std::string& f) {
    std::ifstream in(f);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  };
  r.out = slurp(out);
  r.err = slurp(err);
  fs::remove(out);
  fs::remove(err);
  return r;
}

class ReplayCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("palpa-replay-test-" + std::to_string(getpid()));
    fs::create_directories(dir_);
    session_ = (dir_ / "s.palpa").string();
    const Result r = run(std::string(PALPA_PALPATE) + " --seconds 1 --probes 2 --record " + session_);
    ASSERT_EQ(r.rc, 0) << r.err;
    ASSERT_NE(r.out.find("bytes per probe-tick"), std::string::npos) << r.out;
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  static inline fs::path dir_;
  static inline std::string session_;
};

TEST_F(ReplayCli, RecordedSessionReplaysBitIdentical) {
  const Result r = run(std::string(PALPA_REPLAY) + " " + session_);
  EXPECT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("session " + session_ + ": finished, 1000 ticks (1.00 s at 1000 Hz), 2 probes, 0 dropped records"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("replay: forces bit-identical to the recording over 1000 ticks"), std::string::npos) << r.out;
}

// A generated organ is renumbered in spatial order before the session; its
// normals must be those the session file gives back (found: with its old
// normals permuted this session replayed 5.4e-20 N off from tick 1162).
TEST_F(ReplayCli, AGeneratedOrgansSessionReplaysBitIdentical) {
  const std::string session = (dir_ / "generated.palpa").string();
  const Result rec =
      run(std::string(PALPA_PALPATE) + " --organ-vertices 50000 --probes 3 --seconds 1.5 --record " + session);
  ASSERT_EQ(rec.rc, 0) << rec.err;
  const Result r = run(std::string(PALPA_REPLAY) + " " + session);
  EXPECT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("replay: forces bit-identical to the recording over 1500 ticks"), std::string::npos) << r.out;
}

TEST_F(ReplayCli, RecordNeverOverwrites) {
  const Result r = run(std::string(PALPA_PALPATE) + " --seconds 0.1 --record " + session_);
  EXPECT_EQ(r.rc, 1);
  EXPECT_EQ(r.err, "palpa-palpate: " + session_ + ": exists; a recorder never overwrites a session\n");
}

// Moves probe 0's recorded positions by 1 mm in x from the chunk that holds
// tick `tick` on (to its end); returns that chunk's first tick.
std::int64_t shift_probe_positions(const std::string& file, std::int64_t tick) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db,
                               "SELECT first_tick, count, position FROM probe_chunks WHERE probe = 0 AND first_tick <= ? "
                               "ORDER BY first_tick DESC LIMIT 1",
                               -1, &st, nullptr),
            SQLITE_OK);
  sqlite3_bind_int64(st, 1, tick);
  EXPECT_EQ(sqlite3_step(st), SQLITE_ROW);
  const auto first = sqlite3_column_int64(st, 0);
  const auto count = static_cast<std::size_t>(sqlite3_column_int64(st, 1));
  const auto* b = static_cast<const std::uint8_t*>(sqlite3_column_blob(st, 2));
  std::vector<double> pos(3 * count);
  palpa::record::internal::decode_column({b, static_cast<std::size_t>(sqlite3_column_bytes(st, 2))}, 3 * count, 8,
                                         pos.data());
  sqlite3_finalize(st);
  for (std::size_t i = 0; i < count; ++i) pos[3 * i] += 1e-3;
  const auto blob = palpa::record::internal::encode_column(pos.data(), pos.size(), 8, palpa::record::internal::Codec::XorFloat);
  EXPECT_EQ(sqlite3_prepare_v2(db, "UPDATE probe_chunks SET position = ? WHERE probe = 0 AND first_tick = ?", -1, &st, nullptr),
            SQLITE_OK);
  sqlite3_bind_blob(st, 1, blob.data(), static_cast<int>(blob.size()), SQLITE_TRANSIENT);
  sqlite3_bind_int64(st, 2, first);
  EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
  sqlite3_finalize(st);
  sqlite3_close(db);
  return first;
}

// Probe 1's positions moved by 1 mm from the chunk that holds t = 0.5 s on:
// the replay says the forces differ from that chunk's first tick.
TEST_F(ReplayCli, AlteredInputIsFoundFromTheTickItChanges) {
  const std::string altered = (dir_ / "altered.palpa").string();
  fs::copy_file(session_, altered, fs::copy_options::overwrite_existing);
  const auto first = shift_probe_positions(altered, 500);
  const Result r = run(std::string(PALPA_REPLAY) + " " + altered);
  EXPECT_EQ(r.rc, 3) << r.out << r.err;
  EXPECT_NE(r.out.find("replay: forces differ from tick " + std::to_string(first) + " (t = "), std::string::npos) << r.out;
}

TEST_F(ReplayCli, FramesAndVideo) {
  const fs::path frames = dir_ / "frames";
  const fs::path video = dir_ / "v.mp4";
  const Result r = run(std::string(PALPA_REPLAY) + " " + session_ + " --frames " + frames.string() + " --video " +
                    video.string() + " --size 320x240 --fps 10 --to 0.5");
  ASSERT_EQ(r.rc, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("wrote 6 frames"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(frames / "frame_000006.png"));
  EXPECT_FALSE(fs::exists(frames / "frame_000007.png"));
  // An MP4 starts with its ftyp box.
  std::ifstream in(video, std::ios::binary);
  char head[8] = {};
  in.read(head, 8);
  EXPECT_EQ(std::string(head + 4, 4), "ftyp");
  // A PNG of the frame size.
  std::ifstream png(frames / "frame_000001.png", std::ios::binary);
  unsigned char h[24] = {};
  png.read(reinterpret_cast<char*>(h), 24);
  EXPECT_EQ((h[16] << 24 | h[17] << 16 | h[18] << 8 | h[19]), 320);
  EXPECT_EQ((h[20] << 24 | h[21] << 16 | h[22] << 8 | h[23]), 240);
}

// The three-thread replay draws the same frames as the stages run one after
// the other, bit for bit, though it draws them in two scenes (two GL
// contexts) in turn, warms each scene up with a draw of the organ at rest,
// and brings a scene's stream up to date with the changes of two packets at
// once.
TEST_F(ReplayCli, PipelinedFramesAreTheSequentialFrames) {
  const fs::path on = dir_ / "pipeline_on", off = dir_ / "pipeline_off";
  const std::string common = " --size 320x240 --fps 20 --from 0.2 --to 0.7";
  const Result a = run(std::string(PALPA_REPLAY) + " " + session_ + " --frames " + on.string() + common);
  const Result b =
      run(std::string(PALPA_REPLAY) + " " + session_ + " --frames " + off.string() + common + " --pipeline off");
  ASSERT_EQ(a.rc, 0) << a.out << a.err;
  ASSERT_EQ(b.rc, 0) << b.out << b.err;
  EXPECT_NE(b.out.find("one stage at a time"), std::string::npos) << b.out;
  std::size_t frames = 0;
  for (const auto& e : fs::directory_iterator(on)) {
    const cv::Mat x = cv::imread(e.path().string(), cv::IMREAD_UNCHANGED);
    const cv::Mat y = cv::imread((off / e.path().filename()).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(x.empty());
    ASSERT_FALSE(y.empty()) << e.path().filename();
    EXPECT_EQ(cv::norm(x, y, cv::NORM_INF), 0) << e.path().filename();
    ++frames;
  }
  EXPECT_EQ(frames, 11u);
}

// Redrawing only the pixels that changed since a scene's last frame (the
// default) against drawing every frame whole: the same frames, byte for
// byte, in both scenes of the pipeline and one stage at a time. The frames
// change from one to the next (probes move, the organ dents), so a region
// that misses a change shows as a stale pixel.
TEST_F(ReplayCli, RedrawingOnlyWhatChangedGivesTheWholeFrames) {
  const fs::path part = dir_ / "damage_on", whole = dir_ / "damage_off", seq = dir_ / "damage_seq";
  // No overlays: every pixel is the 3D scene's.
  const std::string common = " --size 320x240 --fps 30 --from 0.1 --to 0.9 --overlays none";
  const Result a = run(std::string(PALPA_REPLAY) + " " + session_ + " --frames " + part.string() + common);
  const Result b = run(std::string(PALPA_REPLAY) + " " + session_ + " --frames " + whole.string() + common +
                       " --damage off");
  const Result c = run(std::string(PALPA_REPLAY) + " " + session_ + " --frames " + seq.string() + common +
                       " --pipeline off");
  ASSERT_EQ(a.rc, 0) << a.out << a.err;
  ASSERT_EQ(b.rc, 0) << b.out << b.err;
  ASSERT_EQ(c.rc, 0) << c.out << c.err;
  std::size_t frames = 0, changed = 0;
  cv::Mat last;
  for (std::size_t i = 1;; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06zu.png", i);
    const cv::Mat x = cv::imread((part / name).string(), cv::IMREAD_UNCHANGED);
    if (x.empty()) break;
    const cv::Mat y = cv::imread((whole / name).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat z = cv::imread((seq / name).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(y.empty()) << name;
    ASSERT_FALSE(z.empty()) << name;
    EXPECT_EQ(cv::norm(x, y, cv::NORM_INF), 0) << name << ": partly redrawn (two scenes) vs whole";
    EXPECT_EQ(cv::norm(z, y, cv::NORM_INF), 0) << name << ": partly redrawn (one scene) vs whole";
    if (!last.empty() && cv::norm(x, last, cv::NORM_INF) > 0) ++changed;
    last = x;
    ++frames;
  }
  EXPECT_EQ(frames, 25u);
  EXPECT_GE(changed, 20u) << "the frames hardly change: the test would not see a stale pixel";
}

// Culling the closed organ's back faces and blending the translucent shafts
// plainly (the defaults) against VTK's full path (--cull off --translucency
// oit): the organ, background and overlays are the same pixels; only the
// probe shafts (60% opaque) may differ, where VTK's weighted order-
// independent translucency (16-bit float accumulation, both cylinder walls
// weighted together) and plain blending (the walls in drawing order) round
// differently. So: few pixels differ at all, and the differing ones are few.
TEST_F(ReplayCli, CulledAndPlainlyBlendedFramesMatchVtksFullPath) {
  const fs::path fast = dir_ / "fast", full = dir_ / "full";
  const std::string common = " --size 640x360 --fps 10 --from 0.3 --to 0.6";
  const Result a = run(std::string(PALPA_REPLAY) + " " + session_ + " --frames " + fast.string() + common);
  const Result b = run(std::string(PALPA_REPLAY) + " " + session_ + " --frames " + full.string() + common +
                       " --cull off --translucency oit");
  ASSERT_EQ(a.rc, 0) << a.out << a.err;
  ASSERT_EQ(b.rc, 0) << b.out << b.err;
  std::size_t frames = 0;
  for (const auto& e : fs::directory_iterator(fast)) {
    const cv::Mat x = cv::imread(e.path().string(), cv::IMREAD_COLOR);
    const cv::Mat y = cv::imread((full / e.path().filename()).string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(x.empty());
    ASSERT_FALSE(y.empty()) << e.path().filename();
    cv::Mat d;
    cv::absdiff(x, y, d);
    std::vector<cv::Mat> c;
    cv::split(d, c);
    const cv::Mat m = cv::max(cv::max(c[0], c[1]), c[2]);
    const double any = cv::countNonZero(m > 0), big = cv::countNonZero(m > 24);
    const double pixels = static_cast<double>(x.total());
    std::printf("%s: %.0f pixels differ (%.3f%%), %.0f by more than 24 levels, at most %.0f\n",
                e.path().filename().c_str(), any, 100 * any / pixels, big, cv::norm(d, cv::NORM_INF));
    EXPECT_LE(any, 0.005 * pixels) << e.path().filename();
    EXPECT_LE(big, 0.001 * pixels) << e.path().filename();
    ++frames;
  }
  EXPECT_EQ(frames, 4u);
}

TEST_F(ReplayCli, AssessExportsTicksOrganAndMarkups) {
  const fs::path csv = dir_ / "t.csv", vtp = dir_ / "o.vtp", mrk = dir_ / "m.mrk.json";
  const Result r = run(std::string(PALPA_ASSESS) + " " + session_ + " --csv " + csv.string() + " --vtp " + vtp.string() +
                       " --markups " + mrk.string());
  ASSERT_EQ(r.rc, 0) << r.err;
  std::ifstream c(csv);
  std::string line;
  std::size_t lines = 0;
  std::getline(c, line);
  EXPECT_EQ(line.rfind("tick,time_s,probe,position_x_m", 0), 0u);
  while (std::getline(c, line)) ++lines;
  EXPECT_EQ(lines, 2000u);  // 1000 ticks x 2 probes
  std::ifstream v(vtp);
  std::stringstream vs;
  vs << v.rdbuf();
  EXPECT_NE(vs.str().find("<VTKFile type=\"PolyData\""), std::string::npos);
  EXPECT_NE(vs.str().find("Name=\"coverage_level\""), std::string::npos);
  EXPECT_NE(vs.str().find("Name=\"peak_force_n\""), std::string::npos);
  std::ifstream m(mrk);
  std::stringstream ms;
  ms << m.rdbuf();
  EXPECT_NE(ms.str().find("\"name\": \"marks\""), std::string::npos);
}

TEST_F(ReplayCli, AssessWritesJsonAndHtml) {
  const fs::path json = dir_ / "a.json", html = dir_ / "a.html";
  const Result r = run(std::string(PALPA_ASSESS) + " " + session_ + " --json " + json.string() + " --html " + html.string());
  ASSERT_EQ(r.rc, 0) << r.err;
  std::ifstream j(json);
  std::stringstream js;
  js << j.rdbuf();
  EXPECT_NE(js.str().find("\"ticks\": 1000"), std::string::npos) << js.str();
  EXPECT_NE(js.str().find("\"probes\": 2"), std::string::npos);
  std::ifstream h(html);
  std::stringstream hs;
  hs << h.rdbuf();
  EXPECT_NE(hs.str().find("data:image/png;base64,"), std::string::npos);
}

TEST(ReplayCliErrors, Messages) {
  struct Case {
    std::string args;
    int rc;
    std::string first_line;
  };
  const std::string missing = (fs::temp_directory_path() / "palpa-no-such-session.palpa").string();
  const Case cases[] = {
      {"", 2, "palpa-replay: no session file given"},
      {missing, 1, "palpa-replay: " + missing + ": no such file"},
      {"s.palpa --size 10x10", 2, "palpa-replay: --size: expected WxH with 64 <= W <= 7680 and 64 <= H <= 4320, got '10x10'"},
      {"s.palpa --fps 0", 2, "palpa-replay: --fps: expected a rate in [1, 240], got 0"},
      {"s.palpa --overlays force,sparkles", 2,
       "palpa-replay: --overlays: unknown overlay 'sparkles' (expected force, levels, coverage, marks, timeline)"},
      {"s.palpa --from 2 --to 1", 2, "palpa-replay: --to must be after --from"},
      {"s.palpa --colour red", 2, "palpa-replay: unknown option '--colour'"},
      {"a.palpa b.palpa", 2, "palpa-replay: one session at a time, got 'b.palpa' too"},
  };
  for (const auto& c : cases) {
    const Result r = run(std::string(PALPA_REPLAY) + " " + c.args);
    EXPECT_EQ(r.rc, c.rc) << c.args;
    // The error is the last non-empty line before the usage, or the only line.
    const std::string first = r.err.substr(r.err.find_first_not_of('\n'), r.err.find('\n', r.err.find_first_not_of('\n')) - r.err.find_first_not_of('\n'));
    EXPECT_EQ(first, c.first_line) << c.args;
  }
  const Result a = run(std::string(PALPA_ASSESS) + " " + missing);
  EXPECT_EQ(a.rc, 1);
  EXPECT_EQ(a.err, "palpa-assess: " + missing + ": no such file\n");
}

}  // namespace

// Seeking: a replay from tick 900 restores the latest snapshot before it
// (at tick 801) and replays only from there, with the same forces.
#include "app/replay/session_job.h"
#include "../record/record_rig.h"

namespace {

TEST(ReplaySession, SeeksFromTheLatestSnapshot) {
  const auto file = palpa::record::test::temp_dir() / "seek.palpa";
  fs::remove(file);
  palpa::record::RecorderOptions o;
  o.block_when_full = true;
  o.snapshot_interval_s = 0.4;
  palpa::record::test::Rig().record(file, 1500, o, [](auto&, auto, auto) {});
  const palpa::app::LoadedSession s = palpa::app::load_session(file.string());
  ASSERT_EQ(s.file.snapshots().size(), 3u);
  palpa::app::ForceCheck check;
  std::uint64_t first = 0, seen = 0;
  palpa::app::replay_session(s, 900, 1500, [&](const palpa::haptics::TickRecord& t, auto, const auto&) {
    if (seen++ == 0) first = t.tick;
  }, check, 128);
  EXPECT_EQ(first, 900u);
  EXPECT_EQ(seen, 600u);
  EXPECT_EQ(check.ticks, 1500u - 801u) << "replayed from the snapshot at tick 801";
  EXPECT_TRUE(check.identical) << palpa::app::describe(check);
  // From the start, in small windows: the same.
  palpa::app::ForceCheck all;
  palpa::app::replay_session(s, 0, 1500, nullptr, all, 100);
  EXPECT_EQ(all.ticks, 1500u);
  EXPECT_TRUE(all.identical) << palpa::app::describe(all);
}

// Snapshots added after the fact (a replay of the file, as for a workbench
// recording): one per interval, each at the first tick past its time where
// no deformation step is pending (the script steps every 3 or 4 ticks), and
// a seek from each replays the rest of the recording bit-identically.
TEST(ReplaySession, AddedSnapshotsSeekBitIdentically) {
  const auto dir = palpa::record::test::temp_dir();
  const auto file = dir / "snapshots_added.palpa";
  fs::remove(file);
  palpa::record::RecorderOptions o;
  o.block_when_full = true;
  o.snapshot_interval_s = 0;  // none while recording
  palpa::record::test::Rig().record(file, 1500, o, [](auto&, auto, auto) {});
  const auto before = palpa::app::load_session(file.string()).file.snapshots();

  EXPECT_EQ(palpa::app::add_seek_snapshots(file.string(), 0.4), 3u);
  const palpa::app::LoadedSession s = palpa::app::load_session(file.string());
  std::vector<std::uint64_t> ticks;
  for (const auto& snap : s.file.snapshots()) {
    bool old = false;
    for (const auto& b : before) old = old || b.tick == snap.tick;
    if (!old) ticks.push_back(snap.tick);
  }
  ASSERT_EQ(ticks.size(), 3u);
  std::size_t with_pending = 0;
  for (std::size_t k = 0; k < ticks.size(); ++k) {
    // Tick n runs at n ms: the interval's first tick is 400 (k + 1) (one
    // later where (k + 1) x 0.4 s rounds above its time), and the state after
    // it is where the next tick starts (no map or tissue edit is pending in
    // this session, so none waits).
    EXPECT_GE(ticks[k], 400 * (k + 1) + 1) << "snapshot " << k;
    EXPECT_LE(ticks[k], 400 * (k + 1) + 2) << "snapshot " << k;
    with_pending += !s.file.snapshot(ticks[k], *s.model).pending.empty();
    palpa::app::ForceCheck check;
    std::uint64_t first = 0;
    palpa::app::replay_session(s, ticks[k], 1500, [&](const auto& t, auto, const auto&) {
      if (first == 0) first = t.tick;
    }, check, 128);
    EXPECT_EQ(first, ticks[k]);
    EXPECT_EQ(check.ticks, 1500u - ticks[k]) << "replayed from the snapshot at tick " << ticks[k];
    EXPECT_TRUE(check.identical) << palpa::app::describe(check);
  }
  // The recorded steps come a few ticks after they are asked for, so a
  // snapshot holds steps not yet made; stored without them, a seek from it
  // does not give the recorded forces (what the pending steps are for).
  ASSERT_GT(with_pending, 0u) << "no added snapshot holds pending steps: the test checks nothing about them";
  {
    const auto bare = dir / "snapshots_without_pending.palpa";
    fs::remove(bare);
    fs::copy_file(file, bare);
    std::uint64_t tick = 0;
    for (auto t : ticks)
      if (!s.file.snapshot(t, *s.model).pending.empty()) tick = t;
    palpa::record::SnapshotAppender(bare).add(s.file.snapshot(tick, *s.model).state, {});
    const palpa::app::LoadedSession b = palpa::app::load_session(bare.string());
    // Either the steps it would need are not read (an error) or the forces differ.
    bool failed = false;
    try {
      palpa::app::ForceCheck check;
      palpa::app::replay_session(b, tick, 1500, nullptr, check, 128);
      failed = !check.identical;
    } catch (const std::exception&) {
      failed = true;
    }
    EXPECT_TRUE(failed) << "a seek from a snapshot stored without its pending steps gave the recorded forces";
  }
  // Again: every tick already has its snapshot, none is added.
  EXPECT_EQ(palpa::app::add_seek_snapshots(file.string(), 0.4), 0u);

  EXPECT_THROW(palpa::app::add_seek_snapshots(file.string(), 0), std::invalid_argument);
  // A file whose replay departs from its recorded forces gets snapshots only
  // up to there, and the caller hears from which tick.
  {
    const auto altered = dir / "snapshots_altered.palpa";
    palpa::record::test::Rig().record(altered, 1500, o, [](auto&, auto, auto) {});
    const auto first = shift_probe_positions(altered.string(), 1200);
    try {
      palpa::app::add_seek_snapshots(altered.string(), 0.4);
      ADD_FAILURE() << "no error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(altered.string() + ": seek snapshots stop at tick " + std::to_string(first) +
                                           " (2 added): its replay forces differ from tick " + std::to_string(first)),
                std::string::npos)
          << e.what();
    }
  }
  try {
    palpa::app::add_seek_snapshots((dir / "no_such.palpa").string(), 0.4);
    FAIL() << "no error";
  } catch (const palpa::record::RecordError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such.palpa"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no such file"), std::string::npos) << e.what();
  }
}

}  // namespace
