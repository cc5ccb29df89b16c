// File > Prepare organ... under Xvfb (part of test_app_gui, whose main() is
// in test_main_window.cpp): the default organ prepared on a worker thread
// while the loop runs on the old one, the progress rising, the loop on the
// new organ afterwards; Cancel right after the start changes nothing; a bad
// edge length is refused with a message; on a scenario the preparation is an
// undoable edit that saving records. The preparation runs on its own thread:
// the tests wait for conditions with generous timeouts and never assert
// wall-time figures. Each test has its own prep cache ($PALPA_PREP_CACHE).

#include "app/gui/main_window.h"
#include "app/gui/prep_action.h"
#include "app/gui/scenario_document.h"
#include "common/test_support.h"
#include "gui_wait.h"
#include "render/surface_view.h"
#include "scenario/scenario.h"

#include <QAction>
#include <QApplication>
#include <QProgressDialog>
#include <QPushButton>
#include <QStatusBar>
#include <QTest>
#include <QTimer>
#include <QUndoStack>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <iterator>
#include <vector>

namespace palpa::app {
namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class PrepActionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!qApp) GTEST_SKIP() << "no X display: these tests run under tests/app/xvfb_run.sh";
    cache_ = test::temp_dir("gui_prep_cache");
    ::setenv("PALPA_PREP_CACHE", cache_.c_str(), 1);
  }
  void TearDown() override {
    ::unsetenv("PALPA_PREP_CACHE");
    std::error_code ec;
    if (!cache_.empty()) std::filesystem::remove_all(cache_, ec);
  }

  std::unique_ptr<MainWindow> open_window() {
    auto w = std::make_unique<MainWindow>();
    w->resize(1100, 800);
    w->show();
    EXPECT_TRUE(QTest::qWaitForWindowExposed(w.get()));
    QTest::qWait(100);
    return w;
  }

  static bool wait_until(const std::function<bool()>& done, int timeout_ms = 300000) {
    return gui_test::wait_until(done, timeout_ms);
  }

  // A coarse, unfitted preparation: quick on the default organ.
  static scenario::PrepSpec coarse(double edge_m) {
    scenario::PrepSpec s;
    s.edge = edge_m;
    s.fit_rounds = 0;
    return s;
  }

  std::filesystem::path cache_;
};

TEST_F(PrepActionTest, PreparesTheDefaultOrganOnAWorkerThreadAndTheLoopRunsOnIt) {
  auto w = open_window();
  PrepAction* a = w->prep_action();
  ASSERT_NE(a, nullptr);
  QAction* menu_entry = w->findChild<QAction*>("prepareOrgan");
  ASSERT_NE(menu_entry, nullptr);
  EXPECT_FALSE(menu_entry->toolTip().isEmpty());

  const auto before = w->workbench().organ().mesh;
  ASSERT_NE(before, nullptr);
  std::vector<double> fractions;
  QString finished, failed;
  QObject::connect(a, &PrepAction::progress, [&](const QString&, double f) { fractions.push_back(f); });
  QObject::connect(a, &PrepAction::finished, [&](const QString& s) { finished = s; });
  QObject::connect(a, &PrepAction::failed, [&](const QString& s) { failed = s; });

  ASSERT_EQ(a->start(coarse(0.006)), QString());
  EXPECT_TRUE(a->running());
  ASSERT_NE(a->progress_dialog(), nullptr);
  EXPECT_TRUE(a->progress_dialog()->isVisible());
  // Meanwhile the window and the loop go on with the old organ.
  EXPECT_EQ(w->workbench().organ().mesh, before);
  const auto ticks_at_start = w->workbench().statistics().ticks;
  EXPECT_TRUE(wait_until([&] { return w->workbench().statistics().ticks > ticks_at_start || !a->running(); }));

  ASSERT_TRUE(wait_until([&] { return !finished.isEmpty() || !failed.isEmpty(); }));
  ASSERT_TRUE(failed.isEmpty()) << failed.toStdString();
  EXPECT_FALSE(a->running());
  EXPECT_EQ(a->progress_dialog(), nullptr);

  // The new organ: another mesh, closed, drawn and simulated.
  const auto after = w->workbench().organ().mesh;
  ASSERT_NE(after, before);
  EXPECT_NE(after->vertex_count(), before->vertex_count());
  EXPECT_TRUE(w->workbench().organ().facts.closed());
  EXPECT_EQ(w->surface_view()->mesh().vertex_count(), after->vertex_count());
  ASSERT_NE(w->workbench().loop(), nullptr);
  const auto ticks = w->workbench().statistics().ticks;
  EXPECT_TRUE(wait_until([&] { return w->workbench().statistics().ticks > ticks; }, 20000));
  w->advance();

  // The progress rose to the end.
  ASSERT_GE(fractions.size(), 4u);
  for (std::size_t i = 1; i < fractions.size(); ++i) EXPECT_GE(fractions[i], fractions[i - 1]) << i;
  EXPECT_LT(fractions.front(), 0.5);
  EXPECT_DOUBLE_EQ(fractions.back(), 1.0);

  // The report's summary in the status bar; the window remembers how the organ was prepared.
  EXPECT_TRUE(finished.contains("prepared: ")) << finished.toStdString();
  EXPECT_TRUE(finished.contains("Hausdorff")) << finished.toStdString();
  EXPECT_TRUE(w->statusBar()->currentMessage().contains("edge CV") ||
              w->statusBar()->currentMessage().contains("CV"))
      << w->statusBar()->currentMessage().toStdString();
  ASSERT_TRUE(w->organ_ref().prep.has_value());
  EXPECT_DOUBLE_EQ(w->organ_ref().prep->edge, 0.006);
  EXPECT_TRUE(w->error_text().isEmpty()) << w->error_text().toStdString();
}

TEST_F(PrepActionTest, CancelRightAfterTheStartChangesNothing) {
  auto w = open_window();
  PrepAction* a = w->prep_action();
  const auto before = w->workbench().organ().mesh;
  bool cancelled = false, finished = false;
  QObject::connect(a, &PrepAction::cancelled, [&] { cancelled = true; });
  QObject::connect(a, &PrepAction::finished, [&] { finished = true; });

  ASSERT_EQ(a->start(coarse(0.006)), QString());
  a->cancel();
  ASSERT_TRUE(wait_until([&] { return cancelled || finished || !a->running(); }));
  EXPECT_TRUE(cancelled);
  EXPECT_FALSE(finished);
  EXPECT_FALSE(a->running());
  EXPECT_EQ(w->workbench().organ().mesh, before);
  EXPECT_FALSE(w->organ_ref().prep.has_value());
  EXPECT_TRUE(w->statusBar()->currentMessage().contains("cancelled")) << w->statusBar()->currentMessage().toStdString();
  EXPECT_TRUE(a->last_message().contains("unchanged")) << a->last_message().toStdString();
  EXPECT_TRUE(w->error_text().isEmpty());

  // The Cancel button of the dialog does the same.
  cancelled = false;
  ASSERT_EQ(a->start(coarse(0.006)), QString());
  ASSERT_NE(a->progress_dialog(), nullptr);
  auto* button = a->progress_dialog()->findChild<QPushButton*>("prepCancel");
  ASSERT_NE(button, nullptr);
  EXPECT_FALSE(button->toolTip().isEmpty());
  button->click();
  ASSERT_TRUE(wait_until([&] { return !a->running(); }));
  EXPECT_TRUE(cancelled);
  EXPECT_EQ(w->workbench().organ().mesh, before);
}

TEST_F(PrepActionTest, ABadEdgeLengthIsRefusedWithAMessage) {
  auto w = open_window();
  PrepAction* a = w->prep_action();
  const auto before = w->workbench().organ().mesh;
  QString failed;
  QObject::connect(a, &PrepAction::failed, [&](const QString& s) { failed = s; });

  const QString error = a->start(coarse(-0.001));
  EXPECT_EQ(error, "Could not prepare the organ: the edge length must be from 0.1 to 100 mm, got -1 mm");
  EXPECT_EQ(failed, error);
  EXPECT_EQ(w->error_text(), error);
  EXPECT_FALSE(a->running());
  EXPECT_EQ(a->progress_dialog(), nullptr);

  EXPECT_EQ(a->start(coarse(0.5)), "Could not prepare the organ: the edge length must be from 0.1 to 100 mm, got 500 mm");
  scenario::PrepSpec none;  // neither an edge nor a probe radius
  EXPECT_EQ(a->start(none),
            "Could not prepare the organ: missing required key \"edge_mm\" (or \"probe_radius_mm\")");
  EXPECT_EQ(w->workbench().organ().mesh, before);
}

TEST_F(PrepActionTest, OnAScenarioItIsAnUndoableEditThatSavingRecords) {
  auto w = open_window();
  ASSERT_TRUE(w->new_scenario()) << w->error_text().toStdString();
  ScenarioDocument* doc = w->document();
  ASSERT_TRUE(doc->has_scenario());
  const auto before = w->workbench().organ().mesh;
  PrepAction* a = w->prep_action();
  QString finished, failed;
  QObject::connect(a, &PrepAction::finished, [&](const QString& s) { finished = s; });
  QObject::connect(a, &PrepAction::failed, [&](const QString& s) { failed = s; });

  ASSERT_EQ(a->start(coarse(0.008)), QString());
  ASSERT_TRUE(wait_until([&] { return !finished.isEmpty() || !failed.isEmpty(); }));
  ASSERT_TRUE(failed.isEmpty()) << failed.toStdString();

  // The document's scenario records the preparation; the running one uses it.
  ASSERT_TRUE(doc->scenario().organ.prep.has_value());
  EXPECT_DOUBLE_EQ(doc->scenario().organ.prep->edge, 0.008);
  EXPECT_TRUE(doc->modified());
  ASSERT_TRUE(w->workbench().has_scenario());
  const auto prepared = w->workbench().organ().mesh;
  EXPECT_NE(prepared->vertex_count(), before->vertex_count());
  EXPECT_EQ(w->surface_view()->mesh().vertex_count(), prepared->vertex_count());
  EXPECT_EQ(w->workbench().scenario()->materials->tissue_of.size(), prepared->vertex_count());

  // Saving writes the prep object.
  const auto dir = test::temp_dir("gui_prep_scenario");
  const auto file = dir / "prepared.json";
  ASSERT_TRUE(w->save_document_as(QString::fromStdString(file.string()))) << w->error_text().toStdString();
  EXPECT_NE(read_text(file).find("\"prep\": {\n      \"edge_mm\": 8,"), std::string::npos) << read_text(file);
  EXPECT_EQ(scenario::load_scenario(file).organ.prep, doc->scenario().organ.prep);

  // Undo: the organ as loaded again; redo: the prepared one (from the cache).
  doc->undo_stack()->undo();
  EXPECT_FALSE(doc->scenario().organ.prep.has_value());
  EXPECT_EQ(w->workbench().organ().mesh->vertex_count(), before->vertex_count());
  EXPECT_EQ(w->surface_view()->mesh().vertex_count(), before->vertex_count());
  doc->undo_stack()->redo();
  ASSERT_TRUE(doc->scenario().organ.prep.has_value());
  EXPECT_EQ(w->workbench().organ().mesh->vertex_count(), prepared->vertex_count());
  const auto ticks = w->workbench().statistics().ticks;
  EXPECT_TRUE(wait_until([&] { return w->workbench().statistics().ticks > ticks; }, 20000));
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

// Opening a saved scenario whose organ.prep is not in the cache prepares on
// a worker thread under a progress dialog: the window's event loop keeps
// running (a zero-interval timer fires meanwhile), Cancel changes nothing,
// and the next open (still uncached) resolves the prepared organ.
TEST_F(PrepActionTest, OpeningAnUncachedPreparedScenarioShowsProgressAndCanBeCancelled) {
  auto w = open_window();
  ASSERT_TRUE(w->new_scenario()) << w->error_text().toStdString();
  const QString error = w->document()->edit("Prepare", [](scenario::Scenario& s) { s.organ.prep = coarse(0.008); });
  ASSERT_TRUE(error.isEmpty()) << error.toStdString();
  const auto dir = test::temp_dir("gui_open_prepared");
  const QString file = QString::fromStdString((dir / "prepared.json").string());
  ASSERT_TRUE(w->save_document_as(file)) << w->error_text().toStdString();
  const std::size_t prepared_vertices = w->workbench().organ().mesh->vertex_count();
  w->open_default_organ();
  const auto before = w->workbench().organ().mesh;
  ASSERT_NE(before->vertex_count(), prepared_vertices);

  // Cancel as soon as the dialog exists: nothing changes.
  std::filesystem::remove_all(cache_);
  std::filesystem::create_directories(cache_);
  int polls = 0;
  bool saw_dialog = false;
  QTimer poll;
  poll.setInterval(0);
  QObject::connect(&poll, &QTimer::timeout, [&] {
    ++polls;
    if (auto* d = w->findChild<QProgressDialog*>("openPrepProgress")) {
      saw_dialog = true;
      if (auto* b = d->findChild<QPushButton*>()) b->click();  // its Cancel button
    }
  });
  poll.start();
  EXPECT_FALSE(w->open_scenario(file));
  poll.stop();
  EXPECT_TRUE(saw_dialog);
  EXPECT_GT(polls, 0) << "the window's event loop ran during the preparation";
  EXPECT_EQ(w->workbench().organ().mesh, before) << "cancelled: the organ is unchanged";
  EXPECT_FALSE(w->workbench().has_scenario());
  EXPECT_TRUE(w->statusBar()->currentMessage().contains("cancelled")) << w->statusBar()->currentMessage().toStdString();

  // Again, uncached, not cancelled: the prepared organ runs.
  std::filesystem::remove_all(cache_);
  std::filesystem::create_directories(cache_);
  polls = 0;
  saw_dialog = false;
  poll.disconnect();
  QObject::connect(&poll, &QTimer::timeout, [&] {
    ++polls;
    saw_dialog = saw_dialog || w->findChild<QProgressDialog*>("openPrepProgress") != nullptr;
  });
  poll.start();
  ASSERT_TRUE(w->open_scenario(file)) << w->error_text().toStdString();
  poll.stop();
  EXPECT_TRUE(saw_dialog);
  EXPECT_GT(polls, 0);
  ASSERT_TRUE(w->workbench().has_scenario());
  EXPECT_EQ(w->workbench().organ().mesh->vertex_count(), prepared_vertices);
  EXPECT_EQ(w->findChild<QProgressDialog*>("openPrepProgress"), nullptr) << "the dialog is gone";
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

}  // namespace
}  // namespace palpa::app
