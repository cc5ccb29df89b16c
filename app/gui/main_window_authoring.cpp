// The window's authoring mode (main_window.h, "Authoring"): the scenario
// document with its undo history in the Edit menu, New / Save / Save As in
// the File menu, the prompt before unsaved changes are lost, the authoring
// panel (a dock) and the tools on the 3D view, and the x-ray view.

#include "app/gui/authoring_panel.h"
#include "app/gui/authoring_tools.h"
#include "app/gui/main_window.h"
#include "app/gui/material_panel.h"
#include "app/gui/scenario_document.h"
#include "render/probe_view.h"
#include "render/surface_view.h"

#include <QAction>
#include <QComboBox>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QMenu>
#include <QMessageBox>
#include <QScrollArea>
#include <QScrollBar>
#include <QStatusBar>
#include <QUndoStack>
#include <QVTKOpenGLNativeWidget.h>

#include <vtkActor.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>

#include <cmath>

namespace palpa::app {

namespace {

constexpr double kXrayOpacity = 0.3;  // the organ in authoring's x-ray view

}  // namespace

void MainWindow::build_authoring_ui(QMenu* file, QAction* before, QMenu* edit) {
  document_ = new ScenarioDocument(this);
  document_->set_applier([this](const scenario::Scenario& s) { apply_document(s); });
  connect(document_, &ScenarioDocument::error, this, [this](const QString& text) { show_error(text); });
  connect(document_, &ScenarioDocument::modifiedChanged, this, [this] { update_document_title(); });

  // File: New scenario, Save, Save As (before Screenshot). Save and Save As
  // have no shortcut: Ctrl+S is the screenshot's, Ctrl+Shift+S Stop recording.
  QAction* new_scenario_action = new QAction("&New scenario", this);
  new_scenario_action->setObjectName("newScenario");
  new_scenario_action->setShortcut(QKeySequence::New);
  new_scenario_action->setToolTip("A new scenario around the organ shown (base tissue from the presets), to "
                                  "author in authoring mode");
  connect(new_scenario_action, &QAction::triggered, this, [this] {
    if (new_scenario() && !authoring_) set_authoring(true);
  });
  QAction* save = new QAction("Sa&ve scenario", this);
  save->setObjectName("saveScenario");
  save->setToolTip("Save the scenario to its file (atomically: the old file stays whole until the new one is)");
  save->setShortcut(QKeySequence::Save);
  connect(save, &QAction::triggered, this, [this] { save_document(); });
  QAction* save_as = new QAction("Save scenario &as...", this);
  save_as->setObjectName("saveScenarioAs");
  save_as->setShortcut(QKeySequence::SaveAs);
  save_as->setToolTip("Save the scenario to a new file (.json, docs/SCENARIO.md)");
  connect(save_as, &QAction::triggered, this, [this] {
    const QString path =
        QFileDialog::getSaveFileName(this, "Save the scenario as", QString(), "Scenarios (*.json);;All files (*)");
    if (!path.isEmpty()) save_document_as(path.endsWith(".json", Qt::CaseInsensitive) ? path : path + ".json");
  });
  file->insertAction(before, new_scenario_action);
  file->insertAction(before, save);
  file->insertAction(before, save_as);
  file->insertSeparator(before);
  auto sync_save = [this, save, save_as] {
    save->setEnabled(document_->has_scenario());
    save_as->setEnabled(document_->has_scenario());
  };
  connect(document_, &ScenarioDocument::changed, this, sync_save);
  sync_save();

  // Edit: the scenario's undo history (Ctrl+Z, Ctrl+Shift+Z); the material
  // panel's undo stays below it, without a shortcut.
  QAction* first = edit->actions().value(0);
  QAction* undo = document_->undo_stack()->createUndoAction(this, "&Undo");
  undo->setObjectName("undo");
  undo->setShortcut(QKeySequence::Undo);
  undo->setToolTip("Undo the last edit of the scenario");
  QAction* redo = document_->undo_stack()->createRedoAction(this, "&Redo");
  redo->setObjectName("redo");
  redo->setShortcuts({QKeySequence("Ctrl+Shift+Z"), QKeySequence("Ctrl+Y")});
  redo->setToolTip("Redo the edit undone last");
  edit->insertAction(first, undo);
  edit->insertAction(first, redo);
  edit->insertSeparator(first);

  // The mode, its panel (a dock) and its tools on the 3D view.
  author_action_ = new QAction("&Author scenario", this);
  author_action_->setObjectName("authorMode");
  author_action_->setCheckable(true);
  author_action_->setShortcut(QKeySequence("Ctrl+E"));
  author_action_->setToolTip("Authoring mode: place and move lesions, paint tissue, draw pulses, set the task; the "
                             "organ is drawn translucent with every lesion (hidden ones too)");
  connect(author_action_, &QAction::toggled, this, [this](bool on) { set_authoring(on); });
  edit->addSeparator();
  edit->addAction(author_action_);

  author_tools_ = new AuthoringTools(
      document_,
      [this](const QPoint& pos, Vec3& point, Vec3& normal) {
        Vec3 drawn;
        return pick_at(pos, point, normal, drawn);
      },
      [this](const Vec3& p) { return project_to_viewport(p); }, this);
  connect(author_tools_, &AuthoringTools::redraw, this, [this] { viewport_->renderWindow()->Render(); });
  author_panel_ = new AuthoringPanel(document_, author_tools_);
  author_panel_->setObjectName("authoringPanel");
  auto* scroll = new QScrollArea;
  scroll->setWidgetResizable(true);
  scroll->setFrameShape(QFrame::NoFrame);
  scroll->setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  scroll->setMinimumWidth(author_panel_->sizeHint().width() + scroll->verticalScrollBar()->sizeHint().width() + 8);
  scroll->setWidget(author_panel_);
  author_dock_ = new QDockWidget("Authoring", this);
  author_dock_->setObjectName("authoringDock");
  author_dock_->toggleViewAction()->setToolTip("Show the Authoring panel (lesions, tissue, task, breathing, pulses, "
                                               "brush); closing it leaves Author mode");
  author_dock_->setWidget(scroll);
  addDockWidget(Qt::LeftDockWidgetArea, author_dock_);
  author_dock_->hide();
  connect(author_dock_, &QDockWidget::visibilityChanged, this, [this](bool visible) {
    // Closing the dock leaves the mode (not while the window itself hides).
    if (!visible && authoring_ && isVisible() && !author_dock_->isVisible() && !isMinimized()) set_authoring(false);
  });
}

// ---------------------------------------------------------------------------
void MainWindow::set_authoring(bool on) {
  // Authoring is the Author mode: the mode leads (set_mode calls back here
  // once mode_ says Author, or no longer does).
  if (on != (mode_ == WorkbenchMode::Author)) {
    set_mode(on ? WorkbenchMode::Author : WorkbenchMode::Explore);
    if (author_action_->isChecked() != authoring_) {  // refused: the action shows what is
      const QSignalBlocker block(author_action_);
      author_action_->setChecked(authoring_);
    }
    return;
  }
  if (author_action_->isChecked() != on) {
    const QSignalBlocker block(author_action_);
    author_action_->setChecked(on);
  }
  if (on == authoring_) return;
  authoring_ = on;
  if (!on) author_tools_->set_tool(AuthoringTool::None);
  author_dock_->setVisible(on);
  if (on) author_dock_->raise();
  hover_view_->set_visible(false);
  sync_authoring_view();
  statusBar()->showMessage(on ? QString("Authoring: pick a tool in the Authoring panel; drag a lesion's handle to move "
                                        "it; Edit > Undo undoes an edit")
                              : QString("Authoring mode left"),
                           5000);
  emit authoringChanged(on);
}

bool MainWindow::xray() const {
  return view_ && view_->actor()->GetProperty()->GetOpacity() < 1.0;
}

void MainWindow::sync_face_culling() {
  // view_ draws the workbench's organ. The x-ray view shows the far side
  // through the near one.
  if (view_) view_->set_backface_culling(workbench_.organ().facts.closed_outward() && !xray());
  if (replay_view_) replay_view_->set_backface_culling(replay_view_closed_outward_);
}

// The x-ray view (authoring only): the organ translucent, every lesion
// drawn; the tools' handles over it.
void MainWindow::sync_authoring_view() {
  if (view_) view_->actor()->GetProperty()->SetOpacity(authoring_ ? kXrayOpacity : 1.0);
  sync_face_culling();
  rebuild_lesion_views();
  const auto& f = workbench_.organ().facts;
  const double diag = (f.bbox_max - f.bbox_min).norm();
  author_tools_->attach(authoring_ && !in_replay() ? inclusions_renderer() : nullptr, 0.02 * diag);
  apply_frame_transform();
  viewport_->renderWindow()->Render();
}

QPoint MainWindow::project_to_viewport(const Vec3& organ_point) const {
  Vec3 p = organ_point;
  if (const auto field = workbench_.field(); field && field->breathing.enabled) p = field->to_world(p, frame_time_);
  vtkRenderer* r = renderer();
  r->SetWorldPoint(p.x(), p.y(), p.z(), 1.0);
  r->WorldToDisplay();
  double d[3];
  r->GetDisplayPoint(d);
  const double dpr = viewport_->devicePixelRatioF();
  return QPoint(static_cast<int>(std::lround(d[0] / dpr - 0.5)),
                static_cast<int>(std::lround(viewport_->height() - d[1] / dpr - 0.5)));
}

// A new organ or scenario was installed from a file (or the bare organ):
// the document takes what runs now, clean.
void MainWindow::authoring_after_new_organ() {
  if (!document_) return;
  if (const scenario::Resolved* sc = workbench_.scenario()) {
    document_->reset(sc->scenario);
    if (sc->scenario.organ.path == "default") {
      organ_file_ = "default";
      organ_unit_ = "m";
    } else {
      organ_file_ = QString::fromStdString(sc->scenario.organ.resolved.string());
      organ_unit_ = QString::fromStdString(sc->scenario.organ.unit);
    }
  } else {
    document_->reset(std::nullopt);
  }
  author_tools_->cancel_pulse();
  sync_authoring_view();
  update_document_title();
}

// The document's applier: the edited scenario runs (apply_to_workbench),
// then the window shows it (lesions, task, title, panels).
void MainWindow::apply_document(const scenario::Scenario& s) {
  if (in_replay()) throw std::logic_error("leave the replay first (Session > Back to live)");
  const std::shared_ptr<const mesh::SurfaceMesh> before = workbench_.organ().mesh;
  apply_to_workbench(workbench_, s);
  // Another mesh (the organ's preparation changed, or undone): a new view of it.
  const auto& after = workbench_.organ().mesh;
  if (before && after && after != before &&
      (after->positions != before->positions || after->triangles != before->triangles))
    show_new_organ(std::make_unique<render::SurfaceView>(after), /*reset_document=*/false);
  clear_error();
  need_full_sync_ = true;
  pull_surface();
  show_task();
  sync_material_panel();
  refresh_probe_list();
  sync_session_actions();
  sync_authoring_view();
  update_document_title();
}

// "Palpa - <title> (<file>)", with "[*]" (shown as an asterisk) while the
// document has unsaved changes.
void MainWindow::update_document_title() {
  if (!document_ || !document_->has_scenario()) {
    setWindowModified(false);
    return;
  }
  const scenario::Scenario& s = document_->scenario();
  const std::filesystem::path file = document_->file();
  const QString name = QString::fromStdString(file.empty() ? std::string("not saved") : file.filename().string());
  QString title = QString::fromStdString(s.title.empty() ? (file.empty() ? std::string("new scenario") : file.stem().string())
                                                         : s.title);
  const bool modified = document_->modified();
  setWindowTitle(QString("Palpa - %1 (%2)").arg(title, name) + (modified ? "[*]" : ""));
  setWindowModified(modified);
}

// ---------------------------------------------------------------------------
bool MainWindow::new_scenario() {
  if (!confirm_discard("making a new scenario")) return false;
  if (!workbench_.has_organ()) {
    show_error("Could not make a scenario: no organ is open");
    return false;
  }
  if (in_replay()) leave_replay();
  scenario::Scenario s;
  const QString organ_name = QFileInfo(QString::fromStdString(workbench_.organ().name)).completeBaseName();
  s.title = QString("%1 scenario").arg(organ_name.isEmpty() ? QString("organ") : organ_name).toStdString();
  s.organ.path = organ_file_.toStdString();
  s.organ.resolved = organ_file_ == "default" ? mesh::default_organ_path() : std::filesystem::path(s.organ.path);
  s.organ.unit = organ_unit_.toStdString();
  s.organ.prep = organ_prep_;  // a prepared bare organ: the scenario prepares it the same way
  // The base tissue: the material panel's preset when it shows one, else liver (or the first preset).
  std::string key = material_panel_->preset_key();
  try {
    if (key.empty() || !tissue::find_preset(key)) key = tissue::find_preset("liver") ? "liver" : tissue::presets().at(0).key;
    s.base_tissue = ensure_preset_tissue(s, key);
  } catch (const std::exception& e) {
    show_error(QString("Could not make a scenario: no tissue presets (%1)").arg(e.what()));
    return false;
  }
  s.task.instructions = "Palpate the organ and report every lump you find: where it is, its size and how firm it is.";
  const QString error = document_->start_new(s);
  if (!error.isEmpty()) return false;  // shown by the document
  statusBar()->showMessage("A new scenario around " + QString::fromStdString(workbench_.organ().name) +
                               ": place lesions with the Authoring panel's tools, then File > Save scenario as",
                           8000);
  return true;
}

bool MainWindow::save_document() {
  if (!document_->has_scenario()) return false;
  if (document_->file().empty()) {
    const QString path =
        QFileDialog::getSaveFileName(this, "Save the scenario as", QString(), "Scenarios (*.json);;All files (*)");
    if (path.isEmpty()) return false;
    return save_document_as(path.endsWith(".json", Qt::CaseInsensitive) ? path : path + ".json");
  }
  return save_document_as(QString::fromStdString(document_->file().string()));
}

bool MainWindow::save_document_as(const QString& path) {
  if (!document_->has_scenario()) return false;
  if (!document_->save_as(path.toStdString()).isEmpty()) return false;  // shown by the document
  clear_error();
  add_recent(QFileInfo(path).absoluteFilePath());
  show_task();
  update_document_title();
  statusBar()->showMessage("Saved the scenario " + path, 5000);
  return true;
}

bool MainWindow::confirm_discard(const QString& doing) {
  if (!document_ || !document_->modified()) return true;
  const QString name = document_->file().empty() ? QString("The new scenario")
                                                  : QString("The scenario %1").arg(QString::fromStdString(
                                                        document_->file().filename().string()));
  const QString question = QString("%1 has unsaved changes. Save them before %2?").arg(name, doing);
  QMessageBox::StandardButton answer;
  if (save_prompt_) {
    answer = save_prompt_(question);
  } else {
    QMessageBox box(QMessageBox::Warning, "Unsaved changes", question,
                    QMessageBox::Save | QMessageBox::Discard | QMessageBox::Cancel, this);
    box.setObjectName("saveChangesPrompt");
    box.setDefaultButton(QMessageBox::Save);
    answer = static_cast<QMessageBox::StandardButton>(box.exec());
  }
  switch (answer) {
    case QMessageBox::Save: return save_document();
    case QMessageBox::Discard:
      document_->reset(document_->has_scenario() ? std::optional(document_->scenario()) : std::nullopt);
      return true;
    default: return false;
  }
}

}  // namespace palpa::app
