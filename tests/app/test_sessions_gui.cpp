// Sessions in the workbench window under Xvfb (linked into test_app_gui,
// whose main() makes the QApplication): Record / Stop writes a session file
// of the running loop (the same loop goes on) with the trainee's name that
// record::SessionFile opens and that replays bit for bit; the session
// browser lists it with its trainee and a damaged file with its error (and
// leaves that file as it was), and scores a scenario session as the assess
// module does; the replay seeks to a time and shows the tick and the surface
// that an independent re-simulation of the file (session_job) gives there.
// The loop runs in real time: the tests wait for conditions with a timeout
// and never assert wall-time figures.

#include "app/gui/assessment_dialog.h"
#include "app/gui/main_window.h"
#include "app/gui/replay_panel.h"
#include "app/gui/session_browser.h"
#include "app/gui/session_player.h"
#include "app/replay/session_job.h"
#include "common/test_support.h"
#include "gui_wait.h"
#include "record/session_file.h"
#include "render/surface_view.h"

#include <QAction>
#include <QApplication>
#include <QFileInfo>
#include <QLabel>
#include <QLineEdit>
#include <QSettings>
#include <QSlider>
#include <QTableWidget>
#include <QTextBlock>
#include <QTextDocument>
#include <QTest>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <random>

#include <unistd.h>

namespace palpa::app {
namespace {

using gui_test::kSlowBuild;  // the sanitizer builds: see gui_wait.h

class SessionsGuiTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!qApp)
      GTEST_SKIP() << "no X display: these tests run under tests/app/xvfb_run.sh, which ctest uses for them";
    folder_ = palpa::test::temp_dir("gui_sessions_" + std::to_string(::getpid()) + "_" +
                                    ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(folder_);
    std::filesystem::create_directories(folder_);
  }

  std::unique_ptr<MainWindow> open_window() {
    auto w = std::make_unique<MainWindow>();
    w->resize(1100, 820);
    w->show();
    EXPECT_TRUE(QTest::qWaitForWindowExposed(w.get()));
    w->set_sessions_folder(QString::fromStdString(folder_.string()));
    QTest::qWait(100);
    return w;
  }

  static bool wait_until(const std::function<bool()>& done, int timeout_ms = 30000) {
    return gui_test::wait_until(done, timeout_ms, 10);
  }

  // Records at least `ticks` ticks while the window's mouse probe presses
  // vertex 0 deeper and deeper (the surface moves all along); returns the file.
  static std::filesystem::path record(MainWindow& w, const QString& trainee, std::uint64_t ticks) {
    w.set_trainee(trainee);
    Workbench& wb = w.workbench();
    const haptics::HapticLoop* loop = wb.loop();
    EXPECT_NE(loop, nullptr);
    const std::uint64_t before = loop->ticks();
    EXPECT_TRUE(w.start_recording()) << w.error_text().toStdString();
    EXPECT_TRUE(w.recording());
    EXPECT_EQ(wb.loop(), loop) << "Record must not build another loop";
    EXPECT_TRUE(wb.loop()->running());
    EXPECT_GE(wb.loop()->ticks(), before) << "the loop's tick count goes on";
    const std::filesystem::path file = wb.recording_file();
    // Measured, not asserted (wall time): how long the loop's threads stopped for the snapshot.
    std::printf("the loop paused %.2f ms for the recording's snapshot\n", 1e3 * wb.record_pause());
    EXPECT_TRUE(w.recording_text().startsWith("Recording")) << w.recording_text().toStdString();
    const auto& mesh = *wb.organ().mesh;
    const int id = wb.probes().front().id;
    wb.place(id, mesh.positions[0], mesh.normals[0], 0.0);
    // The press deepens 0.1 mm every 20 of the loop's ticks (20 ms at 1 kHz),
    // by the loop's count, not by how often this thread gets to poll: under
    // load the recording's time still sees the same press.
    const std::uint64_t pressed_from = wb.loop()->ticks();
    int step = 0;
    EXPECT_TRUE(wait_until([&] {
      ++step;
      const auto n = static_cast<double>(wb.loop()->ticks() - pressed_from) / 20;
      wb.set_depth(id, std::min(0.006, 1e-4 * (1 + std::floor(n))));
      return wb.recording_stats().ticks_committed >= ticks && step > 40;
    }));
    // The status bar states the writer's drops (none on a quiet machine; a
    // starved writer may drop some under heavy load, and then says how many).
    const QString text = w.recording_text();
    EXPECT_TRUE(text.contains(" dropped records")) << text.toStdString();
    last_drops_ = wb.recording_stats().dropped;
    EXPECT_TRUE(w.stop_recording()) << w.error_text().toStdString();
    EXPECT_FALSE(w.recording());
    EXPECT_TRUE(w.recording_text().isEmpty());
    EXPECT_EQ(wb.loop(), loop);
    EXPECT_TRUE(wb.loop()->running());
    return file;
  }

  std::filesystem::path folder_;
  static inline std::uint64_t last_drops_ = 0;  // the writer's drops of the last recording, as it counted them
};

TEST_F(SessionsGuiTest, RecordAndStopWriteASessionOfTheRunningLoopWithTheTrainee) {
  auto w = open_window();
  // The controls are there, with tooltips.
  auto* name = w->findChild<QLineEdit*>("traineeName");
  ASSERT_NE(name, nullptr);
  EXPECT_FALSE(name->toolTip().isEmpty());
  for (const char* a : {"recordSession", "stopRecording", "leaveReplay", "showSessionBrowser"}) {
    auto* action = w->findChild<QAction*>(a);
    ASSERT_NE(action, nullptr) << a;
    EXPECT_FALSE(action->toolTip().isEmpty()) << a;
  }
  EXPECT_TRUE(w->findChild<QAction*>("recordSession")->isEnabled());
  EXPECT_FALSE(w->findChild<QAction*>("stopRecording")->isEnabled());
  // A scripted device with force output presses and lifts again and again
  // beside the mouse probe (its force commands are recorded).
  const auto& mesh = *w->workbench().organ().mesh;
  const Index v = mesh.vertex_count() / 2;
  const Vec3 above = mesh.positions[v] + 0.005 * mesh.normals[v].normalized();
  const Vec3 inside = mesh.positions[v] - 0.004 * mesh.normals[v].normalized();
  const auto trajectory = folder_ / "press.csv";
  {
    std::ofstream f(trajectory);
    f.precision(17);
    f << "t,x,y,z,buttons\n";
    for (int k = 0; k <= 4; ++k) {
      const Vec3& p = k % 2 == 0 ? above : inside;
      f << 0.4 * k << "," << p.x() << "," << p.y() << "," << p.z() << ",0\n";
    }
  }
  ASSERT_TRUE(w->add_device_probe("scripted", QString::fromStdString("loop=true;file=" + trajectory.string())))
      << w->error_text().toStdString();
  const std::size_t scripted_slot = w->workbench().selected_probe()->slot;

  const auto file = record(*w, "Ada Lovelace", 1500);
  ASSERT_FALSE(file.empty());
  EXPECT_EQ(file.parent_path(), folder_);
  EXPECT_TRUE(QFileInfo(QString::fromStdString(file.string())).fileName().startsWith("Ada-Lovelace_default-organ_"))
      << file;
  EXPECT_EQ(file.extension(), ".palpa");
  // The trainee field is remembered.
  EXPECT_EQ(QSettings().value("session/trainee").toString(), "Ada Lovelace");

  // The file, as record::SessionFile reads it.
  const auto f = record::SessionFile::open(file);
  const record::SessionHeader& h = f.header();
  EXPECT_EQ(h.info.trainee, "Ada Lovelace");
  EXPECT_EQ(h.status, record::SessionStatus::Finished);
  // What the writer dropped is what the file says it dropped (none on a quiet
  // machine; a CPU-starved writer may drop some, and the file then says so).
  EXPECT_GE(h.dropped, last_drops_);
  // Nothing was dropped before the recording (the idle queues were emptied):
  // every drop the loop made is one the file counts.
  EXPECT_LE(w->workbench().statistics().record_drops, h.dropped);
  EXPECT_GE(h.ticks, 1500u);
  // It starts from the snapshot of the running loop: its first tick is that snapshot's.
  const auto snaps = f.snapshots();
  ASSERT_FALSE(snaps.empty());
  const std::uint64_t first = snaps.front().tick;
  EXPECT_GT(first, 0u) << "the loop ran before the recording";
  const record::TickSpan span = f.ticks(first, first + h.ticks);
  ASSERT_EQ(span.ticks.size(), h.ticks);
  for (std::size_t k = 0; k < span.ticks.size(); ++k) ASSERT_EQ(span.ticks[k].tick, first + k);
  EXPECT_TRUE(f.ticks(0, first).ticks.empty());
  // The scripted probe pressed during the recording: its commands pushed back.
  double largest = 0;
  bool held_late = false;  // ThreadSanitizer slows the loop: the watchdog then holds the force at zero
  const std::uint32_t late = haptics::kSafetyLoopLate | haptics::kSafetyModelLate;
  for (const auto& t : span.ticks) {
    largest = std::max(largest, haptics::to_vec(t.force_device[scripted_slot]).norm());
    held_late = held_late || (t.flags[scripted_slot] & late) != 0;
  }
  EXPECT_TRUE(largest > 0.005 || (kSlowBuild && held_late)) << "largest force " << largest << " N";

  // The file alone re-simulates the recorded forces bit for bit.
  const LoadedSession s = load_session(file.string());
  EXPECT_EQ(s.first_tick, first);
  ForceCheck check;
  replay_session(s, 0, ~std::uint64_t{0}, nullptr, check);
  EXPECT_EQ(check.ticks, h.ticks);
  EXPECT_TRUE(check.identical) << describe(check);
}

TEST_F(SessionsGuiTest, TheBrowserListsSessionsWithTheirTraineeAndDamagedFilesWithTheirError) {
  auto w = open_window();
  const auto file = record(*w, "Grace Hopper", 300);
  // A damaged file beside it: garbage bytes.
  const auto broken = folder_ / "broken.palpa";
  std::string garbage(8192, '\0');
  std::mt19937 rng(11);
  for (char& c : garbage) c = static_cast<char>(rng() & 0xff);
  { std::ofstream(broken, std::ios::binary) << garbage; }

  SessionBrowser* b = w->session_browser();
  b->refresh();
  ASSERT_EQ(b->count(), 2);
  const int good = b->row_of(QString::fromStdString(file.string()));
  const int bad = b->row_of(QString::fromStdString(broken.string()));
  ASSERT_GE(good, 0);
  ASSERT_GE(bad, 0);
  const SessionEntry& g = b->entry(good);
  EXPECT_TRUE(g.error.isEmpty()) << g.error.toStdString();
  EXPECT_EQ(g.trainee, "Grace Hopper");
  const auto hd = record::SessionFile::open(file).header();
  EXPECT_EQ(g.status.toStdString(),
            hd.dropped == 0 ? std::string("finished") : "finished, " + std::to_string(hd.dropped) + " records dropped");
  EXPECT_TRUE(g.scenario.isEmpty());
  EXPECT_EQ(g.score_state, SessionEntry::Score::None) << "no scenario: nothing to score against";
  const auto h = record::SessionFile::open(file).header();
  EXPECT_DOUBLE_EQ(g.duration, static_cast<double>(h.ticks) / h.config.rate_hz);
  EXPECT_EQ(g.date.toStdString(), h.created_utc);
  const SessionEntry& x = b->entry(bad);
  EXPECT_TRUE(x.error.contains("broken.palpa")) << x.error.toStdString();
  EXPECT_TRUE(x.error.contains("not a Palpa session")) << x.error.toStdString();
  EXPECT_TRUE(x.trainee.isEmpty());
  // Listed, shown with its error, and never touched.
  EXPECT_EQ(b->table()->rowCount(), 2);
  std::ifstream in(broken, std::ios::binary);
  const std::string after((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(after, garbage);
  // A damaged file does not replay; the window says why and stays live.
  EXPECT_FALSE(w->open_replay(QString::fromStdString(broken.string())));
  EXPECT_TRUE(w->error_text().contains("broken.palpa")) << w->error_text().toStdString();
  EXPECT_FALSE(w->in_replay());
  EXPECT_TRUE(w->workbench().loop()->running());
}

TEST_F(SessionsGuiTest, TheBrowserScoresAScenarioSessionAsTheAssessModuleDoes) {
  auto w = open_window();
  const auto scenario = palpa::test::project_data_dir() / "scenarios" / "breast_two_nodules.json";
  ASSERT_TRUE(w->open_file(QString::fromStdString(scenario.string()))) << w->error_text().toStdString();
  const auto file = record(*w, "Lise Meitner", 500);
  SessionBrowser* b = w->session_browser();
  b->refresh();
  const int row = b->row_of(QString::fromStdString(file.string()));
  ASSERT_GE(row, 0);
  EXPECT_EQ(b->entry(row).scenario, "breast_two_nodules.json");
  EXPECT_TRUE(QFileInfo(QString::fromStdString(file.string())).fileName().startsWith("Lise-Meitner_breast_two_nodules_"));
  ASSERT_TRUE(wait_until([&] { return b->scores_idle(); }, 120000));
  const SessionEntry& e = b->entry(b->row_of(QString::fromStdString(file.string())));
  ASSERT_EQ(e.score_state, SessionEntry::Score::Done) << e.score_error.toStdString();
  const assess::Report expected = assess_session(load_session(file.string()));
  EXPECT_DOUBLE_EQ(e.score, expected.score);
  EXPECT_EQ(e.passed, expected.passed);

  // Assessment shows the report: the verdict and every lesion in the text,
  // the coverage map and the force plot as images the view can load; Save
  // writes what palpa-assess writes for the same file, byte for byte.
  AssessmentDialog* d = b->show_assessment(b->row_of(QString::fromStdString(file.string())));
  ASSERT_NE(d, nullptr);
  EXPECT_TRUE(d->isVisible());
  EXPECT_EQ(b->show_assessment(b->row_of(QString::fromStdString(file.string()))), d) << "one window per session";
  const QString text = d->view()->toPlainText();
  EXPECT_TRUE(text.contains(QString::fromStdString(expected.verdict))) << text.toStdString();
  for (const auto& l : expected.lesions) EXPECT_TRUE(text.contains(QString::fromStdString(l.name))) << l.name;
  std::vector<QSize> images;
  for (QTextBlock block = d->view()->document()->begin(); block.isValid(); block = block.next())
    for (auto it = block.begin(); !it.atEnd(); ++it)
      if (it.fragment().charFormat().isImageFormat()) {
        const QTextImageFormat f = it.fragment().charFormat().toImageFormat();
        const QImage image = d->view()->loadResource(QTextDocument::ImageResource, QUrl(f.name())).value<QImage>();
        images.push_back(image.size());
      }
  ASSERT_EQ(images.size(), 2u) << "the coverage map and the force plot";
  EXPECT_EQ(images[0], QSize(480, 480)) << "the coverage map";
  EXPECT_EQ(images[1], QSize(860, 280)) << "the force plot";
  const auto html = folder_ / "report.html", json = folder_ / "report.json";
  const auto cli_html = folder_ / "cli.html", cli_json = folder_ / "cli.json";
  QString error;
  ASSERT_TRUE(d->save_html(QString::fromStdString(html.string()), &error)) << error.toStdString();
  ASSERT_TRUE(d->save_json(QString::fromStdString(json.string()), &error)) << error.toStdString();
  const std::string command = std::string(PALPA_ASSESS) + " '" + file.string() + "' --html '" + cli_html.string() +
                              "' --json '" + cli_json.string() + "' > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const auto bytes = [](const std::filesystem::path& f) {
    std::ifstream in(f, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  EXPECT_FALSE(bytes(cli_html).empty());
  EXPECT_TRUE(bytes(html) == bytes(cli_html)) << "the saved page is not palpa-assess's";
  EXPECT_TRUE(bytes(json) == bytes(cli_json)) << "the saved numbers are not palpa-assess's";
  EXPECT_FALSE(d->save_html(QString::fromStdString((folder_ / "no_such_dir" / "r.html").string()), &error));
  EXPECT_TRUE(error.contains("no_such_dir")) << error.toStdString();
  EXPECT_EQ(b->show_assessment(-1), nullptr);
  d->close();
}

TEST_F(SessionsGuiTest, ReplaySeeksToATimeAndShowsTheRecordedTickAndSurface) {
  auto w = open_window();
  const auto file = record(*w, "Rosalind Franklin", 2200);
  const std::uint64_t live_ticks = w->workbench().loop()->ticks();
  ASSERT_TRUE(w->open_replay(QString::fromStdString(file.string()))) << w->error_text().toStdString();
  ASSERT_TRUE(w->in_replay());
  // The live loop is stopped: its devices do not drive the organ.
  EXPECT_FALSE(w->workbench().loop()->running());
  EXPECT_FALSE(w->findChild<QAction*>("recordSession")->isEnabled());
  ReplayPanel* panel = w->replay_panel();
  ASSERT_NE(panel->player(), nullptr);
  for (const char* name : {"replayPlay", "replaySpeed", "replaySlider", "replayLeave"})
    EXPECT_FALSE(panel->findChild<QWidget*>(name)->toolTip().isEmpty()) << name;

  // What the file says, read and re-simulated independently of the window.
  const LoadedSession s = load_session(file.string());
  const std::uint64_t first = s.first_tick;
  const double t0 = s.file.ticks(first, first + 1).ticks.front().time;
  const double rate = s.file.header().config.rate_hz;
  EXPECT_NEAR(panel->player()->duration(), static_cast<double>(s.file.header().ticks - 1) / rate, 1e-12);
  int pressed = 0;  // seeks that saw the probe held pressed
  auto expect_shows = [&](double seconds) {
    SCOPED_TRACE(seconds);
    ASSERT_TRUE(panel->seek(seconds)) << w->error_text().toStdString();
    const SessionPlayer& p = *panel->player();
    const std::uint64_t tick = first + static_cast<std::uint64_t>(std::llround(seconds * rate));
    EXPECT_EQ(p.tick(), tick);
    EXPECT_DOUBLE_EQ(p.time(), s.file.ticks(tick, tick + 1).ticks.front().time - t0);
    EXPECT_LE(p.last_start(), tick);
    // The slider stands at that time.
    EXPECT_EQ(panel->findChild<QSlider*>("replaySlider")->value(), static_cast<int>(std::lround(p.time() * 1000)));
    // The surface that tick saw, by session_job's re-simulation from the file.
    // Also how deep the probes pressed over the last 100 ticks, as recorded:
    // the least, over those ticks, of the deepest probe's penetration, m.
    std::vector<float> expected;
    ForceCheck check;
    double held_depth = std::numeric_limits<double>::infinity();
    replay_session(s, first, tick + 1,
                   [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> probes,
                       const deform::DeformableSurface& surface) {
                     if (t.tick + 100 > tick) {
                       double d = 0;
                       for (const auto& r : probes) d = std::max(d, r.depth);
                       held_depth = std::min(held_depth, d);
                     }
                     if (t.tick == tick) expected.assign(surface.stream().begin(), surface.stream().end());
                   },
                   check);
    EXPECT_TRUE(check.identical) << describe(check);
    const auto& mesh = *s.model->mesh;
    ASSERT_EQ(expected.size(), 4 * mesh.vertex_count());
    const render::SurfaceView* view = w->surface_view();
    ASSERT_NE(view, nullptr);
    double deepest = 0;
    std::size_t wrong = 0;
    for (Index i = 0; i < mesh.vertex_count(); ++i) {
      const double h = expected[4 * i + 3];
      deepest = std::max(deepest, std::abs(h));
      const Vec3 want = mesh.positions[i] + h * mesh.normals[i].normalized();
      if ((view->drawn_position(i) - want).norm() > 1e-9) ++wrong;
    }
    EXPECT_EQ(wrong, 0u);
    // A probe held at least 1 mm deep for the last 0.1 s dents the surface.
    // The file says how deep it was (the press follows the loop's ticks, but
    // this thread sets each depth when it gets to, so not to the tick).
    std::printf("at %.1f s the probes had pressed >= %.2f mm for 100 ticks; the deepest dent is %.3f mm\n", seconds,
                1e3 * held_depth, 1e3 * deepest);
    if (held_depth >= 1e-3) {
      EXPECT_GT(deepest, 1e-4) << "the probe pressed: the recorded surface is dented";
      ++pressed;
    }
  };
  expect_shows(1.5);
  expect_shows(0.7);   // back: restores the snapshot at or before, re-simulates forward
  expect_shows(1.9);   // ahead: on from where it is
  expect_shows(1.0);
  // The press reaches 6 mm 1.2 s into the recording by the loop's ticks, so
  // the later seeks saw it held (unless this thread was starved for most of
  // a second; under ThreadSanitizer the loop itself falls behind).
  if (!kSlowBuild) {
    EXPECT_GE(pressed, 1) << "no seek saw the probe pressed: the dent went unchecked";
  }

  // Play at 4x moves on; pause holds.
  panel->set_speed(4.0);
  EXPECT_DOUBLE_EQ(panel->speed(), 4.0);
  const std::uint64_t at = panel->player()->tick();
  panel->play();
  EXPECT_TRUE(panel->playing());
  EXPECT_TRUE(wait_until([&] { return panel->player()->tick() > at + 100 || panel->player()->at_end(); }));
  panel->pause();
  const std::uint64_t held = panel->player()->tick();
  QTest::qWait(200);
  EXPECT_EQ(panel->player()->tick(), held);

  // Back to live: the same loop runs on from where it stopped.
  w->leave_replay();
  EXPECT_FALSE(w->in_replay());
  EXPECT_TRUE(w->workbench().loop()->running());
  EXPECT_TRUE(wait_until([&] { return w->workbench().loop()->ticks() > live_ticks + 100; }));
  EXPECT_TRUE(w->findChild<QAction*>("recordSession")->isEnabled());
}

TEST_F(SessionsGuiTest, SessionFileNamesAreSafe) {
  const QDateTime t(QDate(2026, 3, 4), QTime(5, 6, 7), Qt::UTC);
  EXPECT_EQ(MainWindow::session_file_name("Ada Lovelace", "liver_tumour", t), "Ada-Lovelace_liver_tumour_20260304-050607Z.palpa");
  EXPECT_EQ(MainWindow::session_file_name("  ", "../x/y", t), "anonymous_x-y_20260304-050607Z.palpa");
}

}  // namespace
}  // namespace palpa::app
