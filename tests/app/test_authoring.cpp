// Authoring mode under Xvfb (part of test_app_gui, whose main() is in
// test_main_window.cpp): a lesion placed by a click on the organ, moved by a
// drag, undone and redone, the running scenario following every step; Save
// and the asterisk; the file read back equals the document; a bad edit is
// refused and changes nothing; the prompt before unsaved changes are lost
// (Save, Discard, Cancel); the panel's task, breathing, base tissue, pulse
// path and brush. The loop runs on its own threads: the tests wait for
// conditions with generous timeouts and never assert wall-time figures.

#include "app/gui/authoring_panel.h"
#include "app/gui/authoring_tools.h"
#include "app/gui/main_window.h"
#include "app/gui/scenario_document.h"
#include "common/test_support.h"
#include "gui_wait.h"
#include "render/surface_view.h"
#include "scenario/scenario.h"

#include <QAction>
#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QLabel>
#include <QMessageBox>
#include <QMouseEvent>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QTableWidget>
#include <QTest>
#include <QTimer>
#include <QToolButton>
#include <QUndoStack>
#include <QVTKOpenGLNativeWidget.h>
#include <vtkActor.h>
#include <vtkProperty.h>

#include <functional>
#include <optional>

namespace palpa::app {
namespace {

class AuthoringTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!qApp) GTEST_SKIP() << "no X display: these tests run under tests/app/xvfb_run.sh";
  }

  std::unique_ptr<MainWindow> open_window() {
    auto w = std::make_unique<MainWindow>();
    w->resize(1200, 860);
    w->show();
    EXPECT_TRUE(QTest::qWaitForWindowExposed(w.get()));
    QTest::qWait(200);
    return w;
  }

  // A window in authoring mode on a new scenario around the default organ.
  std::unique_ptr<MainWindow> authoring_window() {
    auto w = open_window();
    w->set_authoring(true);
    EXPECT_TRUE(w->new_scenario()) << w->error_text().toStdString();
    EXPECT_TRUE(w->document()->has_scenario());
    EXPECT_FALSE(w->document()->modified());
    QTest::qWait(100);
    return w;
  }

  static bool wait_until(const std::function<bool()>& done, int timeout_ms = 20000) {
    return gui_test::wait_until(done, timeout_ms);
  }

  // The rest point under viewport position `p` (logical pixels), if on the organ.
  static std::optional<Vec3> pick(MainWindow& w, QPoint p) {
    auto* vp = w.viewport();
    const double dpr = vp->devicePixelRatioF();
    auto hit = w.surface_view()->pick(w.renderer(), (p.x() + 0.5) * dpr, (vp->height() - p.y() - 0.5) * dpr);
    if (!hit) return std::nullopt;
    return hit->rest_point;
  }

  // A viewport position on the organ near the centre shifted by `offset`.
  static std::optional<QPoint> point_on_organ(MainWindow& w, QPoint offset = {}) {
    auto* vp = w.viewport();
    for (int r = 0; r < 200; r += 10)
      for (int dx : {0, r, -r})
        for (int dy : {0, r, -r}) {
          const QPoint p(vp->width() / 2 + offset.x() + dx, vp->height() / 2 + offset.y() + dy);
          if (pick(w, p)) return p;
        }
    return std::nullopt;
  }

  // The mesh's longest edge, m.
  static double longest_edge(const MainWindow& w, const Workbench& wb) {
    (void)w;
    const auto& mesh = *wb.organ().mesh;
    double e = 0;
    for (const auto& t : mesh.triangles)
      for (int k = 0; k < 3; ++k) e = std::max(e, (mesh.positions[t[k]] - mesh.positions[t[(k + 1) % 3]]).norm());
    return e;
  }

  static void drag(QWidget* vp, QPoint from, QPoint to, int steps) {
    QTest::mousePress(vp, Qt::LeftButton, Qt::NoModifier, from);
    for (int i = 1; i <= steps; ++i) {
      const QPoint p = from + (to - from) * i / steps;
      QMouseEvent move(QEvent::MouseMove, p, vp->mapToGlobal(p), Qt::NoButton, Qt::LeftButton, Qt::NoModifier);
      QApplication::sendEvent(vp, &move);
      QTest::qWait(10);
    }
    QTest::mouseRelease(vp, Qt::LeftButton, Qt::NoModifier, to);
  }

  static std::size_t running_lesions(MainWindow& w) {
    return w.workbench().scenario() ? w.workbench().scenario()->lesions.size() : 0;
  }
};

TEST_F(AuthoringTest, PlaceMoveUndoRedoSaveAndReadBack) {
  auto w = authoring_window();
  auto* doc = w->document();
  auto* vp = w->viewport();
  EXPECT_TRUE(w->authoring());
  EXPECT_TRUE(w->findChild<QAction*>("authorMode")->isChecked());
  EXPECT_TRUE(w->findChild<QDockWidget*>("authoringDock")->isVisible());
  EXPECT_TRUE(w->xray()) << "authoring draws the organ translucent";
  EXPECT_FALSE(w->surface_view()->actor()->GetProperty()->GetBackfaceCulling()) << "the x-ray view shows the far side";
  ASSERT_TRUE(w->workbench().has_scenario()) << "a new scenario runs at once";
  EXPECT_EQ(doc->scenario().organ.path, "default");
  EXPECT_FALSE(doc->scenario().base_tissue.empty());
  const double edge = longest_edge(*w, w->workbench());

  // Place: the tool, then a click on the organ.
  w->findChild<QToolButton*>("placeLesionTool")->click();
  ASSERT_EQ(w->authoring_tools()->tool(), AuthoringTool::PlaceLesion);
  w->findChild<QDoubleSpinBox*>("lesionDepth")->setValue(15);
  w->findChild<QDoubleSpinBox*>("lesionRadius")->setValue(7);
  const auto p = point_on_organ(*w);
  ASSERT_TRUE(p.has_value());
  const Vec3 at = *pick(*w, *p);
  const haptics::HapticLoop* loop_before = w->workbench().loop();
  ASSERT_NE(loop_before, nullptr);
  QTest::mouseClick(vp, Qt::LeftButton, Qt::NoModifier, *p);
  ASSERT_EQ(doc->scenario().lesions.size(), 1u) << w->error_text().toStdString();
  // An edit is a command to the running loop, not a restart: the same
  // loop goes on ticking.
  EXPECT_EQ(w->workbench().loop(), loop_before) << "placing a lesion restarted the simulation";
  const std::uint64_t ticks_after_edit = w->workbench().statistics().ticks;
  EXPECT_TRUE(wait_until([&] { return w->workbench().statistics().ticks > ticks_after_edit; }));
  const scenario::LesionSpec placed = doc->scenario().lesions[0];
  EXPECT_EQ(placed.lesion.name, "L1");
  EXPECT_TRUE(placed.from_surface);
  EXPECT_LT((placed.surface_point - at).norm(), edge);
  EXPECT_NEAR(placed.depth, 0.015, 1e-12);
  EXPECT_NEAR(placed.lesion.semi_axes.x(), 0.007, 1e-12);
  // The running scenario has it, below the picked point.
  ASSERT_EQ(running_lesions(*w), 1u);
  const tissue::Lesion running = w->workbench().scenario()->lesions[0];
  EXPECT_EQ(running.name, "L1");
  EXPECT_LT((running.centre - at).norm(), 0.015 + edge);
  EXPECT_GT((running.centre - at).norm(), 0.015 - edge);
  EXPECT_EQ(w->lesions_drawn(), 1u) << "authoring draws hidden lesions too";
  // The asterisk, the Undo menu's text.
  EXPECT_TRUE(doc->modified());
  EXPECT_TRUE(w->isWindowModified());
  EXPECT_TRUE(w->windowTitle().contains("[*]")) << w->windowTitle().toStdString();
  auto* undo = w->findChild<QAction*>("undo");
  auto* redo = w->findChild<QAction*>("redo");
  ASSERT_NE(undo, nullptr);
  ASSERT_NE(redo, nullptr);
  EXPECT_EQ(undo->text(), "&Undo Place lesion 'L1'");
  EXPECT_EQ(undo->shortcut(), QKeySequence(QKeySequence::Undo));
  EXPECT_TRUE(w->findChild<QAction*>("undoMaterialEdit")->shortcut().isEmpty());

  // Move: press on the lesion, drag over the surface, release.
  const auto q = point_on_organ(*w, QPoint(60, 30));
  ASSERT_TRUE(q.has_value());
  ASSERT_GT((*q - *p).manhattanLength(), 20);
  const Vec3 to = *pick(*w, *q);
  drag(vp, *p, *q, 10);
  ASSERT_EQ(doc->scenario().lesions.size(), 1u);
  const scenario::LesionSpec moved = doc->scenario().lesions[0];
  EXPECT_LT((moved.surface_point - to).norm(), edge) << "moved to where the drag ended";
  EXPECT_EQ(moved.depth, placed.depth) << "a move changes only the surface point";
  EXPECT_EQ(moved.lesion, placed.lesion);
  EXPECT_EQ(undo->text(), "&Undo Move lesion");
  EXPECT_EQ(doc->undo_stack()->count(), 2);
  EXPECT_LT((w->workbench().scenario()->lesions[0].centre - running.centre).norm() -
                (moved.surface_point - placed.surface_point).norm(),
            2 * edge);
  EXPECT_GT((w->workbench().scenario()->lesions[0].centre - running.centre).norm(), 0.0);

  // Undo: back where it was; redo: moved again; undo twice: no lesion.
  undo->trigger();
  EXPECT_EQ(doc->scenario().lesions[0], placed);
  EXPECT_EQ(w->workbench().scenario()->lesions[0], running);
  redo->trigger();
  EXPECT_EQ(doc->scenario().lesions[0], moved);
  undo->trigger();
  undo->trigger();
  EXPECT_TRUE(doc->scenario().lesions.empty());
  EXPECT_EQ(running_lesions(*w), 0u);
  EXPECT_FALSE(doc->modified()) << "back at the state it was made in";
  redo->trigger();
  redo->trigger();
  EXPECT_EQ(doc->scenario().lesions.size(), 1u);
  EXPECT_EQ(doc->scenario().lesions[0], moved);
  EXPECT_EQ(running_lesions(*w), 1u);
  // The loop runs on.
  const auto ticks = w->workbench().statistics().ticks;
  EXPECT_TRUE(wait_until([&] { return w->workbench().statistics().ticks > ticks; }));

  // Save: the asterisk goes; the file read back equals the document.
  const auto dir = palpa::test::temp_dir("authoring_save");
  const auto file = dir / "case.json";
  ASSERT_TRUE(w->save_document_as(QString::fromStdString(file.string()))) << w->error_text().toStdString();
  EXPECT_FALSE(doc->modified());
  EXPECT_FALSE(w->isWindowModified());
  EXPECT_FALSE(w->windowTitle().contains("[*]")) << w->windowTitle().toStdString();
  EXPECT_TRUE(w->windowTitle().contains("case.json")) << w->windowTitle().toStdString();
  scenario::Scenario read = scenario::load_scenario(file);
  scenario::Scenario mine = doc->scenario();
  read.file.clear();
  mine.file.clear();
  EXPECT_TRUE(read == mine) << scenario::to_json_text(read) << "\n---\n" << scenario::to_json_text(mine);
  EXPECT_LT((read.lesions.at(0).surface_point - moved.surface_point).norm(), 1e-9);
  EXPECT_FALSE(std::filesystem::exists(dir / "case.json.tmp"));
  // An edit after the save: the asterisk again; undo back to the saved state: clean.
  w->findChild<QDoubleSpinBox*>("forceLimit")->setValue(6.5);
  EXPECT_TRUE(w->isWindowModified());
  EXPECT_EQ(doc->scenario().task.force_limit, 6.5);
  undo->trigger();
  EXPECT_FALSE(w->isWindowModified());

  // Leaving authoring: the organ opaque, hidden lesions not drawn.
  w->set_authoring(false);
  EXPECT_FALSE(w->xray());
  EXPECT_TRUE(w->surface_view()->actor()->GetProperty()->GetBackfaceCulling()) << "opaque again: back faces skipped";
  EXPECT_EQ(w->lesions_drawn(), 0u);
  EXPECT_FALSE(w->findChild<QAction*>("authorMode")->isChecked());
  EXPECT_EQ(w->mode(), WorkbenchMode::Explore) << "authoring is the Author mode";
  // The Mode menu leads too: Author turns authoring on, Exam turns it off
  // (no x-ray, no lesion drawn, no authoring panel in front of a trainee).
  ASSERT_TRUE(w->set_mode(WorkbenchMode::Author));
  EXPECT_TRUE(w->authoring());
  EXPECT_TRUE(w->xray());
  EXPECT_EQ(w->lesions_drawn(), 1u);
  ASSERT_TRUE(w->set_mode(WorkbenchMode::Exam));
  EXPECT_FALSE(w->authoring());
  EXPECT_FALSE(w->xray());
  EXPECT_EQ(w->lesions_drawn(), 0u);
  EXPECT_FALSE(w->findChild<QDockWidget*>("authoringDock")->isVisible());
  w->findChild<QAction*>("authorMode")->trigger();  // Edit > Author scenario leaves the exam for Author mode
  EXPECT_EQ(w->mode(), WorkbenchMode::Author);
  EXPECT_TRUE(w->authoring());
  w->set_authoring(false);
  if (const char* shots = std::getenv("PALPA_TEST_SCREENSHOTS"); shots && *shots) {
    w->set_authoring(true);
    QTest::qWait(200);
    w->grab().save(QString(shots) + "/workbench_authoring.png");
  }
}

TEST_F(AuthoringTest, ABadEditIsRefusedAndChangesNothing) {
  auto w = authoring_window();
  auto* doc = w->document();
  w->findChild<QToolButton*>("placeLesionTool")->click();
  const auto p = point_on_organ(*w);
  ASSERT_TRUE(p.has_value());
  QTest::mouseClick(w->viewport(), Qt::LeftButton, Qt::NoModifier, *p);
  ASSERT_EQ(doc->scenario().lesions.size(), 1u);
  const scenario::Scenario before = doc->scenario();
  const auto running_before = w->workbench().scenario()->lesions;
  const int commands = doc->undo_stack()->count();

  // A negative radius typed into the table.
  auto* table = w->findChild<QTableWidget*>("lesionTable");
  ASSERT_NE(table, nullptr);
  ASSERT_EQ(table->rowCount(), 1);
  table->item(0, AuthoringPanel::Radius)->setText("-3");
  EXPECT_TRUE(w->error_text().contains("radius_mm")) << w->error_text().toStdString();
  EXPECT_TRUE(w->error_text().contains("-3")) << w->error_text().toStdString();
  EXPECT_TRUE(doc->scenario() == before);
  EXPECT_EQ(doc->undo_stack()->count(), commands);
  EXPECT_EQ(w->workbench().scenario()->lesions, running_before);
  EXPECT_EQ(table->item(0, AuthoringPanel::Radius)->text().toDouble(), before.lesions[0].lesion.semi_axes.x() * 1e3)
      << "the table shows the document again";
  // Not a number.
  table->item(0, AuthoringPanel::Ratio)->setText("stiff");
  EXPECT_TRUE(w->error_text().contains("not a number")) << w->error_text().toStdString();
  EXPECT_TRUE(doc->scenario() == before);
  // Through the document: a lesion at zero depth, a pulse of one point.
  EXPECT_FALSE(doc->edit("Edit lesion", [](scenario::Scenario& s) { s.lesions[0].depth = 0; }).isEmpty());
  EXPECT_TRUE(w->error_text().contains("/lesions/0/depth_mm")) << w->error_text().toStdString();
  EXPECT_FALSE(doc->edit("Add pulse path", [](scenario::Scenario& s) {
                     tissue::Pulse pulse;
                     pulse.path = {Vec3::Zero()};
                     s.pulses.push_back(pulse);
                   }).isEmpty());
  EXPECT_TRUE(doc->scenario() == before);
  EXPECT_EQ(doc->undo_stack()->count(), commands);
  EXPECT_EQ(w->workbench().scenario()->lesions, running_before);
  EXPECT_TRUE(w->workbench().scenario()->scenario.pulses.empty());
  // A good edit still goes through.
  table->item(0, AuthoringPanel::Ratio)->setText("6");
  EXPECT_EQ(doc->scenario().lesions[0].lesion.modulus_ratio, 6.0);
  EXPECT_EQ(w->workbench().scenario()->lesions[0].modulus_ratio, 6.0);
  EXPECT_EQ(doc->undo_stack()->count(), commands + 1);
}

TEST_F(AuthoringTest, ThePromptBeforeLosingChangesSavesDiscardsOrCancels) {
  const auto dir = palpa::test::temp_dir("authoring_prompt");
  const auto file = dir / "prompt.json";
  QStringList asked;
  auto edited_window = [&] {
    auto w = authoring_window();
    EXPECT_TRUE(w->save_document_as(QString::fromStdString(file.string())));
    EXPECT_TRUE(w->document()->edit("Edit task", [](scenario::Scenario& s) { s.task.time_limit = 123; }).isEmpty());
    EXPECT_TRUE(w->document()->modified());
    return w;
  };
  // Cancel: the window stays open, the changes with it.
  {
    auto w = edited_window();
    w->set_save_prompt([&](const QString& q) {
      asked << q;
      return QMessageBox::Cancel;
    });
    EXPECT_FALSE(w->close());
    EXPECT_TRUE(w->isVisible());
    EXPECT_TRUE(w->document()->modified());
    ASSERT_EQ(asked.size(), 1);
    EXPECT_TRUE(asked[0].contains("prompt.json") && asked[0].contains("closing the window")) << asked[0].toStdString();
    // Opening another organ is cancelled too.
    EXPECT_FALSE(w->open_file(QString::fromStdString((palpa::test::project_data_dir() / "breast.ply").string())));
    EXPECT_TRUE(w->workbench().has_scenario());
    EXPECT_EQ(scenario::load_scenario(file).task.time_limit, 300) << "nothing saved";
    // Discard: it closes, the file as it was.
    w->set_save_prompt([](const QString&) { return QMessageBox::Discard; });
    EXPECT_TRUE(w->close());
    EXPECT_EQ(scenario::load_scenario(file).task.time_limit, 300);
  }
  // Save: saved, then closed.
  {
    auto w = edited_window();
    w->set_save_prompt([](const QString&) { return QMessageBox::Save; });
    EXPECT_TRUE(w->close());
    EXPECT_EQ(scenario::load_scenario(file).task.time_limit, 123);
  }
  // The real question box, answered by a click (New scenario, Cancel).
  {
    auto w = edited_window();
    bool seen = false;
    QTimer::singleShot(300, [&] {
      auto* box = qobject_cast<QMessageBox*>(QApplication::activeModalWidget());
      if (!box) return;
      seen = box->objectName() == "saveChangesPrompt";
      box->button(QMessageBox::Cancel)->click();
    });
    EXPECT_FALSE(w->new_scenario());
    EXPECT_TRUE(seen);
    EXPECT_EQ(w->document()->scenario().task.time_limit, 123);
    w->set_save_prompt([](const QString&) { return QMessageBox::Discard; });
  }
}

TEST_F(AuthoringTest, ThePanelEditsTheTaskBreathingTissuePulseAndPaint) {
  auto w = authoring_window();
  auto* doc = w->document();
  auto* undo = w->findChild<QAction*>("undo");
  // Task.
  auto* text = w->findChild<QPlainTextEdit*>("taskInstructions");
  text->setPlainText("Find the two nodules.");
  w->authoring_panel()->commit_instructions();
  EXPECT_EQ(doc->scenario().task.instructions, "Find the two nodules.");
  EXPECT_EQ(w->workbench().scenario()->scenario.task.instructions, "Find the two nodules.");
  EXPECT_TRUE(w->task_text().contains("Find the two nodules.")) << w->task_text().toStdString();
  w->findChild<QDoubleSpinBox*>("timeLimit")->setValue(120);
  w->findChild<QDoubleSpinBox*>("passScore")->setValue(80);
  w->findChild<QDoubleSpinBox*>("positionTolerance")->setValue(12);
  w->findChild<QCheckBox*>("reportConsistency")->setChecked(false);
  const scenario::Task& t = doc->scenario().task;
  EXPECT_EQ(t.time_limit, 120);
  EXPECT_NEAR(t.scoring.pass_score, 0.8, 1e-12);
  EXPECT_NEAR(t.scoring.position_tolerance, 0.012, 1e-12);
  EXPECT_FALSE(t.report.consistency);
  EXPECT_EQ(undo->text(), "&Undo Edit task");
  // Breathing.
  w->findChild<QCheckBox*>("breathingOn")->setChecked(true);
  w->findChild<QDoubleSpinBox*>("breathingRate")->setValue(12);
  w->findChild<QDoubleSpinBox*>("breathingAmplitude")->setValue(6);
  EXPECT_TRUE(doc->scenario().breathing.enabled);
  EXPECT_EQ(doc->scenario().breathing.rate_bpm, 12);
  EXPECT_NEAR(doc->scenario().breathing.translation.norm(), 0.006, 1e-12);
  EXPECT_TRUE(w->workbench().field()->breathing.enabled);
  EXPECT_EQ(undo->text(), "&Undo Set breathing");
  w->findChild<QCheckBox*>("breathingOn")->setChecked(false);
  EXPECT_FALSE(w->workbench().field() && w->workbench().field()->breathing.enabled);
  // Base tissue: another preset.
  auto* base = w->findChild<QComboBox*>("authorBaseTissue");
  ASSERT_GT(base->count(), 1);
  const int other = base->currentIndex() == 0 ? 1 : 0;
  const std::string key = base->itemData(other).toString().toStdString();
  QTest::qWait(50);
  emit base->activated(other);
  const auto* preset = tissue::find_preset(key);
  ASSERT_NE(preset, nullptr);
  const auto& s = doc->scenario();
  const auto it = std::find_if(s.tissues.begin(), s.tissues.end(), [&](const auto& x) { return x.name == s.base_tissue; });
  ASSERT_NE(it, s.tissues.end());
  EXPECT_EQ(it->youngs_modulus, preset->tissue.youngs_modulus);
  EXPECT_EQ(w->workbench().material().tissue.youngs_modulus, preset->tissue.youngs_modulus);
  EXPECT_EQ(undo->text(), "&Undo Set base tissue");
  EXPECT_EQ(base->currentIndex(), other);

  // Pulse: two clicks, Enter.
  w->findChild<QToolButton*>("drawPulsePath")->click();
  ASSERT_EQ(w->authoring_tools()->tool(), AuthoringTool::DrawPulse);
  const auto a = point_on_organ(*w, QPoint(-40, 0));
  const auto b = point_on_organ(*w, QPoint(40, 0));
  ASSERT_TRUE(a && b);
  QTest::mouseClick(w->viewport(), Qt::LeftButton, Qt::NoModifier, *a);
  QTest::keyClick(w->viewport(), Qt::Key_Return);  // one point: refused
  EXPECT_TRUE(doc->scenario().pulses.empty());
  EXPECT_TRUE(w->error_text().contains("at least 2 points")) << w->error_text().toStdString();
  QTest::mouseClick(w->viewport(), Qt::LeftButton, Qt::NoModifier, *b);
  EXPECT_EQ(w->authoring_tools()->pulse_points().size(), 2u);
  w->findChild<QDoubleSpinBox*>("pulseRate")->setValue(80);
  QTest::keyClick(w->viewport(), Qt::Key_Return);
  ASSERT_EQ(doc->scenario().pulses.size(), 1u) << w->error_text().toStdString();
  EXPECT_EQ(doc->scenario().pulses[0].path.size(), 2u);
  EXPECT_EQ(doc->scenario().pulses[0].rate_bpm, 80);
  EXPECT_EQ(w->workbench().field()->pulse_count, 1u);
  EXPECT_EQ(undo->text(), "&Undo Add pulse path");
  EXPECT_TRUE(w->authoring_tools()->pulse_points().empty());
  // The saved path stays drawn: a dot at each end and along it, at most
  // 0.8 handle sizes apart.
  const double spacing = 0.8 * w->authoring_tools()->handle_size();
  EXPECT_EQ(w->authoring_tools()->pulse_path_dots(), 1u + static_cast<std::size_t>(std::ceil((doc->scenario().pulses[0].path[1] - doc->scenario().pulses[0].path[0]).norm() / spacing)));
  EXPECT_GE(w->authoring_tools()->pulse_path_dots(), 2u);

  // Paint: a click paints a sphere of the modulus scale; erase removes it.
  w->findChild<QToolButton*>("paintTool")->click();
  ASSERT_EQ(w->authoring_tools()->tool(), AuthoringTool::Paint);
  w->findChild<QDoubleSpinBox*>("brushScale")->setValue(3);
  QTest::mouseClick(w->viewport(), Qt::LeftButton, Qt::NoModifier, *a);
  ASSERT_EQ(doc->scenario().regions.size(), 1u) << w->error_text().toStdString();
  EXPECT_EQ(doc->scenario().regions[0].kind, tissue::RegionKind::Sphere);
  EXPECT_EQ(doc->scenario().regions[0].scale, 3);
  EXPECT_EQ(undo->text(), "&Undo Paint tissue");
  EXPECT_EQ(w->authoring_tools()->painted_drawn(), 1u) << "the painted sphere is drawn";
  if (const char* shots = std::getenv("PALPA_TEST_SCREENSHOTS"); shots && *shots) {
    QTest::qWait(200);
    w->grab().save(QString(shots) + "/workbench_authoring_pulse_paint.png");
  }
  w->findChild<QCheckBox*>("brushErase")->setChecked(true);
  QTest::mouseClick(w->viewport(), Qt::LeftButton, Qt::NoModifier, *a);
  EXPECT_TRUE(doc->scenario().regions.empty());
  EXPECT_EQ(w->authoring_tools()->painted_drawn(), 0u);
  EXPECT_EQ(undo->text(), "&Undo Erase painted tissue");

  // Every step undoes, down to the new scenario.
  while (doc->undo_stack()->canUndo()) undo->trigger();
  EXPECT_FALSE(doc->modified());
  EXPECT_TRUE(doc->scenario().pulses.empty());
  EXPECT_EQ(w->authoring_tools()->pulse_path_dots(), 0u) << "the undone path is no longer drawn";
  EXPECT_FALSE(doc->scenario().breathing.enabled);
  EXPECT_EQ(doc->scenario().task.time_limit, scenario::Task{}.time_limit);
}

TEST_F(AuthoringTest, OpeningAScenarioFileGivesACleanDocumentOfIt) {
  auto w = open_window();
  const auto file = palpa::test::project_data_dir() / "scenarios" / "breast_two_nodules.json";
  ASSERT_TRUE(w->open_file(QString::fromStdString(file.string()))) << w->error_text().toStdString();
  ASSERT_TRUE(w->document()->has_scenario());
  EXPECT_FALSE(w->document()->modified());
  EXPECT_EQ(w->document()->file(), file);
  EXPECT_EQ(w->document()->scenario().lesions.size(), 2u);
  EXPECT_EQ(w->lesions_drawn(), 0u) << "hidden lesions, not authoring";
  w->set_authoring(true);
  EXPECT_EQ(w->lesions_drawn(), 2u) << "the x-ray view draws hidden lesions";
  EXPECT_EQ(w->authoring_tools()->handle_count(), 2u);
  EXPECT_EQ(w->findChild<QTableWidget*>("lesionTable")->rowCount(), 2);
  // A bare organ: no document.
  w->open_default_organ();
  EXPECT_FALSE(w->document()->has_scenario());
  EXPECT_FALSE(w->findChild<QLabel*>("authorHint")->isHidden());
}

}  // namespace
}  // namespace palpa::app
