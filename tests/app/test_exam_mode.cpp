// Issue 10 in the window under Xvfb (part of test_app_gui, whose main() is in
// test_main_window.cpp): Exam mode hides what gives a lesion away, its
// countdown runs on exam time the test passes and finishes the exam, marks
// are made (key M, the dialog), listed, deleted, recorded as Mark events,
// and Finish reveals the lesions and classifies the marks; the Diagnostics
// dock's sustained-misses warning fed figures directly; an idle window
// draws nothing; every control has a tooltip; the Open dialog's filters; the
// last scenario reopens; a unit change reloads the organ. No test depends on
// wall-clock speed: exam time and diagnostics figures are passed in, and
// conditions are waited for with generous timeouts.

#include "app/gui/diagnostics_panel.h"
#include "app/gui/exam_panel.h"
#include "app/gui/help.h"
#include "app/gui/main_window.h"
#include "common/test_support.h"
#include "gui_wait.h"
#include "mesh/generate.h"
#include "mesh/io.h"
#include "record/session_file.h"
#include "render/surface_view.h"
#include "scenario/scenario.h"

#include <QAbstractButton>
#include <QAbstractSpinBox>
#include <QAction>
#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QDialogButtonBox>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QLabel>
#include <QListWidget>
#include <QMenu>
#include <QMenuBar>
#include <QPushButton>
#include <QRegularExpression>
#include <QScrollBar>
#include <QSlider>
#include <QStatusBar>
#include <QTest>
#include <QToolBar>
#include <QVTKOpenGLNativeWidget.h>

#include <cstdlib>
#include <functional>

namespace palpa::app {
namespace {

class ExamModeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!qApp) GTEST_SKIP() << "no X display: these tests run under tests/app/xvfb_run.sh";
  }
  std::unique_ptr<MainWindow> open_window() {
    auto w = std::make_unique<MainWindow>();
    w->resize(1100, 820);
    w->show();
    EXPECT_TRUE(QTest::qWaitForWindowExposed(w.get()));
    QTest::qWait(100);
    return w;
  }
  static bool wait_until(const std::function<bool()>& done, int timeout_ms = 20000) {
    return gui_test::wait_until(done, timeout_ms);
  }
  static std::filesystem::path shipped(const std::string& name) {
    return palpa::test::project_data_dir() / "scenarios" / name;
  }
  // A copy of a shipped scenario changed by `edit` (the organ by its absolute path).
  static std::filesystem::path scenario_copy(const std::string& name, const std::filesystem::path& dir,
                                             const std::function<void(scenario::Scenario&)>& edit) {
    scenario::Scenario s = scenario::load_scenario(shipped(name));
    s.organ.path = s.organ.resolved.string();
    edit(s);
    std::filesystem::create_directories(dir);
    const auto file = dir / name;
    scenario::save_scenario(s, file);
    return file;
  }
  // Presses the selected mouse probe into the organ at the vertex nearest `near`.
  static void press_near(MainWindow& w, const Vec3& near, double depth) {
    const auto& mesh = *w.workbench().organ().mesh;
    Index v = 0;
    for (Index i = 0; i < mesh.vertex_count(); ++i)
      if ((mesh.positions[i] - near).norm() < (mesh.positions[v] - near).norm()) v = i;
    w.workbench().place(w.workbench().selected_id(), mesh.positions[v], mesh.normals[v], depth);
  }
  static QStringList visible_label_texts(QWidget* w) {
    QStringList texts;
    for (QLabel* l : w->findChildren<QLabel*>())
      if (l->isVisible()) texts << l->text();
    return texts;
  }
};

QString q(const std::filesystem::path& p) { return QString::fromStdString(p.string()); }

TEST_F(ExamModeTest, ExamModeNeedsAScenario) {
  auto w = open_window();
  EXPECT_EQ(w->mode(), WorkbenchMode::Explore);
  w->findChild<QAction*>("modeExam")->trigger();
  EXPECT_EQ(w->mode(), WorkbenchMode::Explore);
  EXPECT_TRUE(w->error_text().contains("needs a scenario")) << w->error_text().toStdString();
  EXPECT_EQ(w->findChild<QComboBox*>("modeBox")->currentText(), "Explore");
  // Author behaves as Explore for now.
  EXPECT_TRUE(w->set_mode(WorkbenchMode::Author));
  EXPECT_TRUE(w->findChild<QAction*>("showForceArrows")->isEnabled());
}

TEST_F(ExamModeTest, ExamModeHidesWhatGivesALesionAwayAndLeavingRestoresTheView) {
  auto w = open_window();
  const auto dir = palpa::test::temp_dir("exam_hides");
  // One lesion shown to everybody: an exam draws none the less.
  const auto file = scenario_copy("breast_two_nodules.json", dir, [](scenario::Scenario& s) {
    s.lesions[0].lesion.visibility = tissue::Visibility::Shown;
  });
  ASSERT_TRUE(w->open_file(q(file))) << w->error_text().toStdString();
  EXPECT_FALSE(w->findChild<QAction*>("revealLesions")->isChecked());
  const std::size_t drawn = w->lesions_drawn();
  EXPECT_GE(drawn, 1u);
  auto* arrows = w->findChild<QAction*>("showForceArrows");
  auto* reveal = w->findChild<QAction*>("revealLesions");
  auto* material = w->findChild<QDockWidget*>("materialDock");
  auto* readouts = w->findChild<QDockWidget*>("readoutsDock");
  arrows->setChecked(true);
  material->show();
  readouts->show();
  QList<WorkbenchMode> changes;
  QObject::connect(w.get(), &MainWindow::modeChanged, [&](WorkbenchMode m) { changes << m; });

  w->findChild<QAction*>("modeExam")->trigger();
  ASSERT_EQ(w->mode(), WorkbenchMode::Exam);
  EXPECT_EQ(changes, QList<WorkbenchMode>{WorkbenchMode::Exam});
  EXPECT_EQ(w->findChild<QComboBox*>("modeBox")->currentText(), "Exam");
  EXPECT_EQ(w->lesions_drawn(), 0u);
  EXPECT_FALSE(arrows->isEnabled());
  EXPECT_FALSE(arrows->isChecked());
  EXPECT_FALSE(reveal->isEnabled());
  EXPECT_FALSE(reveal->isChecked());
  EXPECT_FALSE(material->isVisible());
  EXPECT_FALSE(material->isEnabled());
  EXPECT_FALSE(material->toggleViewAction()->isEnabled());
  EXPECT_FALSE(readouts->isVisible());
  EXPECT_TRUE(w->findChild<QDockWidget*>("examDock")->isVisible());
  EXPECT_TRUE(w->findChild<PressureGauge*>("pressureGauge")->isVisible());
  QTest::qWait(100);
  for (const QString& text : visible_label_texts(w.get()))
    for (const char* leak : {"kPa", "N/m", "Young", "tiffness", "modulus"})
      EXPECT_FALSE(text.contains(leak)) << "a visible label gives the tissue away: " << text.toStdString();
  // Revealing is refused until Finish (a disabled action does not trigger).
  reveal->trigger();
  EXPECT_EQ(w->lesions_drawn(), 0u);

  // Back to Explore: the view as it was.
  w->findChild<QAction*>("modeExplore")->trigger();
  EXPECT_EQ(w->mode(), WorkbenchMode::Explore);
  EXPECT_TRUE(arrows->isEnabled());
  EXPECT_TRUE(arrows->isChecked());
  EXPECT_TRUE(reveal->isEnabled());
  EXPECT_FALSE(reveal->isChecked());
  EXPECT_TRUE(material->isVisible());
  EXPECT_TRUE(material->isEnabled());
  EXPECT_TRUE(readouts->isVisible());
  EXPECT_FALSE(w->findChild<QDockWidget*>("examDock")->isVisible());
  EXPECT_EQ(w->lesions_drawn(), drawn);
}

TEST_F(ExamModeTest, TheCountdownRunsOnExamTimeAndFinishesTheExam) {
  auto w = open_window();
  const auto dir = palpa::test::temp_dir("exam_countdown");
  const auto file = scenario_copy("breast_two_nodules.json", dir, [](scenario::Scenario& s) { s.task.time_limit = 120; });
  ASSERT_TRUE(w->open_scenario_as_trainee(q(file))) << w->error_text().toStdString();
  ExamPanel* panel = w->exam_panel();
  ASSERT_TRUE(panel->running());
  EXPECT_LE(panel->time_left(), 120.0);
  w->advance_exam_time(30);
  // The frames add the loop's own time too (a fraction of a second here).
  EXPECT_LE(panel->time_left(), 90.0);
  EXPECT_GT(panel->time_left(), 60.0);
  EXPECT_TRUE(panel->countdown_text().contains("left")) << panel->countdown_text().toStdString();
  EXPECT_FALSE(panel->finished());
  w->advance_exam_time(100);
  EXPECT_TRUE(panel->finished());
  EXPECT_EQ(panel->countdown_text(), "Finished");
  // Finish reveals: every lesion drawn, Reveal enabled again.
  EXPECT_EQ(w->lesions_drawn(), 2u);
  EXPECT_TRUE(w->findChild<QAction*>("revealLesions")->isEnabled());
  EXPECT_FALSE(w->findChild<QAction*>("markFinding")->isEnabled());
}

TEST_F(ExamModeTest, MarksAreMadeListedDeletedAndClassifiedAtFinish) {
  auto w = open_window();
  ASSERT_TRUE(w->open_scenario_as_trainee(q(shipped("breast_two_nodules.json")))) << w->error_text().toStdString();
  const auto& lesions = w->workbench().scenario()->lesions;
  ASSERT_EQ(lesions.size(), 2u);
  ExamPanel* panel = w->exam_panel();

  // Key M with the probe pressed over nodule A: the dialog asks size and consistency.
  press_near(*w, w->workbench().scenario()->scenario.lesions[0].surface_point, 0.004);
  ASSERT_TRUE(wait_until([&] {
    w->advance();
    return w->workbench().selected_probe()->output.in_contact;
  }));
  EXPECT_TRUE(wait_until([&] { return panel->gauge()->force() > 0; }));
  w->activateWindow();
  const bool active = QTest::qWaitForWindowActive(w.get(), 5000);
  if (active) QTest::keyClick(w->viewport(), Qt::Key_M);
  else w->findChild<QAction*>("markFinding")->trigger();  // no window manager focus: the same action
  MarkDialog* dialog = nullptr;
  ASSERT_TRUE(wait_until([&] { return (dialog = w->findChild<MarkDialog*>("markDialog")) && dialog->isVisible(); }))
      << "key M did not ask for the mark (window active: " << active << ")";
  dialog->size_box()->setValue(12.0);
  dialog->consistency_box()->setCurrentText("hard");
  QTest::mouseClick(dialog->findChild<QDialogButtonBox*>()->button(QDialogButtonBox::Ok), Qt::LeftButton);
  ASSERT_EQ(panel->marks().size(), 1u);
  EXPECT_NEAR(panel->marks()[0].diameter, 0.012, 1e-12);
  EXPECT_EQ(panel->marks()[0].consistency, "hard");
  EXPECT_EQ(w->findChild<QListWidget*>("examMarks")->count(), 1);

  // Marks by the testable path: one on nodule B's centre, one far away, one deleted.
  ASSERT_TRUE(w->add_mark(lesions[1].centre + Vec3(0.002, 0, 0), 0.010, "firm"));
  ASSERT_TRUE(w->add_mark(lesions[1].centre + Vec3(0, 0, 0.2), 0.010, "soft"));
  ASSERT_TRUE(w->add_mark(lesions[1].centre + Vec3(0, 0.3, 0), 0.010, "soft"));
  auto* list = w->findChild<QListWidget*>("examMarks");
  list->setCurrentRow(3);
  QTest::mouseClick(w->findChild<QPushButton*>("examDeleteMark"), Qt::LeftButton);
  ASSERT_EQ(panel->marks().size(), 3u);

  // PALPA_TEST_SCREENSHOTS=DIR keeps pictures of the exam for people.
  const char* shots = std::getenv("PALPA_TEST_SCREENSHOTS");
  if (shots && *shots) {
    w->advance();
    w->grab().save(QString(shots) + "/workbench_exam.png");
  }
  QTest::mouseClick(w->findChild<QPushButton*>("examFinish"), Qt::LeftButton);
  ASSERT_TRUE(panel->finished());
  if (shots && *shots) {
    w->advance();
    w->grab().save(QString(shots) + "/workbench_exam_finished.png");
  }
  const ExamResult& r = panel->result();
  ASSERT_EQ(r.marks.size(), 3u);
  // The mark made with key M at the contact point over nodule A is on it (a
  // mark counts from the surface point above a buried lesion, whatever its
  // depth); nodule B's mark is found, the far one is a false positive.
  EXPECT_EQ(r.marks[0].lesion, 0) << "a mark on the surface right above nodule A";
  EXPECT_EQ(r.marks[1].lesion, 1);
  EXPECT_NEAR(r.marks[1].distance, 0.002, 1e-9);
  EXPECT_NEAR(r.marks[1].size_error, 0.010 - lesion_diameter(lesions[1]), 1e-9);
  EXPECT_EQ(r.marks[2].lesion, -1);
  EXPECT_GE(r.false_positives, 1);
  EXPECT_EQ(r.found + r.missed, 2);
  EXPECT_TRUE(panel->result_text().contains("false positive"));
  EXPECT_EQ(w->lesions_drawn(), 2u);
  EXPECT_FALSE(w->add_mark(lesions[0].centre, 0.01, "firm")) << "no marks after Finish";
}

TEST_F(ExamModeTest, MarksAreRecordedAsMarkEvents) {
  auto w = open_window();
  const auto dir = palpa::test::temp_dir("exam_record");
  w->set_sessions_folder(q(dir));
  w->set_trainee("Exam Trainee");
  ASSERT_TRUE(w->open_scenario_as_trainee(q(shipped("breast_two_nodules.json")))) << w->error_text().toStdString();
  ASSERT_TRUE(wait_until([&] { return w->workbench().loop() != nullptr; }));
  ASSERT_TRUE(w->start_recording()) << w->error_text().toStdString();
  const Vec3 a(0.01, 0.02, 0.03), b(-0.01, 0.0, 0.04);
  ASSERT_TRUE(w->add_mark(a, 0.011, "firm"));
  ASSERT_TRUE(w->add_mark(b, 0.0, "soft"));
  const Vec3 c(0.0, -0.01, 0.02);
  ASSERT_TRUE(w->add_mark(c, 0.0, "hard"));
  w->remove_mark(2);  // the trainee deletes the third: an Unmark naming it
  const QString file = QString::fromStdString(w->workbench().recording_file().string());
  ASSERT_TRUE(w->stop_recording()) << w->error_text().toStdString();
  const auto f = record::SessionFile::open(file.toStdString());
  std::vector<record::EventRecord> marks, unmarks;
  for (const auto& e : f.events()) {
    if (e.kind == record::EventKind::Mark) marks.push_back(e);
    if (e.kind == record::EventKind::Unmark) unmarks.push_back(e);
  }
  ASSERT_EQ(marks.size(), 3u);
  ASSERT_EQ(unmarks.size(), 1u);
  EXPECT_EQ(haptics::to_vec(unmarks[0].point), c);
  EXPECT_STREQ(unmarks[0].text, "mark 3 deleted");
  EXPECT_GE(unmarks[0].tick, marks[2].tick);  // recorded after the mark it withdraws
  EXPECT_EQ(haptics::to_vec(marks[0].point), a);
  EXPECT_DOUBLE_EQ(marks[0].value, 0.011);
  EXPECT_STREQ(marks[0].text, "firm");
  EXPECT_EQ(haptics::to_vec(marks[1].point), b);
  EXPECT_STREQ(marks[1].text, "soft");
  EXPECT_EQ(w->exam_panel()->marks().size(), 2u);  // and kept in the window's exam
}

TEST_F(ExamModeTest, TheDiagnosticsWarnOnlyOnSustainedMisses) {
  auto w = open_window();
  EXPECT_FALSE(w->findChild<QDockWidget*>("diagnosticsDock")->isVisible()) << "hidden by default";
  DiagnosticsPanel* d = w->diagnostics();
  d->restart();
  auto* status = w->findChild<QLabel*>("diagnosticsWarning");
  // 1000 ticks a second; `misses` of them missed in each second.
  double t = 1000;
  std::uint64_t ticks = 0, missed = 0;
  const auto second = [&](std::uint64_t misses) {
    for (int half = 0; half < 2; ++half) {
      t += 0.5;
      ticks += 500;
      missed += misses / 2;
      d->feed({t, ticks, missed, 1000, 80, 60, 1});
    }
  };
  d->feed({t, ticks, missed, 1000, 80, 60, 1});
  second(40);  // 4 %: bad
  second(40);
  EXPECT_TRUE(d->warning().isEmpty()) << "two bad seconds are not sustained";
  second(4);   // 0.4 %: good, the count starts again
  second(40);
  second(40);
  EXPECT_TRUE(d->warning().isEmpty());
  second(40);  // the third bad second in a row
  EXPECT_FALSE(d->warning().isEmpty());
  EXPECT_TRUE(d->warning().contains("fewer probes")) << d->warning().toStdString();
  EXPECT_TRUE(status->isVisible());
  EXPECT_TRUE(status->text().contains("missing deadlines"));
  second(0);
  EXPECT_TRUE(d->warning().isEmpty());
  EXPECT_FALSE(status->isVisible());
  // The figures moved out of the Readouts dock.
  EXPECT_TRUE(w->findChild<QDockWidget*>("diagnosticsDock")->isAncestorOf(w->findChild<QLabel*>("tickP99Readout")));
}

TEST_F(ExamModeTest, TheDiagnosticsNameARunningMemoryMonitor) {
  auto w = open_window();
  DiagnosticsPanel* d = w->diagnostics();
  auto* row = w->findChild<QLabel*>("memoryMonitorReadout");
  ASSERT_NE(row, nullptr);
  // Three whole seconds in which 4 % of the ticks miss: the warning, worded
  // with the monitors known at that moment.
  const auto sustained_misses = [&] {
    d->restart();
    double t = 1000;
    std::uint64_t ticks = 0, missed = 0;
    d->feed({t, ticks, missed, 1000, 80, 60, 1});
    for (int half = 0; half < 2 * DiagnosticsPanel::kBadSeconds; ++half) {
      t += 0.5;
      ticks += 500;
      missed += 20;
      d->feed({t, ticks, missed, 1000, 80, 60, 1});
    }
    return d->warning();
  };
  d->set_memory_monitors({haptics::MemoryMonitor{0, "paddr", 500000}, haptics::MemoryMonitor{3, "vaddr", -1}});
  EXPECT_EQ(row->text(), "DAMON: kdamond.0, kdamond.3");
  EXPECT_TRUE(row->toolTip().contains("echo off > /sys/kernel/mm/damon/admin/kdamonds/3/state"))
      << row->toolTip().toStdString();
  const QString with = sustained_misses();
  EXPECT_TRUE(with.contains("missing deadlines")) << with.toStdString();
  EXPECT_TRUE(with.contains("DAMON is sampling")) << with.toStdString();
  d->set_memory_monitors({});
  EXPECT_EQ(row->text(), "none");
  const QString without = sustained_misses();
  EXPECT_TRUE(without.contains("missing deadlines")) << without.toStdString();
  EXPECT_FALSE(without.contains("DAMON")) << without.toStdString();
}

// The frame timer draws only on change (an idle window took 65-73% of a
// core redrawing the same picture).
TEST_F(ExamModeTest, AnIdleWindowDrawsNothingAndAChangeDraws) {
  auto w = open_window();
  // Let the organ come to rest, then the frame timer's ticks (driven here).
  for (int k = 0; k < 5; ++k) {
    w->advance();
    QTest::qWait(30);
  }
  ASSERT_FALSE(w->workbench().selected_probe() && w->workbench().selected_probe()->output.in_contact);
  // A few ticks may still take the last stream entries; then none draws.
  for (int k = 0; k < 20; ++k) {
    w->frame_tick();
    QTest::qWait(10);
  }
  const auto before = w->renders();
  for (int k = 0; k < 120; ++k) {
    w->frame_tick();
    QTest::qWait(5);
  }
  EXPECT_EQ(w->renders(), before) << "an idle window drew";
  // advance() always draws.
  w->advance();
  EXPECT_EQ(w->renders(), before + 1);
  // A press changes the surface: the ticks draw it.
  press_near(*w, w->workbench().organ().facts.bbox_max, 0.004);
  const auto pressed_at = w->renders();
  EXPECT_TRUE(wait_until([&] {
    w->frame_tick();
    return w->renders() > pressed_at + 2;
  }));
  // A standard view draws.
  const auto viewed_at = w->renders();
  w->findChild<QAction*>("viewAnterior")->trigger();
  EXPECT_GT(w->renders(), viewed_at);
}

TEST_F(ExamModeTest, EveryControlHasATooltip) {
  auto w = open_window();
  for (QDockWidget* d : w->findChildren<QDockWidget*>()) d->show();
  QTest::qWait(100);
  QStringList missing;
  const auto stripped = [](QString t) {
    t.remove(QRegularExpression("&(?!&)"));
    t.remove("...");
    return t.trimmed();
  };
  std::function<void(QMenu*, const QString&)> walk = [&](QMenu* m, const QString& path) {
    for (QAction* a : m->actions()) {
      if (a->isSeparator()) continue;
      const QString here = path + " > " + stripped(a->text());
      if (a->toolTip().isEmpty() || a->toolTip() == stripped(a->text())) missing << "action " + here;
      if (a->menu()) walk(a->menu(), here);
    }
  };
  for (QAction* top : w->menuBar()->actions())
    if (top->menu()) walk(top->menu(), stripped(top->text()));
  for (QToolBar* bar : w->findChildren<QToolBar*>())
    for (QAction* a : bar->actions())
      if (!a->isSeparator() && !qobject_cast<QWidget*>(bar->widgetForAction(a)))
        missing << "toolbar action " + stripped(a->text());
  for (QWidget* c : w->findChildren<QWidget*>()) {
    if (!c->isVisible() || c->objectName().startsWith("qt_") || qobject_cast<QScrollBar*>(c)) continue;
    const bool input = qobject_cast<QAbstractButton*>(c) || qobject_cast<QAbstractSpinBox*>(c) ||
                       qobject_cast<QComboBox*>(c) || qobject_cast<QAbstractSlider*>(c);
    if (!input || !c->toolTip().isEmpty()) continue;
    // A toolbar's button shows its action's tooltip.
    if (auto* b = qobject_cast<QAbstractButton*>(c); b && qobject_cast<QToolBar*>(b->parentWidget())) continue;
    missing << QString("%1 '%2' (%3)").arg(c->metaObject()->className(), c->objectName(),
                                            qobject_cast<QAbstractButton*>(c) ? qobject_cast<QAbstractButton*>(c)->text() : QString());
  }
  EXPECT_TRUE(missing.isEmpty()) << "without a tooltip:\n" << missing.join("\n").toStdString();
}

TEST_F(ExamModeTest, ShortcutsAreListedFromTheActions) {
  auto w = open_window();
  const QStringList rows = shortcut_rows(w.get());
  const auto has = [&](const QString& part) {
    return std::any_of(rows.begin(), rows.end(), [&](const QString& r) { return r.contains(part); });
  };
  EXPECT_TRUE(has("Mode > Mark a finding here\tM")) << rows.join("\n").toStdString();
  EXPECT_TRUE(has("View > Standard views > Anterior"));
  EXPECT_TRUE(has("Session > Record"));
  // Every action with a shortcut is listed once.
  int with_shortcut = 0;
  QSet<QAction*> seen;
  for (QAction* a : w->findChildren<QAction*>())
    if (!a->shortcut().isEmpty() && !seen.contains(a)) {
      seen.insert(a);
      ++with_shortcut;
    }
  EXPECT_EQ(rows.size(), with_shortcut);
  w->findChild<QAction*>("showShortcuts")->trigger();
  EXPECT_TRUE(wait_until([&] { return w->findChild<QDialog*>("shortcutsDialog") != nullptr; }));
  w->findChild<QDialog*>("shortcutsDialog")->close();
  w->findChild<QAction*>("userGuide")->trigger();
  EXPECT_TRUE(w->findChild<QDialog*>("userGuideDialog") != nullptr) << w->error_text().toStdString();
  EXPECT_TRUE(about_text().contains("VTK"));
}

TEST_F(ExamModeTest, TheOpenDialogListsEveryFormatTheLoaderReads) {
  const QString filter = MainWindow::open_dialog_filter();
  for (const char* suffix : {"json", "obj", "stl", "ply", "off", "vtk", "vtp", "trian"}) {
    EXPECT_TRUE(filter.contains(QString("*.%1").arg(suffix))) << suffix;
    EXPECT_TRUE(MainWindow::can_open(QString("organ.%1").arg(suffix))) << suffix;
  }
}

TEST_F(ExamModeTest, TheLastScenarioReopens) {
  {
    auto w = open_window();
    ASSERT_TRUE(w->open_file(q(shipped("liver_tumour.json")))) << w->error_text().toStdString();
    w->close();
  }
  auto w = open_window();
  EXPECT_FALSE(w->workbench().has_scenario());
  EXPECT_TRUE(w->last_scenario().endsWith("liver_tumour.json"));
  ASSERT_TRUE(w->reopen_last_scenario()) << w->error_text().toStdString();
  EXPECT_TRUE(w->workbench().has_scenario());
}

TEST_F(ExamModeTest, AUnitChangeReloadsTheOrganAndAFailureChangesNothing) {
  auto w = open_window();
  const auto dir = palpa::test::temp_dir("exam_unit");
  const auto path = dir / "sphere_mm.obj";
  // A sphere of radius 40 in the file's unit.
  mesh::save_mesh(mesh::make_sphere(600, 40.0), path);
  auto* unit = w->findChild<QComboBox*>("unitBox");
  unit->setCurrentText("mm");
  ASSERT_TRUE(w->open_mesh(q(path))) << w->error_text().toStdString();
  const auto extent = [&] {
    const auto& f = w->workbench().organ().facts;
    return (f.bbox_max - f.bbox_min).x();
  };
  EXPECT_NEAR(extent(), 0.080, 0.002);
  unit->setCurrentText("cm");
  EXPECT_NEAR(extent(), 0.80, 0.02) << "the organ is reloaded in cm";
  EXPECT_TRUE(w->error_text().isEmpty()) << w->error_text().toStdString();
  // The file goes away: the reload fails, the organ and the box stay.
  std::filesystem::remove(path);
  unit->setCurrentText("mm");
  EXPECT_NEAR(extent(), 0.80, 0.02);
  EXPECT_EQ(unit->currentText(), "cm");
  EXPECT_TRUE(w->error_text().contains("sphere_mm.obj")) << w->error_text().toStdString();
  unit->setCurrentText("auto");
}

}  // namespace
}  // namespace palpa::app
