// The workbench window.

#include "app/gui/main_window.h"
#include "app/gui/prep_action.h"

#include "app/gui/authoring_tools.h"
#include "app/gui/device_dialog.h"
#include "app/gui/diagnostics_panel.h"
#include "app/gui/exam_panel.h"
#include "app/gui/force_plot.h"
#include "app/gui/material_panel.h"
#include "app/gui/probe_panel.h"
#include "app/gui/probe_tool.h"
#include "app/gui/readouts_panel.h"
#include "app/gui/replay_panel.h"
#include "app/gui/session_browser.h"
#include "app/gui/session_player.h"
#include "mesh/io.h"
#include "render/lesion_view.h"
#include "render/probe_view.h"
#include "render/scene.h"
#include "render/surface_view.h"

#include <QAction>
#include <QApplication>
#include <QCheckBox>
#include <QCloseEvent>
#include <QComboBox>
#include <QDateTime>
#include <QDialog>
#include <QDir>
#include <QDialogButtonBox>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QDragEnterEvent>
#include <QDropEvent>
#include <QFileDialog>
#include <QFileInfo>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QImage>
#include <QLabel>
#include <QListWidget>
#include <QMenuBar>
#include <QMimeData>
#include <QMouseEvent>
#include <QLineEdit>
#include <QPushButton>
#include <QScrollArea>
#include <QScrollBar>
#include <QSettings>
#include <QSpinBox>
#include <QRegularExpression>
#include <QStackedWidget>
#include <QStandardPaths>
#include <QStatusBar>
#include <QToolBar>
#include <QSurfaceFormat>
#include <QVBoxLayout>
#include <QWheelEvent>

#include <QVTKOpenGLNativeWidget.h>
#include <vtkAutoInit.h>
VTK_MODULE_INIT(vtkInteractionStyle);
#include <vtkCamera.h>
#include <vtkOpenGLRenderWindow.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkNew.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <algorithm>
#include <cmath>
#include <optional>

namespace palpa::app {
namespace {

constexpr int kMaxRecent = 8;

QString mm(double metres, int decimals = 1) { return QString::number(metres * 1e3, 'f', decimals); }

}  // namespace

void configure_application_defaults() {
  // Multisampling off (4x faster on llvmpipe); VTK's format set before the
  // QApplication exists, as QVTKOpenGLNativeWidget requires.
  vtkOpenGLRenderWindow::SetGlobalMaximumNumberOfMultiSamples(0);
  QSurfaceFormat format = QVTKOpenGLNativeWidget::defaultFormat();
  format.setSamples(0);
  QSurfaceFormat::setDefaultFormat(format);
  QCoreApplication::setOrganizationName("Palpa");
  QCoreApplication::setApplicationName("palpa");
}

// VTK objects of the viewport.
struct MainWindow::Vtk {
  vtkNew<vtkGenericOpenGLRenderWindow> window;
  vtkNew<vtkRenderer> renderer;
  // Shown lesions, drawn translucent over the organ (they lie inside it,
  // where the opaque surface would hide them) with the organ's camera.
  vtkNew<vtkRenderer> inclusions;
  vtkNew<vtkInteractorStyleTrackballCamera> style;
};

MainWindow::MainWindow(QWidget* parent) : QMainWindow(parent), vtk_(std::make_unique<Vtk>()) {
  setWindowTitle("Palpa");
  setAcceptDrops(true);
  build_ui();
  build_menus();
  build_session_ui();
  build_window_parts();
  load_settings();
  replay_dock_->hide();  // a replay starts from the browser or the menu, never from saved state
  exam_dock_->hide();    // an exam starts from the Mode menu, never from saved state
  browser_->set_folder(sessions_folder_);
  open_default_organ();

  // Frame timer: the haptic loop runs on its own threads; each frame reads
  // its state and draws.
  clock_.start();
  connect(&frame_timer_, &QTimer::timeout, this, &MainWindow::frame_tick);
  frame_timer_.start(16);
}

MainWindow::~MainWindow() {
  frame_timer_.stop();
  // QWidget's destructor deletes the children after this one has run: a
  // signal they send then (a dock's visibilityChanged as it hides) must not
  // reach a slot of this window, which is no longer a MainWindow (UBSan
  // found the Authoring dock's). Their connections to it go now.
  for (QObject* child : findChildren<QObject*>()) QObject::disconnect(child, nullptr, this, nullptr);
  if (author_tools_) author_tools_->attach(nullptr, 0);  // its handles go before the renderers
  if (replay_panel_) replay_panel_->close();
  replay_probe_views_.clear();
  replay_lesion_views_.clear();
  replay_view_.reset();
  // Probe and surface views go before the render window releases GL state.
  if (vtk_) {
    vtk_->renderer->RemoveAllViewProps();
    vtk_->inclusions->RemoveAllViewProps();
  }
  probe_views_.clear();
  hover_view_.reset();
  view_.reset();
}

vtkRenderer* MainWindow::renderer() const { return vtk_->renderer; }
vtkRenderer* MainWindow::inclusions_renderer() const { return vtk_->inclusions; }

const render::ProbeView* MainWindow::probe_view(int id) const {
  auto it = probe_views_.find(id);
  return it == probe_views_.end() ? nullptr : it->second.get();
}

// ---------------------------------------------------------------------------
// Layout: banner over the viewport, docks for organ, probes, readouts, material.
void MainWindow::build_ui() {
  auto* central = new QWidget(this);
  auto* layout = new QVBoxLayout(central);
  layout->setContentsMargins(0, 0, 0, 0);
  layout->setSpacing(0);
  error_banner_ = new QLabel(central);
  error_banner_->setObjectName("errorBanner");
  error_banner_->setWordWrap(true);
  error_banner_->setStyleSheet("QLabel { background: #8b1e1e; color: white; padding: 6px; }");
  error_banner_->setToolTip("Click to dismiss");
  error_banner_->hide();
  error_banner_->installEventFilter(this);
  layout->addWidget(error_banner_);

  viewport_ = new QVTKOpenGLNativeWidget(central);
  viewport_->setObjectName("viewport");
  viewport_->setMinimumSize(480, 360);
  vtk_->window->SetMultiSamples(0);
  viewport_->setRenderWindow(vtk_->window.Get());
  render::style_renderer(vtk_->renderer);
  vtk_->window->AddRenderer(vtk_->renderer);
  vtk_->window->SetNumberOfLayers(2);
  vtk_->inclusions->SetLayer(1);
  vtk_->inclusions->InteractiveOff();
  vtk_->inclusions->SetActiveCamera(vtk_->renderer->GetActiveCamera());
  vtk_->window->AddRenderer(vtk_->inclusions);
  viewport_->interactor()->SetInteractorStyle(vtk_->style);
  viewport_->setMouseTracking(true);
  viewport_->installEventFilter(this);
  layout->addWidget(viewport_, 1);
  setCentralWidget(central);

  // Organ dock: facts and the unit used when opening files.
  auto* organ = new QWidget;
  auto* organ_layout = new QFormLayout(organ);
  facts_ = new QLabel;
  facts_->setObjectName("meshFacts");
  facts_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  organ_layout->addRow(facts_);
  unit_box_ = new QComboBox;
  unit_box_->setObjectName("unitBox");
  unit_box_->addItems({"auto", "m", "cm", "mm"});
  organ_layout->addRow("File unit", unit_box_);
  auto* organ_dock = new QDockWidget("Organ", this);
  organ_dock->setObjectName("organDock");
  organ_dock->setWidget(organ);
  addDockWidget(Qt::RightDockWidgetArea, organ_dock);

  // Probes dock: list, add, remove (probe_panel.h). The list shows the
  // workbench's selection, so Remove removes the selected probe.
  auto* probes = probe_panel_ = new ProbePanel;
  connect(probe_panel_, &ProbePanel::add_requested, this, &MainWindow::add_probe);
  connect(probe_panel_, &ProbePanel::remove_requested, this, [this](int) { remove_selected_probe(); });
  connect(probe_panel_, &ProbePanel::selected, this, [this](int id) { workbench_.select_probe(id); });
  auto* probes_dock = new QDockWidget("Probes", this);
  probes_dock->setObjectName("probesDock");
  probes_dock->setWidget(probes);
  addDockWidget(Qt::RightDockWidgetArea, probes_dock);

  // Readouts dock: numbers and the force plot (readouts_panel.h).
  auto* readouts = readouts_panel_ = new ReadoutsPanel;
  plot_ = readouts_panel_->plot();
  connect(readouts_panel_, &ReadoutsPanel::reenable_requested, this, &MainWindow::reenable_selected);
  auto* readouts_dock = new QDockWidget("Readouts", this);
  readouts_dock->setObjectName("readoutsDock");
  readouts_dock->setWidget(readouts);
  addDockWidget(Qt::RightDockWidgetArea, readouts_dock);

  // Task dock: a scenario's instructions (hidden without one).
  task_text_ = new QLabel;
  task_text_->setObjectName("taskText");
  task_text_->setWordWrap(true);
  task_text_->setTextFormat(Qt::RichText);
  task_text_->setAlignment(Qt::AlignTop | Qt::AlignLeft);
  task_text_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  task_dock_ = new QDockWidget("Task", this);
  task_dock_->setObjectName("taskDock");
  auto* task_scroll = new QScrollArea;
  task_scroll->setWidgetResizable(true);
  task_scroll->setFrameShape(QFrame::NoFrame);
  task_scroll->setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  task_scroll->setMinimumHeight(160);
  task_scroll->setWidget(task_text_);
  task_dock_->setWidget(task_scroll);
  addDockWidget(Qt::LeftDockWidgetArea, task_dock_);
  task_dock_->hide();

  auto* material_dock = new QDockWidget("Material", this);
  material_dock->setObjectName("materialDock");
  auto* material_scroll = new QScrollArea;
  material_scroll->setWidgetResizable(true);
  material_scroll->setFrameShape(QFrame::NoFrame);
  material_scroll->setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  // The material panel (material_panel.h): an edit goes to the workbench.
  QWidget* panel = material_panel_ = new MaterialPanel;
  connect(material_panel_, &MaterialPanel::edited, this, &MainWindow::apply_material);
  connect(material_panel_, &MaterialPanel::restore_requested, this, &MainWindow::restore_tissue_map);
  material_scroll->setMinimumWidth(std::max(360, panel->sizeHint().width() +
                                                     material_scroll->verticalScrollBar()->sizeHint().width() + 8));
  material_scroll->setWidget(panel);
  material_dock->setWidget(material_scroll);
  addDockWidget(Qt::LeftDockWidgetArea, material_dock);

  hover_view_ = std::make_unique<render::ProbeView>();
  hover_view_->add_to(vtk_->renderer);
  hover_view_->set_visible(false);

  // The mouse probe on the viewport (probe_tool.h): it picks the organ as
  // drawn, the window shows where it would touch and lists its probes.
  probe_tool_ = new ProbeTool(
      workbench_,
      [this](const QPoint& pos, Vec3& rest, Vec3& normal, Vec3& drawn) { return pick_at(pos, rest, normal, drawn); },
      [this] { return in_replay(); }, this);
  connect(probe_tool_, &ProbeTool::hover, this, [this](bool shown, const Vec3& point, const Vec3& normal) {
    if (shown) hover_view_->set_state(point, normal, Vec3::Zero(), false, true);
    hover_view_->set_visible(shown);
    scene_dirty_ = true;
  });
  connect(probe_tool_, &ProbeTool::probeSelected, this, [this] { refresh_probe_list(); });
  connect(probe_tool_, &ProbeTool::probeAdded, this, [this] { need_full_sync_ = true; });
  connect(probe_tool_, &ProbeTool::failed, this, &MainWindow::show_error);
  statusBar()->showMessage("Ready");
}

void MainWindow::build_menus() {
  QMenu* file = menuBar()->addMenu("&File");
  QAction* open = file->addAction("&Open...", this, [this] {
    const QString path =
        QFileDialog::getOpenFileName(this, "Open an organ mesh or a scenario", QString(), open_dialog_filter());
    if (!path.isEmpty()) open_file(path);
  });
  open->setToolTip("Open an organ mesh (OBJ, STL, PLY, OFF, VTK, VTP, TRIAN) or a scenario file (.json)");
  file->addAction("Open &default organ", this, &MainWindow::open_default_organ);
  prep_action_ = new PrepAction(this);
  file->addAction(prep_action_->action());
  recent_menu_ = file->addMenu("Open &recent");
  file->addSeparator();
  QAction* shot = file->addAction("&Screenshot...", this, [this] {
    const QString path = QFileDialog::getSaveFileName(this, "Save screenshot", "palpa.png", "PNG (*.png)");
    if (!path.isEmpty()) save_screenshot(path);
  });
  shot->setShortcut(QKeySequence("Ctrl+Shift+X"));
  file->addSeparator();
  QAction* quit = file->addAction("&Quit", this, &QWidget::close);
  quit->setShortcut(QKeySequence::Quit);

  QMenu* edit = menuBar()->addMenu("&Edit");
  undo_material_ = edit->addAction("&Undo material edit (the scenario's tissues again)", this,
                                   &MainWindow::restore_tissue_map);
  undo_material_->setObjectName("undoMaterialEdit");
  undo_material_->setEnabled(false);
  build_authoring_ui(file, shot, edit);  // Ctrl+Z / Ctrl+Shift+Z: the scenario's undo history

  QMenu* probe = menuBar()->addMenu("&Probe");
  probe->addAction("&Add probe", this, &MainWindow::add_probe)->setShortcut(QKeySequence("Ctrl+P"));
  probe->addAction("&Remove probe", this, &MainWindow::remove_selected_probe)->setShortcut(QKeySequence::Delete);
  hold_action_ = probe->addAction("&Hold indentation after release");
  hold_action_->setCheckable(true);
  hold_action_->setChecked(true);
  connect(hold_action_, &QAction::toggled, probe_tool_, &ProbeTool::set_hold);

  QMenu* devices = menuBar()->addMenu("&Devices");
  devices->addAction("&Add device probe...", this, &MainWindow::add_device_dialog);
  devices->addAction("&Re-enable selected device", this, &MainWindow::reenable_selected);

  QMenu* view = menuBar()->addMenu("&View");
  force_arrows_action_ = view->addAction("Show &force arrows");
  force_arrows_action_->setObjectName("showForceArrows");
  force_arrows_action_->setCheckable(true);
  force_arrows_action_->setChecked(true);
  force_arrows_action_->setToolTip("Draw the force on each probe as an arrow (a scenario's picture shows none "
                                   "unless its lesions are revealed)");
  connect(force_arrows_action_, &QAction::toggled, this, [this] { save_settings(); });
  // Not kept between runs: a trainee's session never starts revealed.
  reveal_action_ = view->addAction("&Reveal lesions (debriefing)");
  reveal_action_->setObjectName("revealLesions");
  reveal_action_->setCheckable(true);
  reveal_action_->setToolTip("Also draw the scenario's hidden and after-exam lesions and the force arrows "
                             "(for the debriefing)");
  connect(reveal_action_, &QAction::toggled, this, [this] { rebuild_lesion_views(); });

  QMenu* sim = menuBar()->addMenu("&Simulation");
  sim->addAction("&Reset", this, &MainWindow::reset)->setShortcut(QKeySequence("Ctrl+R"));
}

// ---------------------------------------------------------------------------
// Settings kept between runs (QSettings): material, unit, recent files, hold, layout.
void MainWindow::load_settings() {
  QSettings s;
  loading_settings_ = true;
  material_panel_->load(s);  // the tissue (kPa, mm as shown), the law and the preset named
  unit_box_->setCurrentIndex(std::clamp(s.value("organ/unit", 0).toInt(), 0, 3));
  hold_action_->setChecked(s.value("probe/hold", true).toBool());
  force_arrows_action_->setChecked(s.value("view/force_arrows", true).toBool());
  recent_ = s.value("recentFiles").toStringList();
  trainee_edit_->setText(s.value("session/trainee", QString()).toString());
  sessions_folder_ = s.value("session/folder", default_sessions_folder()).toString();
  restoreGeometry(s.value("window/geometry").toByteArray());
  restoreState(s.value("window/state").toByteArray());
  loading_settings_ = false;
  rebuild_recent_menu();
  apply_material(material_panel_->settings());
}

void MainWindow::save_settings() const {
  QSettings s;
  material_panel_->save(s);
  s.setValue("organ/unit", unit_box_->currentIndex());
  s.setValue("probe/hold", hold_action_->isChecked());
  s.setValue("view/force_arrows", force_arrows_action_->isChecked());
  s.setValue("recentFiles", recent_);
  s.setValue("session/trainee", trainee_edit_->text());
  s.setValue("session/folder", sessions_folder_);
  s.setValue("window/geometry", saveGeometry());
  s.setValue("window/state", saveState());
}

void MainWindow::closeEvent(QCloseEvent* event) {
  if (!confirm_discard("closing the window")) {
    event->ignore();
    return;
  }
  if (mode_ == WorkbenchMode::Exam) set_mode(WorkbenchMode::Explore);  // the docks as they were, for the saved layout
  if (recording()) stop_recording();
  save_settings();
  QMainWindow::closeEvent(event);
}

// ---------------------------------------------------------------------------
// Errors: shown over the viewport until dismissed or the next good load.
void MainWindow::show_error(const QString& text) {
  error_banner_->setText(text);
  error_banner_->show();
  statusBar()->showMessage(text, 10000);
}

void MainWindow::clear_error() {
  error_banner_->clear();
  error_banner_->hide();
}

QString MainWindow::error_text() const { return error_banner_->isVisible() ? error_banner_->text() : QString(); }
QString MainWindow::facts_text() const { return facts_->text(); }
QString MainWindow::task_text() const { return task_text_->text(); }

// ---------------------------------------------------------------------------
// Organs.
bool MainWindow::open_mesh(const QString& path) {
  const QFileInfo info(path);
  if (!confirm_discard("opening " + info.fileName())) return false;
  if (!info.exists()) {
    recent_.removeAll(path);
    rebuild_recent_menu();
    show_error(QString("Could not open %1: the file does not exist (any more)").arg(path));
    return false;
  }
  try {
    const auto unit = static_cast<mesh::MeshUnit>(unit_box_->currentIndex());
    mesh::Organ organ = mesh::load_organ(path.toStdString(), unit);
    const double unit_m = organ.unit_m;
    install_organ(std::move(organ));
    organ_file_ = info.absoluteFilePath();
    organ_unit_ = unit_m == 1e-2 ? "cm" : unit_m == 1e-3 ? "mm" : "m";
  } catch (const std::exception& e) {
    show_error(QString("Could not open %1: %2").arg(info.fileName(), QString::fromStdString(e.what())));
    return false;
  }
  add_recent(info.absoluteFilePath());
  organ_path_ = info.absoluteFilePath();  // a unit change reloads it
  unit_index_ = unit_box_->currentIndex();
  clear_error();
  statusBar()->showMessage("Opened " + info.fileName(), 5000);
  return true;
}

bool MainWindow::can_open(const QString& path) {
  static const QStringList kSuffixes = {"json", "obj", "stl", "ply", "off", "vtk", "vtp", "trian"};
  return kSuffixes.contains(QFileInfo(path).suffix().toLower());
}

QString MainWindow::open_dialog_filter() {
  return "Organs and scenarios (*.obj *.stl *.ply *.off *.vtk *.vtp *.trian *.json);;"
         "Scenarios (*.json);;Meshes (*.obj *.stl *.ply *.off *.vtk *.vtp *.trian);;All files (*)";
}

bool MainWindow::is_scenario_file(const QString& path) { return QFileInfo(path).suffix().toLower() == "json"; }

bool MainWindow::open_file(const QString& path) { return is_scenario_file(path) ? open_scenario(path) : open_mesh(path); }

// A scenario: read, validated and resolved (organ, lesions, tissue map,
// field) before anything in the window changes.
bool MainWindow::open_scenario(const QString& path) {
  const QFileInfo info(path);
  if (!confirm_discard("opening " + info.fileName())) return false;
  if (!info.exists()) {
    recent_.removeAll(path);
    rebuild_recent_menu();
    show_error(QString("Could not open %1: the file does not exist (any more)").arg(path));
    return false;
  }
  try {
    std::optional<scenario::Resolved> resolved = resolve_scenario_with_progress(this, path);
    if (!resolved) {
      statusBar()->showMessage(QString("Opening %1 cancelled: nothing changed").arg(info.fileName()), 8000);
      return false;
    }
    install_scenario(std::move(*resolved));
  } catch (const std::exception& e) {
    show_error(QString("Could not open %1: %2").arg(info.fileName(), QString::fromStdString(e.what())));
    return false;
  }
  add_recent(info.absoluteFilePath());
  clear_error();
  statusBar()->showMessage("Opened the scenario " + info.fileName(), 5000);
  return true;
}

void MainWindow::open_default_organ() {
  if (!confirm_discard("opening the default organ")) return;
  try {
    install_organ(mesh::load_default_organ());
    organ_file_ = "default";
    organ_unit_ = "m";
    clear_error();
    if (!workbench_.organ().note.empty()) statusBar()->showMessage(QString::fromStdString(workbench_.organ().note));
  } catch (const std::exception& e) {
    show_error(QString("Could not open the default organ: %1").arg(e.what()));
  }
}

// Builds the new surface and view first; only then replaces the old ones.
void MainWindow::install_organ(mesh::Organ organ) {
  auto view = std::make_unique<render::SurfaceView>(organ.mesh);
  leave_replay();
  workbench_.set_organ(std::move(organ));  // all or nothing
  organ_prep_.reset();
  show_new_organ(std::move(view));
}

void MainWindow::install_scenario(scenario::Resolved resolved) {
  auto view = std::make_unique<render::SurfaceView>(resolved.organ.mesh);
  leave_replay();
  workbench_.set_scenario(std::move(resolved));  // all or nothing
  organ_prep_.reset();
  show_new_organ(std::move(view));
}

scenario::OrganRef MainWindow::organ_ref() const {
  if (const scenario::Resolved* sc = workbench_.scenario()) return sc->scenario.organ;
  scenario::OrganRef r;
  r.path = organ_file_.toStdString();
  r.resolved = organ_file_ == "default" ? mesh::default_organ_path() : std::filesystem::path(r.path);
  r.unit = organ_unit_.toStdString();
  r.prep = organ_prep_;
  return r;
}

// A prepared organ: a scenario's organ.prep edited (undoable; saving records
// it), or a bare organ replaced (New scenario then records its preparation).
QString MainWindow::install_prepared_organ(mesh::Organ organ, const scenario::OrganRef& ref) {
  if (workbench_.has_scenario()) {
    if (!document_->has_scenario()) return "the running scenario is not in the authoring document";
    return document_->edit("Prepare organ", [&](scenario::Scenario& s) { s.organ.prep = ref.prep; });
  }
  try {
    install_organ(std::move(organ));
  } catch (const std::exception& e) {
    return QString::fromStdString(e.what());
  }
  organ_prep_ = ref.prep;
  clear_error();
  return {};
}

// The window after the workbench took a new organ or scenario: the view,
// the shown lesions, the probes' glyphs, the facts, the task, the panel.
void MainWindow::show_new_organ(std::unique_ptr<render::SurfaceView> view, bool reset_document) {
  if (view_) vtk_->renderer->RemoveActor(view_->actor());
  view_ = std::move(view);
  sync_face_culling();
  vtk_->renderer->AddActor(view_->actor());
  frame_time_ = workbench_.loop_time();
  rebuild_lesion_views();
  if (workbench_.probes().empty()) {
    try {
      workbench_.add_probe();
    } catch (const std::exception& e) {
      show_error(QString("Could not add a mouse probe: %1").arg(e.what()));
    }
  }
  need_full_sync_ = true;
  view_at_rest_ = true;
  pull_surface();

  // Probe glyph size from the organ's size.
  const auto& f = workbench_.organ().facts;
  const double diag = (f.bbox_max - f.bbox_min).norm();
  if (hover_view_) hover_view_->remove_from(vtk_->renderer);
  hover_view_ = std::make_unique<render::ProbeView>(0.006 * diag, 0.12 * diag);
  hover_view_->add_to(vtk_->renderer);
  hover_view_->set_visible(false);
  for (auto& [id, pv] : probe_views_) pv->remove_from(vtk_->renderer);
  probe_views_.clear();
  plot_->clear();
  refresh_probe_list();

  // Facts: size, counts, closed or not.
  const Vec3 ext = f.bbox_max - f.bbox_min;
  QString text = QString("<b>%1</b><br>%2 vertices, %3 triangles<br>size %4 x %5 x %6 mm<br>%7")
                     .arg(QString::fromStdString(workbench_.organ().name))
                     .arg(f.vertices)
                     .arg(f.triangles)
                     .arg(mm(ext.x()), mm(ext.y()), mm(ext.z()))
                     .arg(f.closed() ? QString("closed")
                                     : QString("open (%1 boundary edges)").arg(f.boundary_edges));
  if (workbench_.organ().unit_guessed)
    text += QString("<br>file unit guessed: %1 m").arg(workbench_.organ().unit_m);
  facts_->setText(text);
  show_task();
  sync_material_panel();

  sync_session_actions();  // a new organ ended any recording of the old loop

  if (reset_document) authoring_after_new_organ();  // the authored document follows what runs

  // Camera on the whole organ.
  render::frame_camera(vtk_->renderer, view_->bounds(), Vec3(0.3, -1.0, 0.8), Vec3::UnitZ());
  after_new_organ();
  draw();
}

void MainWindow::add_recent(const QString& path) {
  recent_.removeAll(path);
  recent_.prepend(path);
  while (recent_.size() > kMaxRecent) recent_.removeLast();
  rebuild_recent_menu();
  QSettings().setValue("recentFiles", recent_);
}

void MainWindow::rebuild_recent_menu() {
  recent_menu_->clear();
  for (const QString& path : recent_)
    recent_menu_->addAction(QFileInfo(path).fileName(), this, [this, path] { open_file(path); })->setToolTip(path);
  recent_menu_->setEnabled(!recent_.isEmpty());
}

// Drag and drop: an organ mesh or a scenario file.
QString MainWindow::droppable_file(const QMimeData* data) {
  if (!data || !data->hasUrls()) return {};
  for (const QUrl& url : data->urls())
    if (url.isLocalFile() && can_open(url.toLocalFile())) return url.toLocalFile();
  return {};
}

bool MainWindow::drop_file(const QMimeData* data) {
  const QString path = droppable_file(data);
  return !path.isEmpty() && open_file(path);
}

void MainWindow::dragEnterEvent(QDragEnterEvent* event) {
  if (!droppable_file(event->mimeData()).isEmpty()) event->acceptProposedAction();
}

void MainWindow::dropEvent(QDropEvent* event) {
  if (droppable_file(event->mimeData()).isEmpty()) return;
  event->acceptProposedAction();
  drop_file(event->mimeData());
}

// The scenario's task (instructions, limits, what to report) in its dock,
// and the window title naming the scenario or the organ.
void MainWindow::show_task() {
  const scenario::Resolved* sc = workbench_.scenario();
  if (!sc) {
    task_text_->clear();
    task_dock_->hide();
    setWindowTitle(QString("Palpa - %1").arg(QString::fromStdString(workbench_.organ().name)));
    return;
  }
  const scenario::Scenario& s = sc->scenario;
  const QString file = QString::fromStdString(s.file.filename().string());
  const QString title = QString::fromStdString(s.title.empty() ? s.file.stem().string() : s.title);
  setWindowTitle(QString("Palpa - %1 (%2)").arg(title, file));
  QStringList report;
  if (s.task.report.position) report << "position";
  if (s.task.report.size) report << "size";
  if (s.task.report.consistency) report << "consistency";
  QString html = QString("<h3>%1</h3>").arg(title.toHtmlEscaped());
  if (!s.description.empty())
    html += QString("<p>%1</p>").arg(QString::fromStdString(s.description).toHtmlEscaped());
  html += QString("<p><b>Task:</b> %1</p>").arg(QString::fromStdString(s.task.instructions).toHtmlEscaped());
  html += "<p>";
  if (s.task.time_limit > 0) html += QString("Time limit: %1 s<br>").arg(s.task.time_limit);
  html += QString("Force limit: %1 N").arg(s.task.force_limit);
  if (!report.isEmpty()) html += QString("<br>Report for each lesion found: %1").arg(report.join(", "));
  html += "</p>";
  task_text_->setText(html);
  task_dock_->show();
}

bool MainWindow::save_screenshot(const QString& path) {
  const QImage image = viewport_->grabFramebuffer();
  if (image.isNull() || !image.save(path, "PNG")) {
    show_error(QString("Could not save the screenshot to %1").arg(path));
    return false;
  }
  statusBar()->showMessage("Saved " + path, 5000);
  return true;
}

// ---------------------------------------------------------------------------
// Material panel -> workbench, immediately.
void MainWindow::apply_material(const MaterialSettings& settings) {
  if (loading_settings_) return;
  MaterialSettings m = settings;
  try {
    workbench_.set_material(m);  // edits of the running loop: the dent and the probes stay
  } catch (const std::exception& e) {
    show_error(QString("Could not apply the material: %1").arg(e.what()));
    return;
  }
  update_scenario_note();
  need_full_sync_ = true;
  pull_surface();
  save_settings();
}

// The panel shows the workbench's settings (after a scenario set them),
// without applying anything.
void MainWindow::sync_material_panel() {
  material_panel_->set_settings(workbench_.material());
  update_scenario_note();
}

// With a scenario: say what a material edit does to its tissue map.
void MainWindow::update_scenario_note() {
  const scenario::Resolved* sc = workbench_.scenario();
  const bool replaced = sc && !workbench_.tissue_map_in_force();
  if (!sc) {
    material_panel_->set_scenario_note(QString());
  } else {
    const auto& s = sc->scenario;
    material_panel_->set_scenario_note(
        replaced ? QString("The scenario's tissue map is replaced: the tissue below now holds for the whole organ. "
                           "Edit > Undo material edit (or the button) restores the scenario's tissues.")
                 : QString("The scenario sets its own tissue map (%1 tissue(s), %2 region(s)); shown here is its "
                           "base tissue '%3'. Editing the tissue replaces the map with one tissue for the whole "
                           "organ (Edit > Undo material edit restores it).")
                       .arg(s.tissues.size())
                       .arg(s.regions.size())
                       .arg(QString::fromStdString(s.base_tissue)));
  }
  material_panel_->set_restore_visible(replaced);
  undo_material_->setEnabled(replaced);
}

void MainWindow::restore_tissue_map() {
  try {
    workbench_.restore_tissue_map();
  } catch (const std::exception& e) {
    show_error(QString("Could not restore the scenario's tissues: %1").arg(e.what()));
    return;
  }
  sync_material_panel();
  need_full_sync_ = true;
  pull_surface();
  statusBar()->showMessage("The scenario's tissue map is in force again", 5000);
}

// ---------------------------------------------------------------------------
// Probes.
void MainWindow::add_probe() {
  try {
    workbench_.add_probe();
  } catch (const std::exception& e) {
    show_error(QString("Could not add a probe: %1").arg(e.what()));
    return;
  }
  need_full_sync_ = true;
  refresh_probe_list();
}

bool MainWindow::add_device_probe(const QString& plugin, const QString& options) {
  // Scripted trajectories are written in world coordinates; a hand-held
  // device's origin goes to the organ's centre.
  haptics::DeviceMapping mapping;
  if (plugin != "scripted" && workbench_.has_organ()) {
    const auto& f = workbench_.organ().facts;
    const Vec3 c = 0.5 * (f.bbox_min + f.bbox_max);
    mapping.offset = {c.x(), c.y(), c.z()};
  }
  try {
    workbench_.add_device_probe(plugin.toStdString(), options.toStdString(), mapping);
  } catch (const std::exception& e) {
    show_error(QString("Could not add a %1 device: %2").arg(plugin, QString::fromStdString(e.what())));
    return false;
  }
  clear_error();
  need_full_sync_ = true;
  refresh_probe_list();
  statusBar()->showMessage("Added a " + plugin + " device", 5000);
  return true;
}

// The device dialog: the loadable plugins, each with a form built from the
// options it declares (device_dialog.h).
void MainWindow::add_device_dialog() {
  DeviceDialog dialog(this);
  if (dialog.exec() != QDialog::Accepted) return;
  add_device_probe(dialog.plugin(), dialog.options());
}

void MainWindow::reenable_selected() {
  workbench_.reenable(workbench_.selected_id());
  update_readouts();
}

void MainWindow::remove_selected_probe() {
  const int id = workbench_.selected_id();
  if (auto it = probe_views_.find(id); it != probe_views_.end()) {
    it->second->remove_from(vtk_->renderer);
    probe_views_.erase(it);
  }
  workbench_.remove_probe(id);
  need_full_sync_ = true;
  pull_surface();
  refresh_probe_list();
}

void MainWindow::refresh_probe_list() {
  probe_panel_->refresh(workbench_.probes(), workbench_.selected_id());
  for (const Probe& p : workbench_.probes())
    plot_->set_probe(p.id, ProbePanel::label(p), ForcePlot::probe_colour(p.id));  // its trace's and glyph's colour
}

void MainWindow::reset() {
  workbench_.reset();
  plot_->clear();
  need_full_sync_ = true;
  pull_surface();
  statusBar()->showMessage("Reset", 3000);
}

// ---------------------------------------------------------------------------
// Mouse gestures on the viewport.
bool MainWindow::pick_at(const QPoint& pos, Vec3& rest_point, Vec3& rest_normal, Vec3& drawn_point) const {
  if (!view_) return false;
  // Qt: logical pixels from the top; VTK: device pixels from the bottom.
  const double dpr = viewport_->devicePixelRatioF();
  const double x = (pos.x() + 0.5) * dpr;
  const double y = (viewport_->height() - pos.y() - 0.5) * dpr;
  const auto field = workbench_.field();
  std::optional<render::SurfacePick> hit;
  if (!field || !field->breathing.enabled) {
    hit = view_->pick(vtk_->renderer, x, y);
  } else {
    // A breathing organ is drawn moved (the frame's transform): the pixel's
    // ray goes into the organ frame (an affine map keeps it a line).
    double near_w[4], far_w[4];
    vtk_->renderer->SetDisplayPoint(x, y, 0.0);
    vtk_->renderer->DisplayToWorld();
    vtk_->renderer->GetWorldPoint(near_w);
    vtk_->renderer->SetDisplayPoint(x, y, 1.0);
    vtk_->renderer->DisplayToWorld();
    vtk_->renderer->GetWorldPoint(far_w);
    if (near_w[3] == 0 || far_w[3] == 0) return false;
    const Vec3 a = field->to_organ(Vec3(near_w[0], near_w[1], near_w[2]) / near_w[3], frame_time_);
    const Vec3 b = field->to_organ(Vec3(far_w[0], far_w[1], far_w[2]) / far_w[3], frame_time_);
    hit = view_->pick_ray(a, b - a);
    if (hit) hit->point = field->to_world(hit->point, frame_time_);
  }
  if (!hit) return false;
  rest_point = hit->rest_point;
  rest_normal = hit->rest_normal;
  drawn_point = hit->point;
  return true;
}

bool MainWindow::eventFilter(QObject* watched, QEvent* event) {
  if (watched == error_banner_ && event->type() == QEvent::MouseButtonRelease) {
    clear_error();
    return true;
  }
  if (watched != viewport_) return QMainWindow::eventFilter(watched, event);
  if (authoring_ && !in_replay() && author_tools_->handle(event)) return true;  // the authoring tools first
  if (probe_tool_->handle(event)) return true;  // then the mouse probe
  return QMainWindow::eventFilter(watched, event);
}

// ---------------------------------------------------------------------------
// The frame: the loop's latest state, the changed stream entries to the GPU, draw.
void MainWindow::advance() { frame(true); }
// The frame timer draws only on change (scene_changed(): new stream
// entries, scene edits, hover, breathing, replayed ticks, props whose
// redraw time moved), so an idle window costs next to nothing.
void MainWindow::frame_tick() { frame(false); }

void MainWindow::frame(bool always_draw) {
  if (in_replay()) {
    // The replay panel moves the player; the live loop is stopped.
    if (always_draw || scene_changed()) {
      draw();
      ++frames_in_window_;
    }
    return;
  }
  if (!workbench_.has_organ() || !view_) return;
  const double now = clock_.nsecsElapsed() * 1e-9;
  const double loop_time_before = workbench_.loop_time();
  workbench_.update();
  if (workbench_.recording()) update_recording_status();
  pull_surface();
  apply_frame_transform();
  sync_probe_views();
  update_readouts();
  // The exam's countdown runs on the loop's time.
  if (mode_ == WorkbenchMode::Exam) {
    const double dt = workbench_.loop_time() - loop_time_before;
    if (dt > 0 && dt < 1.0) advance_exam_time(dt);
    update_exam_frame();
  }
  if (always_draw || scene_changed()) {
    draw();
    ++frames_in_window_;
  }

  // Frame rate over the last second; the haptic rate is the loop's own.
  if (now - rate_window_start_ >= 1.0) {
    frame_rate_ = frames_in_window_ / (now - rate_window_start_);
    frames_in_window_ = 0;
    rate_window_start_ = now;
  }
}

// Only shown lesions are drawn: hidden ones are found by feel, and the
// after-exam ones wait for the debriefing (View > Reveal lesions draws both,
// and the force arrows).
void MainWindow::rebuild_lesion_views() {
  for (auto& lv : lesion_views_) vtk_->inclusions->RemoveActor(lv->actor());
  lesion_views_.clear();
  if (const scenario::Resolved* sc = workbench_.scenario()) {
    for (const tissue::Lesion& l : sc->lesions) {
      if (mode_ == WorkbenchMode::Exam && !reveal_action_->isChecked()) continue;  // none until Finish
      if (l.visibility != tissue::Visibility::Shown && !reveal_action_->isChecked() && !authoring_) continue;
      lesion_views_.push_back(std::make_unique<render::EllipsoidView>(l.centre, l.semi_axes));
      lesion_views_.back()->add_to(vtk_->inclusions);
    }
  }
  apply_frame_transform();
  scene_dirty_ = true;
}

std::size_t MainWindow::lesions_drawn() const { return lesion_views_.size(); }

// A breathing organ (and its shown lesions) drawn where it is at the loop's
// time; the same time maps picks back into the organ frame.
void MainWindow::apply_frame_transform() {
  frame_time_ = workbench_.loop_time();
  const auto field = workbench_.field();
  if (!view_ || !field || !field->breathing.enabled) return;
  scene_dirty_ = true;  // the organ moved
  const Eigen::Matrix4d organ_to_world = field->organ_to_world(frame_time_);
  view_->set_transform(organ_to_world);
  for (auto& lv : lesion_views_) lv->set_transform(organ_to_world);
  if (author_tools_) author_tools_->set_transform(organ_to_world);
}

// The stream entries the loop changed since the last frame (partial upload);
// without a loop (no probe) the surface is drawn at rest.
void MainWindow::pull_surface() {
  if (!view_) return;
  if (!workbench_.loop()) {
    if (!view_at_rest_) {
      const std::vector<float> rest(4 * view_->mesh().vertex_count(), 0.0f);
      view_->update_all(rest);
      view_at_rest_ = true;
      scene_dirty_ = true;
    }
    return;
  }
  // The view copies the changed blocks from the loop's mailbox, through the
  // workbench's copy read with atomic loads (a new view or loop, or a
  // reset: everything once).
  const bool everything = view_at_rest_ || need_full_sync_;
  need_full_sync_ = false;
  workbench_.pull_surface(
      [&](std::span<const float> stream, std::span<const IndexRange> ranges) {
        if (ranges.empty()) return;
        view_->update(stream, ranges);
        scene_dirty_ = true;
      },
      everything);
  view_at_rest_ = false;
}

void MainWindow::sync_probe_views() {
  const auto& f = workbench_.organ().facts;
  const double diag = (f.bbox_max - f.bbox_min).norm();
  for (const Probe& p : workbench_.probes()) {
    auto& pv = probe_views_[p.id];
    if (!pv) {
      pv = std::make_unique<render::ProbeView>(0.006 * diag, 0.12 * diag);
      const QColor c = plot_->colour(p.id);  // the glyph in its trace's colour
      pv->set_colour(Vec3(c.redF(), c.greenF(), c.blueF()));
      pv->add_to(vtk_->renderer);
    }
    // The arrow reaches 0.2 organ diagonals at the maximum force.
    pv->set_force_scale(0.2 * diag / std::max(workbench_.material().max_force, 1e-9));
    pv->set_visible(p.placed);
    // Mouse probes point along their press normal; devices along the contact's force.
    const Vec3 axis = p.host_fed || p.output.force.norm() == 0 ? p.normal : Vec3(p.output.force.normalized());
    // A scenario's picture shows no force (an arrow's length would give its
    // hidden lesions away: the trainee finds them by feel) unless revealed,
    // as palpa render --scenario does; an organ's follows View > force arrows.
    const bool arrows = workbench_.has_scenario() ? reveal_action_->isChecked() : force_arrows_action_->isChecked();
    const Vec3 arrow = arrows ? p.output.force : Vec3::Zero();
    if (p.placed) pv->set_state(p.tip, axis, arrow, p.output.in_contact, p.id == workbench_.selected_id());
  }
}

void MainWindow::update_readouts() {
  readouts_panel_->update(workbench_.probes(), workbench_.selected_id(), workbench_.time(),
                          workbench_.material().max_force);
  const haptics::LoopStatistics st = workbench_.statistics();
  haptic_rate_ = st.achieved_rate_hz;
  // The loop's figures jitter on every frame; shown twice a second, an idle
  // window does not repaint (and recomposite through GL) 60 times a second.
  const double now = clock_.isValid() ? clock_.nsecsElapsed() * 1e-9 : 0.0;
  if (figures_shown_at_ >= 0 && now - figures_shown_at_ < 0.5) return;
  figures_shown_at_ = now;
  diagnostics_->feed({workbench_.time(), st.ticks, st.deadline_misses, haptic_rate_, st.tick_duration.p99_us,
                      frame_rate_, renders_});
  // Loop warnings (no real-time priority, missed deadlines, ...).
  QStringList warnings;
  for (const auto& w : haptics::describe_warnings(workbench_.view().warnings)) warnings << QString::fromStdString(w);
  readouts_panel_->set_warnings(warnings.join("\n"), QString::fromStdString(st.realtime_notice));
}

QString MainWindow::warnings_text() const { return readouts_panel_->warnings_text(); }
QString MainWindow::device_status_text() const { return readouts_panel_->device_status_text(); }

// ---------------------------------------------------------------------------
// Sessions: Record / Stop with the trainee's name, the browser, the replay.
void MainWindow::build_session_ui() {
  QMenu* menu = menuBar()->addMenu("S&ession");
  menu->setToolTipsVisible(true);
  record_action_ = menu->addAction("&Record", this, [this] { start_recording(); });
  record_action_->setObjectName("recordSession");
  record_action_->setShortcut(QKeySequence("Ctrl+Shift+R"));
  record_action_->setToolTip("Record this session (every tick, command and deformation step of the running haptic "
                             "loop) into a new session file of the sessions folder, with the trainee's name");
  stop_action_ = menu->addAction("&Stop recording", this, [this] { stop_recording(); });
  stop_action_->setObjectName("stopRecording");
  stop_action_->setShortcut(QKeySequence("Ctrl+Shift+E"));
  stop_action_->setToolTip("Stop the recording and finish its file (the browser lists it)");
  menu->addSeparator();
  QAction* replay = menu->addAction("Re&play a session file...", this, [this] {
    const QString path = QFileDialog::getOpenFileName(this, "Replay a session", sessions_folder_,
                                                      "Palpa sessions (*.palpa);;All files (*)");
    if (!path.isEmpty()) open_replay(path);
  });
  replay->setToolTip("Replay a recorded session in the window, with a timeline");
  leave_replay_action_ = menu->addAction("&Back to live", this, &MainWindow::leave_replay);
  leave_replay_action_->setObjectName("leaveReplay");
  leave_replay_action_->setToolTip("Leave the replay: the live organ, probes and haptic loop again");
  QAction* folder = menu->addAction("Sessions &folder...", this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, "Folder for new recordings", sessions_folder_);
    if (!dir.isEmpty()) set_sessions_folder(dir);
  });
  folder->setToolTip("Where new recordings are written (and what the browser lists)");

  // The toolbar: Record, Stop, the trainee's name.
  QToolBar* bar = addToolBar("Session");
  bar->setObjectName("sessionToolBar");
  bar->addAction(record_action_);
  bar->addAction(stop_action_);
  bar->addWidget(new QLabel(" Trainee "));
  trainee_edit_ = new QLineEdit;
  trainee_edit_->setObjectName("traineeName");
  trainee_edit_->setPlaceholderText("name");
  trainee_edit_->setMaximumWidth(220);
  trainee_edit_->setToolTip("The trainee's name: written into each recording (its `trainee` meta row) and its "
                            "file name; remembered between runs");
  connect(trainee_edit_, &QLineEdit::editingFinished, this, [this] { save_settings(); });
  bar->addWidget(trainee_edit_);

  // The status bar: recording, elapsed time, dropped records.
  record_label_ = new QLabel;
  record_label_->setObjectName("recordingStatus");
  record_label_->setStyleSheet("QLabel { color: #b01010; font-weight: bold; }");
  record_label_->setToolTip("Recording: session time since Record (s) and the records the writer could not take");
  record_label_->hide();
  statusBar()->addPermanentWidget(record_label_);

  // The browser (a dock, hidden until asked for) and the replay timeline.
  browser_ = new SessionBrowser;
  browser_dock_ = new QDockWidget("Sessions", this);
  browser_dock_->setObjectName("sessionBrowserDock");
  browser_dock_->setWidget(browser_);
  addDockWidget(Qt::BottomDockWidgetArea, browser_dock_);
  browser_dock_->hide();
  QAction* show_browser = browser_dock_->toggleViewAction();
  show_browser->setText("Session &browser");
  show_browser->setObjectName("showSessionBrowser");
  show_browser->setShortcut(QKeySequence("Ctrl+Shift+B"));
  show_browser->setToolTip("The recorded sessions: trainee, scenario, date, duration and score; double-click one "
                           "to replay it");
  menu->insertAction(replay, show_browser);
  connect(browser_, &SessionBrowser::open_requested, this, [this](const QString& path) { open_replay(path); });

  replay_panel_ = new ReplayPanel;
  replay_dock_ = new QDockWidget("Replay", this);
  replay_dock_->setObjectName("replayDock");
  replay_dock_->setWidget(replay_panel_);
  addDockWidget(Qt::BottomDockWidgetArea, replay_dock_);
  replay_dock_->hide();
  connect(replay_panel_, &ReplayPanel::moved, this, &MainWindow::draw_replay);
  connect(replay_panel_, &ReplayPanel::leave_requested, this, &MainWindow::leave_replay);
  connect(replay_panel_, &ReplayPanel::failed, this, [this](const QString& text) { show_error("Replay: " + text); });
  sync_session_actions();
}

QString MainWindow::default_sessions_folder() {
  return QDir(QStandardPaths::writableLocation(QStandardPaths::AppDataLocation)).filePath("sessions");
}

void MainWindow::set_sessions_folder(const QString& folder) {
  sessions_folder_ = QDir(folder).absolutePath();
  browser_->set_folder(sessions_folder_);
  if (!loading_settings_) save_settings();
}

QString MainWindow::session_file_name(const QString& trainee, const QString& what, const QDateTime& utc) {
  auto part = [](const QString& text, const char* fallback) {
    QString p = text.trimmed();
    p.replace(QRegularExpression("[^A-Za-z0-9_-]+"), "-");
    p.replace(QRegularExpression("^-+|-+$"), "");
    return p.isEmpty() ? QString(fallback) : p.left(48);
  };
  return QString("%1_%2_%3Z.palpa")
      .arg(part(trainee, "anonymous"), part(what, "organ"), utc.toUTC().toString("yyyyMMdd-HHmmss"));
}

QString MainWindow::trainee() const { return trainee_edit_->text().trimmed(); }

void MainWindow::set_trainee(const QString& name) {
  trainee_edit_->setText(name);
  save_settings();
}

bool MainWindow::start_recording() {
  if (recording()) return false;
  if (in_replay()) {
    show_error("Could not start recording: leave the replay first (Session > Back to live)");
    return false;
  }
  if (!QDir().mkpath(sessions_folder_)) {
    show_error(QString("Could not start recording: cannot create the sessions folder %1").arg(sessions_folder_));
    return false;
  }
  const scenario::Resolved* sc = workbench_.scenario();
  const QString what = sc ? QString::fromStdString(sc->scenario.file.stem().string())
                          : QFileInfo(QString::fromStdString(workbench_.organ().name)).completeBaseName();
  const QDir dir(sessions_folder_);
  QString path = dir.filePath(session_file_name(trainee(), what, QDateTime::currentDateTimeUtc()));
  for (int k = 2; QFileInfo::exists(path); ++k)  // two recordings in one second
    path = dir.filePath(QFileInfo(path).completeBaseName().section('~', 0, 0) + QString("~%1.palpa").arg(k));
  save_settings();
  try {
    workbench_.start_recording(path.toStdString(), trainee().toStdString());
  } catch (const std::exception& e) {
    show_error(QString("Could not start recording: %1").arg(e.what()));
    return false;
  }
  clear_error();
  sync_session_actions();
  update_recording_status();
  statusBar()->showMessage(QString("Recording to %1 (the haptic loop paused %2 ms for the snapshot it starts from)")
                               .arg(path)
                               .arg(1e3 * workbench_.record_pause(), 0, 'f', 1),
                           5000);
  return true;
}

bool MainWindow::stop_recording() {
  if (!recording()) return false;
  bool ok = true;
  QString file = QString::fromStdString(workbench_.recording_file().string());
  try {
    file = QString::fromStdString(workbench_.stop_recording().string());
  } catch (const std::exception& e) {
    show_error(QString("The recording stopped with an error: %1").arg(e.what()));
    ok = false;
  }
  sync_session_actions();
  update_recording_status();
  browser_->refresh_when_shown();
  if (ok) statusBar()->showMessage("Saved the session " + file, 8000);
  return ok;
}

QString MainWindow::recording_text() const { return record_label_->isVisible() ? record_label_->text() : QString(); }

void MainWindow::update_recording_status() {
  if (!workbench_.recording()) {
    record_label_->clear();
    record_label_->hide();
    return;
  }
  const record::RecorderStats st = workbench_.recording_stats();
  record_label_->setText(QString("Recording %1 s, %2 dropped records")
                             .arg(workbench_.recording_elapsed(), 0, 'f', 1)
                             .arg(st.dropped));
  record_label_->setToolTip(QString("Recording to %1: %2 ticks committed; session time since Record (s) and the "
                                    "records the writer could not take")
                                .arg(QString::fromStdString(workbench_.recording_file().string()))
                                .arg(st.ticks_committed));
  record_label_->show();
}

void MainWindow::sync_session_actions() {
  const bool rec = workbench_.recording();
  record_action_->setEnabled(!rec && !in_replay() && workbench_.loop());
  stop_action_->setEnabled(rec);
  leave_replay_action_->setEnabled(in_replay());
  trainee_edit_->setEnabled(!rec);
  if (!rec) update_recording_status();
}

// A replay: the session's mesh in a view of its own, its probes, its shown
// lesions; the live view and probes are put aside and the loop stopped.
bool MainWindow::open_replay(const QString& path) {
  const QFileInfo info(path);
  if (recording()) {
    show_error(QString("Could not replay %1: stop the recording first").arg(info.fileName()));
    return false;
  }
  std::unique_ptr<SessionPlayer> player;
  std::unique_ptr<render::SurfaceView> view;
  try {
    player = std::make_unique<SessionPlayer>(path.toStdString());
    view = std::make_unique<render::SurfaceView>(player->session().model->mesh);
  } catch (const std::exception& e) {
    show_error(QString("Could not replay %1: %2").arg(info.fileName(), QString::fromStdString(e.what())));
    return false;
  }
  if (!in_replay()) {
    workbench_.suspend();  // the live devices no longer drive the organ
    if (view_) vtk_->renderer->RemoveActor(view_->actor());
    for (auto& [id, pv] : probe_views_) pv->set_visible(false);
    for (auto& lv : lesion_views_) vtk_->inclusions->RemoveActor(lv->actor());
    hover_view_->set_visible(false);
    probe_tool_->cancel();
  } else {
    vtk_->renderer->RemoveActor(replay_view_->actor());
    for (auto& pv : replay_probe_views_) pv->remove_from(vtk_->renderer);
    for (auto& lv : replay_lesion_views_) vtk_->inclusions->RemoveActor(lv->actor());
  }
  replay_probe_views_.clear();
  replay_lesion_views_.clear();
  const bool same_organ = view_ && view_->mesh().positions == view->mesh().positions;
  replay_view_ = std::move(view);
  replay_view_closed_outward_ = mesh::analyse(replay_view_->mesh()).closed_outward();
  sync_face_culling();
  vtk_->renderer->AddActor(replay_view_->actor());
  const auto b = replay_view_->bounds();
  const double diag = std::sqrt((b[1] - b[0]) * (b[1] - b[0]) + (b[3] - b[2]) * (b[3] - b[2]) + (b[5] - b[4]) * (b[5] - b[4]));
  for (std::size_t j = 0; j < player->session().file.header().setups.size(); ++j) {
    auto pv = std::make_unique<render::ProbeView>(0.006 * diag, 0.12 * diag);
    pv->set_force_scale(0.2 * diag / std::max(player->session().force_limit > 0 ? player->session().force_limit : 8.0, 1e-9));
    pv->add_to(vtk_->renderer);
    pv->set_visible(false);
    replay_probe_views_.push_back(std::move(pv));
  }
  for (const tissue::Lesion& l : player->session().lesions) {
    if (l.visibility != tissue::Visibility::Shown && !reveal_action_->isChecked()) continue;
    replay_lesion_views_.push_back(std::make_unique<render::EllipsoidView>(l.centre, l.semi_axes));
    replay_lesion_views_.back()->add_to(vtk_->inclusions);
  }
  if (!same_organ) render::frame_camera(vtk_->renderer, replay_view_->bounds(), Vec3(0.3, -1.0, 0.8), Vec3::UnitZ());
  replay_panel_->open(std::move(player));  // draws its first tick (moved)
  replay_dock_->show();
  replay_dock_->raise();
  sync_session_actions();
  clear_error();
  statusBar()->showMessage("Replaying " + info.fileName() + " (the live loop is paused)", 5000);
  draw();
  return true;
}

void MainWindow::leave_replay() {
  if (!in_replay()) return;
  replay_panel_->close();
  vtk_->renderer->RemoveActor(replay_view_->actor());
  for (auto& pv : replay_probe_views_) pv->remove_from(vtk_->renderer);
  for (auto& lv : replay_lesion_views_) vtk_->inclusions->RemoveActor(lv->actor());
  replay_probe_views_.clear();
  replay_lesion_views_.clear();
  replay_view_.reset();
  replay_dock_->hide();
  if (view_) vtk_->renderer->AddActor(view_->actor());
  rebuild_lesion_views();
  workbench_.resume();
  need_full_sync_ = true;
  pull_surface();
  sync_probe_views();
  sync_session_actions();
  statusBar()->showMessage("Back to the live session", 3000);
  draw();
}

// The replayed tick: its surface, probes (where the devices put them, the
// contact normal, the force unless a scenario hides it) and breathing.
void MainWindow::draw_replay() {
  const SessionPlayer* p = replay_panel_->player();
  if (!p || !replay_view_) return;
  scene_dirty_ = true;
  replay_view_->update_all(p->surface().stream());
  const auto& field = p->session().model->field;
  if (field && field->breathing.enabled) {
    const Eigen::Matrix4d x = field->organ_to_world(p->clock_time());
    replay_view_->set_transform(x);
    for (auto& lv : replay_lesion_views_) lv->set_transform(x);
  }
  const bool arrows = p->session().lesions.empty() && p->session().scenario_title.empty()
                          ? force_arrows_action_->isChecked()
                          : reveal_action_->isChecked();
  const auto results = p->results();
  for (std::size_t j = 0; j < replay_probe_views_.size(); ++j) {
    render::ProbeView& pv = *replay_probe_views_[j];
    if (j >= results.size() || !(results[j].sample.status & PALPA_STATUS_VALID)) {
      pv.set_visible(false);
      continue;
    }
    const haptics::ProbeTickResult& r = results[j];
    const Vec3 force = haptics::to_vec(r.force_world);
    const Vec3 axis = r.in_contact ? Vec3(haptics::to_vec(r.contact_normal)) : Vec3::UnitZ();
    pv.set_visible(true);
    pv.set_state(haptics::to_vec(r.world), axis, arrows ? force : Vec3::Zero(), r.in_contact != 0, j == 0);
  }
}

}  // namespace palpa::app
