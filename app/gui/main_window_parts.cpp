// The window's parts of issue 10, kept apart from main_window.cpp: the
// modes and the exam, drawing only on change, the main toolbar, the View
// and Help additions, the Diagnostics dock, tooltips, the organ's unit, the
// last scenario.

#include "app/gui/diagnostics_panel.h"
#include "app/gui/exam_panel.h"
#include "app/gui/help.h"
#include "app/gui/main_window.h"
#include "mesh/io.h"
#include "record/format.h"
#include "render/lesion_view.h"
#include "render/probe_view.h"
#include "render/scene.h"
#include "render/surface_view.h"

#include <QAction>
#include <QActionGroup>
#include <QComboBox>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QLabel>
#include <QMenu>
#include <QMenuBar>
#include <QMessageBox>
#include <QPushButton>
#include <QSettings>
#include <QStatusBar>
#include <QToolBar>

#include <QVTKOpenGLNativeWidget.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkProp.h>
#include <vtkPropCollection.h>
#include <vtkRenderWindow.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>

#include <algorithm>
#include <functional>
#include <map>

namespace palpa::app {
namespace {

QString stripped(QString text) {
  text.remove(QRegularExpression("&(?!&)"));
  text.remove("...");
  return text.trimmed();
}

// The action of the menu bar whose text (without '&') is `text`.
QAction* menu_action(QMenuBar* bar, const QString& text) {
  std::function<QAction*(QMenu*)> walk = [&](QMenu* m) -> QAction* {
    for (QAction* a : m->actions()) {
      if (a->menu()) {
        if (QAction* found = walk(a->menu())) return found;
      } else if (stripped(a->text()) == text) {
        return a;
      }
    }
    return nullptr;
  };
  for (QAction* top : bar->actions())
    if (top->menu())
      if (QAction* a = walk(top->menu())) return a;
  return nullptr;
}

QMenu* top_menu(QMenuBar* bar, const QString& title) {
  for (QAction* top : bar->actions())
    if (top->menu() && stripped(top->text()) == title) return top->menu();
  return nullptr;
}

// Tooltips of the controls main_window.cpp builds without one, by their
// text (actions) or object name (widgets).
const std::map<QString, QString>& action_tips() {
  static const std::map<QString, QString> tips = {
      {"Open default organ", "Open the bundled default organ"},
      {"Open recent", "Open one of the files opened lately"},
      {"Screenshot", "Save the viewport as a PNG picture"},
      {"Quit", "Close the window (a recording is stopped and saved first)"},
      {"Undo material edit (the scenario's tissues again)",
       "Undo the material edit: the scenario's tissue map (its tissues and regions) again"},
      {"Add probe", "Add a mouse probe and select it"},
      {"Remove probe", "Remove the selected probe"},
      {"Hold indentation after release", "Keep a mouse probe pressed in after the mouse button is released"},
      {"Add device probe", "Add a probe driven by a device plugin (scripted, spacemouse, falcon, igtl)"},
      {"Re-enable selected device", "Re-enable force output of the selected probe's device (clears a latched fault)"},
      {"Reset", "Surface back to rest, every probe lifted"},
      {"Organ", "Show or hide the Organ dock (mesh facts, file unit)"},
      {"Probes", "Show or hide the Probes dock"},
      {"Readouts", "Show or hide the Readouts dock (force, indentation, device state, force plot)"},
      {"Material", "Show or hide the Material dock (tissue, probe tip, shape function)"},
      {"Task", "Show or hide the Task dock (a scenario's instructions and limits)"},
      {"Replay", "Show or hide the replay timeline"},
      {"Session", "Show or hide the Session toolbar (Record, Stop, the trainee's name)"},
  };
  return tips;
}

const std::map<QString, QString>& widget_tips() {
  static const std::map<QString, QString> tips = {
      {"unitBox", "The unit of the organ file's coordinates (auto: the one of m, cm, mm that gives a 15 cm organ); "
                  "changing it reloads the organ opened from a file"},
      {"addProbe", "Add a mouse probe and select it"},
      {"removeProbe", "Remove the selected probe"},
      {"probeList", "The probes; select one to drive it with the mouse and read it out"},
  };
  return tips;
}

}  // namespace

void MainWindow::build_window_parts() {
  material_dock_ = findChild<QDockWidget*>("materialDock");
  readouts_dock_ = findChild<QDockWidget*>("readoutsDock");
  QMenuBar* bar = menuBar();
  QMenu* file = top_menu(bar, "File");
  QMenu* view = top_menu(bar, "View");

  // Diagnostics dock (hidden by default) and its status bar warning.
  diagnostics_ = new DiagnosticsPanel;
  diagnostics_dock_ = new QDockWidget("Diagnostics", this);
  diagnostics_dock_->setObjectName("diagnosticsDock");
  diagnostics_dock_->setWidget(diagnostics_);
  addDockWidget(Qt::RightDockWidgetArea, diagnostics_dock_);
  diagnostics_dock_->hide();
  diagnostics_warning_ = new QLabel;
  diagnostics_warning_->setObjectName("diagnosticsWarning");
  diagnostics_warning_->setStyleSheet("QLabel { color: #a05a00; font-weight: bold; }");
  diagnostics_warning_->setWordWrap(false);
  diagnostics_warning_->hide();
  statusBar()->addPermanentWidget(diagnostics_warning_);
  connect(diagnostics_, &DiagnosticsPanel::warningChanged, this, [this](const QString& text) {
    diagnostics_warning_->setText(text.isEmpty() ? QString() : "Warning: " + text);
    diagnostics_warning_->setToolTip(text + "\n(View > Docks > Diagnostics shows the figures)");
    diagnostics_warning_->setVisible(!text.isEmpty());
  });

  // Exam dock.
  exam_panel_ = new ExamPanel;
  exam_dock_ = new QDockWidget("Exam", this);
  exam_dock_->setObjectName("examDock");
  exam_dock_->setWidget(exam_panel_);
  addDockWidget(Qt::LeftDockWidgetArea, exam_dock_);
  exam_dock_->hide();
  connect(exam_panel_, &ExamPanel::mark_requested, this, [this] { request_mark(); });
  connect(exam_panel_, &ExamPanel::finish_requested, this, &MainWindow::finish_exam);
  connect(exam_panel_, &ExamPanel::mark_removed, this, [this](int index, const ExamMark& m) {
    // Names the withdrawn mark by its point, so palpa-assess drops that Mark
    // even when the recording began after some marks were made.
    record::EventRecord e = record::EventRecord::make(record::EventKind::Unmark, 0, 0,
                                                      QString("mark %1 deleted").arg(index + 1).toStdString());
    e.point = haptics::to_triple(m.point);
    e.value = m.diameter;
    workbench_.record_event(e);
  });

  // File > Open scenario as trainee.
  QAction* open = menu_action(bar, "Open");
  QAction* trainee = new QAction("Open scenario as &trainee...", this);
  trainee->setObjectName("openAsTrainee");
  trainee->setToolTip("Open a scenario in Exam mode: its lesions hidden, a countdown, your findings marked and "
                      "compared with the truth at Finish");
  connect(trainee, &QAction::triggered, this, [this] {
    const QString path = QFileDialog::getOpenFileName(this, "Open a scenario as trainee", QString(),
                                                      "Scenarios (*.json);;All files (*)");
    if (!path.isEmpty()) open_scenario_as_trainee(path);
  });
  if (file) {
    const QList<QAction*> list = file->actions();
    const int at = list.indexOf(open);
    file->insertAction(at >= 0 && at + 1 < list.size() ? list[at + 1] : nullptr, trainee);
  }
  if (open) open->setObjectName("openFile");

  // Mode menu (before View) and its actions.
  auto* mode_menu = new QMenu("&Mode", this);
  mode_menu->setToolTipsVisible(true);
  bar->insertMenu(view ? view->menuAction() : nullptr, mode_menu);
  auto* group = new QActionGroup(this);
  const struct {
    WorkbenchMode mode;
    const char* text;
    const char* shortcut;
    const char* tip;
  } modes[] = {
      {WorkbenchMode::Explore, "&Explore", "Ctrl+1", "The free workbench: every readout, the material panel, lesions as the scenario shows them"},
      {WorkbenchMode::Author, "&Author", "Ctrl+2", "Author a scenario: place and move lesions, paint tissue, draw pulses, set the task (the Authoring panel)"},
      {WorkbenchMode::Exam, "E&xam", "Ctrl+3", "Examine the scenario as a trainee: lesions hidden, no readout that gives one away, a countdown, marks compared with the truth at Finish"},
  };
  for (const auto& m : modes) {
    QAction* a = mode_menu->addAction(m.text);
    a->setObjectName(QString("mode") + mode_name(m.mode));
    a->setCheckable(true);
    a->setShortcut(QKeySequence(m.shortcut));
    a->setToolTip(m.tip);
    group->addAction(a);
    const WorkbenchMode mode = m.mode;
    connect(a, &QAction::triggered, this, [this, mode] { set_mode(mode); });
    mode_actions_[mode] = a;
  }
  mode_menu->addSeparator();
  mark_action_ = mode_menu->addAction("&Mark a finding here", this, [this] { request_mark(); });
  mark_action_->setObjectName("markFinding");
  mark_action_->setShortcut(QKeySequence(Qt::Key_M));
  mark_action_->setToolTip("Exam: mark a finding at the selected probe's contact point (key M, or a device's "
                           "first button) and give its size and consistency");
  finish_action_ = mode_menu->addAction("&Finish exam", this, &MainWindow::finish_exam);
  finish_action_->setObjectName("finishExam");
  finish_action_->setToolTip("End the exam: your marks against the truth, and the lesions revealed");
  addAction(mark_action_);  // the key works wherever the focus is in the window

  // View: camera, standard views, the orientation marker, the docks.
  if (view) {
    view->setToolTipsVisible(true);
    view->addSeparator();
    QAction* reset_cam = view->addAction("Reset &camera", this, &MainWindow::reset_camera);
    reset_cam->setObjectName("resetCamera");
    reset_cam->setShortcut(QKeySequence("Ctrl+0"));
    reset_cam->setToolTip("Frame the whole organ from the default direction");
    QMenu* standard = view->addMenu("&Standard views");
    standard->setToolTipsVisible(true);
    standard->menuAction()->setToolTip("Look at the organ from one side (organ frame read as RAS: x right, y "
                                       "anterior, z superior)");
    const struct {
      StandardView v;
      const char* shortcut;
    } views[] = {{StandardView::Anterior, "Ctrl+Shift+A"}, {StandardView::Posterior, "Ctrl+Shift+P"},
                 {StandardView::Left, "Ctrl+Shift+L"},     {StandardView::Right, "Ctrl+Shift+T"},
                 {StandardView::Superior, "Ctrl+Shift+U"}, {StandardView::Inferior, "Ctrl+Shift+I"}};
    for (const auto& v : views) {
      const StandardView sv = v.v;
      QAction* a = standard->addAction(standard_view_name(sv), this, [this, sv] { set_standard_view(sv); });
      a->setObjectName("view" + standard_view_name(sv));
      a->setShortcut(QKeySequence(v.shortcut));
      a->setToolTip(QString("Look at the organ from the %1 side").arg(standard_view_name(sv).toLower()));
    }
    orientation_marker_ = std::make_unique<OrientationMarker>();
    orientation_action_ = view->addAction("&Orientation marker");
    orientation_action_->setObjectName("orientationMarker");
    orientation_action_->setCheckable(true);
    orientation_action_->setShortcut(QKeySequence("Ctrl+Shift+O"));
    orientation_action_->setToolTip("Axes in the lower left corner that turn with the camera (R, A, S)");
    connect(orientation_action_, &QAction::toggled, this, [this](bool on) {
      orientation_marker_->set_enabled(viewport_->interactor(), on);
      draw();
    });
    view->addSeparator();
    QMenu* docks = view->addMenu("&Docks");
    docks->setToolTipsVisible(true);
    docks->menuAction()->setToolTip("Show or hide the docks around the viewport");
    for (QDockWidget* d : findChildren<QDockWidget*>()) {
      if (d == browser_dock_) continue;  // in the Session menu
      QAction* t = d->toggleViewAction();
      if (d == diagnostics_dock_) {
        t->setShortcut(QKeySequence("Ctrl+Shift+D"));
        t->setToolTip("Show or hide the Diagnostics dock (haptic rate, tick p99, missed deadlines, frame rate)");
      } else if (d == exam_dock_) {
        t->setToolTip("Show or hide the Exam dock (countdown, pressure gauge, marks)");
      }
      docks->addAction(t);
    }
    docks->addAction(browser_dock_->toggleViewAction());
  }

  // Help.
  QMenu* help = bar->addMenu("&Help");
  help->setToolTipsVisible(true);
  QAction* keys = help->addAction("&Keyboard shortcuts", this, [this] { make_shortcuts_dialog(this)->show(); });
  keys->setObjectName("showShortcuts");
  keys->setShortcut(QKeySequence("Ctrl+F1"));
  keys->setToolTip("List every action that has a keyboard shortcut");
  QAction* guide = help->addAction("&User guide", this, [this] {
    QString error;
    if (QDialog* d = make_user_guide_dialog(this, &error)) d->show();
    else show_error(error);
  });
  guide->setObjectName("userGuide");
  guide->setShortcut(QKeySequence::HelpContents);
  guide->setToolTip("Open the user guide (docs/USER_GUIDE.md)");
  QAction* about = help->addAction("&About Palpa", this, [this] { QMessageBox::about(this, "About Palpa", about_text()); });
  about->setObjectName("aboutPalpa");
  about->setToolTip("Version, build and the libraries Palpa uses, with their licences");

  // The main toolbar: the most used actions and the mode.
  QToolBar* tools = new QToolBar("Main", this);
  tools->setObjectName("mainToolBar");
  addToolBar(Qt::TopToolBarArea, tools);
  if (QToolBar* session = findChild<QToolBar*>("sessionToolBar")) insertToolBar(session, tools);
  for (const char* text : {"Open", "Screenshot", "Add probe", "Reset"})
    if (QAction* a = menu_action(bar, text)) tools->addAction(a);
  tools->addAction(menu_action(bar, "Reset camera"));
  tools->addAction(record_action_);
  tools->addSeparator();
  tools->addWidget(new QLabel(" Mode "));
  mode_box_ = new QComboBox;
  mode_box_->setObjectName("modeBox");
  mode_box_->setToolTip("The workbench's mode: Explore, Author (scenario editing) or Exam (a trainee's exam)");
  for (WorkbenchMode m : {WorkbenchMode::Explore, WorkbenchMode::Author, WorkbenchMode::Exam})
    mode_box_->addItem(mode_name(m), static_cast<int>(m));
  connect(mode_box_, qOverload<int>(&QComboBox::activated), this,
          [this](int index) { set_mode(static_cast<WorkbenchMode>(mode_box_->itemData(index).toInt())); });
  tools->addWidget(mode_box_);
  tools->addAction(mark_action_);

  // During an exam nothing reveals the lesions before Finish (not even a
  // programmatic trigger of the disabled action).
  connect(reveal_action_, &QAction::toggled, this, [this](bool on) {
    if (!on || mode_ != WorkbenchMode::Exam || exam_panel_->finished()) return;
    {
      const QSignalBlocker block(reveal_action_);
      reveal_action_->setChecked(false);
    }
    rebuild_lesion_views();
  });

  // The organ's unit applies to the organ opened from a file.
  connect(unit_box_, qOverload<int>(&QComboBox::currentIndexChanged), this, [this] { reload_with_unit(); });

  // Tooltips of the controls built without one.
  for (QAction* a : findChildren<QAction*>()) {
    const auto it = action_tips().find(stripped(a->text()));
    if (it != action_tips().end() && (a->toolTip().isEmpty() || a->toolTip() == stripped(a->text())))
      a->setToolTip(it->second);
  }
  for (QWidget* w : findChildren<QWidget*>()) {
    const auto it = widget_tips().find(w->objectName());
    if (it != widget_tips().end() && w->toolTip().isEmpty()) w->setToolTip(it->second);
  }
  for (QMenu* m : bar->findChildren<QMenu*>()) m->setToolTipsVisible(true);
  sync_mode_controls();
}

// ---------------------------------------------------------------------------
// Drawing only on change: explicit marks (new stream entries, scene edits,
// hover, a breathing organ, a replayed tick) or a prop of the viewport
// whose redraw time moved (glyphs, lesions, arrows). The camera is not
// watched: drawing adjusts its clipping range itself, and the interactor
// draws its own turns and zooms.
namespace {
vtkMTimeType props_time(vtkRenderWindow* window) {
  vtkMTimeType t = 0;
  vtkRendererCollection* renderers = window->GetRenderers();
  vtkCollectionSimpleIterator rit;
  renderers->InitTraversal(rit);
  while (vtkRenderer* r = renderers->GetNextRenderer(rit)) {
    vtkPropCollection* props = r->GetViewProps();
    vtkCollectionSimpleIterator pit;
    props->InitTraversal(pit);
    while (vtkProp* p = props->GetNextProp(pit)) t = std::max(t, p->GetRedrawMTime());
  }
  return t;
}
}  // namespace

bool MainWindow::scene_changed() { return scene_dirty_ || props_time(viewport_->renderWindow()) > props_drawn_at_; }

void MainWindow::draw() {
  viewport_->renderWindow()->Render();
  ++renders_;
  scene_dirty_ = false;
  props_drawn_at_ = props_time(viewport_->renderWindow());
}

// ---------------------------------------------------------------------------
// Modes.
bool MainWindow::set_mode(WorkbenchMode mode) {
  if (mode == mode_) {
    sync_mode_controls();
    return true;
  }
  if (mode == WorkbenchMode::Exam && (!workbench_.has_scenario() || in_replay())) {
    show_error(in_replay() ? QString("Exam mode: leave the replay first (Session > Back to live)")
                           : QString("Exam mode needs a scenario: open one with File > Open scenario as trainee"));
    sync_mode_controls();
    return false;
  }
  const WorkbenchMode old = mode_;
  mode_ = mode;
  if (old == WorkbenchMode::Exam) leave_exam();
  if (mode == WorkbenchMode::Exam) enter_exam();
  if (author_action_) set_authoring(mode == WorkbenchMode::Author);  // the authoring panel, tools and x-ray view
  sync_mode_controls();
  statusBar()->showMessage(mode_name(mode) + " mode", 3000);
  emit modeChanged(mode);
  return true;
}

bool MainWindow::open_scenario_as_trainee(const QString& path) {
  if (!open_scenario(path)) return false;
  if (mode_ == WorkbenchMode::Exam) return true;  // the new scenario's exam started with it
  return set_mode(WorkbenchMode::Exam);
}

void MainWindow::sync_mode_controls() {
  if (auto it = mode_actions_.find(mode_); it != mode_actions_.end()) it->second->setChecked(true);
  if (mode_box_) {
    const QSignalBlocker block(mode_box_);
    mode_box_->setCurrentIndex(mode_box_->findData(static_cast<int>(mode_)));
  }
  const bool open = mode_ == WorkbenchMode::Exam && exam_panel_->running() && !exam_panel_->finished();
  mark_action_->setEnabled(open);
  finish_action_->setEnabled(open);
}

// What an exam hides; remembered to be restored.
void MainWindow::enter_exam() {
  before_exam_ = {force_arrows_action_->isChecked(), reveal_action_->isChecked(), material_dock_->isVisible(),
                  readouts_dock_->isVisible()};
  {
    const QSignalBlocker block(force_arrows_action_);  // not saved as the user's choice
    force_arrows_action_->setChecked(false);
  }
  force_arrows_action_->setEnabled(false);
  for (QDockWidget* d : {material_dock_, readouts_dock_}) {
    d->hide();
    d->setEnabled(false);
    d->toggleViewAction()->setEnabled(false);
  }
  undo_material_->setEnabled(false);
  exam_dock_->show();
  exam_dock_->raise();
  restart_exam();
}

void MainWindow::restart_exam() {
  const scenario::Resolved* sc = workbench_.scenario();
  if (!sc) return;
  {
    const QSignalBlocker block(reveal_action_);
    reveal_action_->setChecked(false);
  }
  reveal_action_->setEnabled(false);
  for (QDialog* d : findChildren<QDialog*>("markDialog")) d->close();
  exam_panel_->start(sc->scenario.task.time_limit, sc->scenario.task.force_limit);
  last_buttons_ = workbench_.selected_probe() ? workbench_.selected_probe()->output.buttons : 0;
  rebuild_lesion_views();
  sync_probe_views();
  sync_mode_controls();
}

void MainWindow::leave_exam() {
  exam_panel_->stop();
  exam_dock_->hide();
  for (QDialog* d : findChildren<QDialog*>("markDialog")) d->close();
  {
    const QSignalBlocker block(force_arrows_action_);
    force_arrows_action_->setChecked(before_exam_.arrows);
  }
  force_arrows_action_->setEnabled(true);
  {
    const QSignalBlocker block(reveal_action_);
    reveal_action_->setChecked(before_exam_.reveal);
  }
  reveal_action_->setEnabled(true);
  material_dock_->setEnabled(true);
  readouts_dock_->setEnabled(true);
  material_dock_->toggleViewAction()->setEnabled(true);
  readouts_dock_->toggleViewAction()->setEnabled(true);
  material_dock_->setVisible(before_exam_.material);
  readouts_dock_->setVisible(before_exam_.readouts);
  update_scenario_note();  // Edit > Undo material edit as before
  rebuild_lesion_views();
  if (workbench_.has_organ()) sync_probe_views();
}

// A new organ or scenario: a running exam starts again on the new scenario
// (or ends without one); the diagnostics start again; the last scenario is
// remembered.
void MainWindow::after_new_organ() {
  organ_path_.clear();
  scene_dirty_ = true;
  if (diagnostics_) diagnostics_->restart();
  if (const scenario::Resolved* sc = workbench_.scenario())
    QSettings().setValue("session/last_scenario",
                         QFileInfo(QString::fromStdString(sc->scenario.file.string())).absoluteFilePath());
  if (mode_ == WorkbenchMode::Exam) {
    if (workbench_.has_scenario()) restart_exam();
    else set_mode(WorkbenchMode::Explore);
  }
}

// ---------------------------------------------------------------------------
// The exam.
bool MainWindow::request_mark() {
  if (mode_ != WorkbenchMode::Exam || !exam_panel_->running() || exam_panel_->finished()) {
    statusBar()->showMessage("Marks are made during an exam (Mode > Exam)", 5000);
    return false;
  }
  const std::optional<Vec3> point = workbench_.finding_point(workbench_.selected_id());
  if (!point) {
    statusBar()->showMessage("Place the probe on the organ first: the mark goes where it touches", 5000);
    return false;
  }
  const scenario::ReportFields& report = workbench_.scenario()->scenario.task.report;
  if (!report.size && !report.consistency) return add_mark(*point, 0.0, QString());
  for (QDialog* d : findChildren<QDialog*>("markDialog")) d->close();
  auto* dialog = new MarkDialog(report.size, report.consistency, this);
  dialog->setAttribute(Qt::WA_DeleteOnClose);
  const Vec3 p = *point;
  connect(dialog, &QDialog::accepted, this, [this, dialog, p] { add_mark(p, dialog->diameter(), dialog->consistency()); });
  dialog->show();
  return true;
}

bool MainWindow::add_mark(const Vec3& point, double diameter, const QString& consistency) {
  if (mode_ != WorkbenchMode::Exam || !exam_panel_->running() || exam_panel_->finished()) return false;
  ExamMark m;
  m.point = point;
  m.diameter = std::max(0.0, diameter);
  m.consistency = consistency.toStdString();
  m.time = exam_panel_->elapsed();
  exam_panel_->add_mark(m);
  if (workbench_.recording()) {
    record::EventRecord e = record::EventRecord::make(record::EventKind::Mark, 0, 0, m.consistency);
    e.point = haptics::to_triple(point);
    e.value = m.diameter;
    if (const Probe* p = workbench_.selected_probe()) e.probe = static_cast<std::int32_t>(p->slot);
    if (!workbench_.record_event(e))
      show_error("The mark could not be written into the recording (its event queue is full); it is kept in the "
                 "Exam dock");
  }
  statusBar()->showMessage(QString("Mark %1 added").arg(exam_panel_->marks().size()), 3000);
  sync_mode_controls();
  return true;
}

void MainWindow::remove_mark(int index) { exam_panel_->remove_mark(index); }

void MainWindow::finish_exam() {
  if (mode_ != WorkbenchMode::Exam || !exam_panel_->running() || exam_panel_->finished()) return;
  const scenario::Resolved* sc = workbench_.scenario();
  if (!sc) return;
  for (QDialog* d : findChildren<QDialog*>("markDialog")) d->close();
  const double tolerance = sc->scenario.task.scoring.position_tolerance;
  const ExamResult result = score_exam(exam_panel_->marks(), sc->lesions, tolerance, sc->organ.mesh.get());
  exam_panel_->show_result(result, sc->lesions, tolerance);
  workbench_.record_event(record::EventRecord::make(
      record::EventKind::Note, 0, 0,
      QString("exam finished: %1 found, %2 false positive(s), %3 missed")
          .arg(result.found)
          .arg(result.false_positives)
          .arg(result.missed)
          .toStdString()));
  // The debriefing: every lesion and the force arrows.
  reveal_action_->setEnabled(true);
  reveal_action_->setChecked(true);
  rebuild_lesion_views();
  sync_probe_views();
  sync_mode_controls();
  statusBar()->showMessage(QString("Exam finished: %1 found, %2 false positive(s), %3 missed")
                               .arg(result.found)
                               .arg(result.false_positives)
                               .arg(result.missed));
}

void MainWindow::advance_exam_time(double seconds) {
  if (mode_ == WorkbenchMode::Exam) exam_panel_->elapse(seconds);
}

// Each exam frame: the gauge, and a device's first button marks.
void MainWindow::update_exam_frame() {
  const Probe* p = workbench_.selected_probe();
  exam_panel_->gauge()->set_force(p ? p->output.normal_force : 0.0);
  const std::uint32_t buttons = p && !p->host_fed ? p->output.buttons : 0;
  if ((buttons & 1u) && !(last_buttons_ & 1u)) request_mark();
  last_buttons_ = buttons;
}

// ---------------------------------------------------------------------------
// View, diagnostics, the organ's unit, the last scenario.
void MainWindow::reset_camera() {
  if (const render::SurfaceView* v = surface_view())
    render::frame_camera(renderer(), v->bounds(), Vec3(0.3, -1.0, 0.8), Vec3::UnitZ());
  draw();
}

void MainWindow::set_standard_view(StandardView view) {
  if (const render::SurfaceView* v = surface_view()) app::set_standard_view(renderer(), v->bounds(), view);
  draw();
}

QString MainWindow::diagnostics_warning() const { return diagnostics_->warning(); }

QString MainWindow::last_scenario() const { return QSettings().value("session/last_scenario").toString(); }

bool MainWindow::reopen_last_scenario() {
  const QString path = last_scenario();
  if (path.isEmpty()) return false;
  if (!QFileInfo::exists(path)) {
    QSettings().remove("session/last_scenario");
    statusBar()->showMessage(QString("The last scenario %1 is gone").arg(path), 8000);
    return false;
  }
  return open_scenario(path);
}

// A new unit for the organ opened from a file: reloaded with it; on failure
// nothing changes (the box goes back) and the error is shown. The default
// organ and a scenario's organ have their own unit: the box is for the
// next file then.
void MainWindow::reload_with_unit() {
  if (loading_settings_) return;
  save_settings();
  if (organ_path_.isEmpty()) {
    statusBar()->showMessage("The file unit applies to the next organ file opened", 5000);
    return;
  }
  const QString path = organ_path_;
  const int previous = unit_index_;
  const int wanted = unit_box_->currentIndex();
  try {
    mesh::Organ organ = mesh::load_organ(path.toStdString(), static_cast<mesh::MeshUnit>(wanted));
    install_organ(std::move(organ));
  } catch (const std::exception& e) {
    {
      const QSignalBlocker block(unit_box_);
      unit_box_->setCurrentIndex(previous);
    }
    save_settings();
    show_error(QString("Could not reload %1 in %2: %3")
                   .arg(QFileInfo(path).fileName(), unit_box_->itemText(wanted), QString::fromStdString(e.what())));
    return;
  }
  organ_path_ = path;
  unit_index_ = wanted;
  clear_error();
  statusBar()->showMessage(QString("Reloaded %1 in %2").arg(QFileInfo(path).fileName(), unit_box_->itemText(wanted)),
                           5000);
}

}  // namespace palpa::app
