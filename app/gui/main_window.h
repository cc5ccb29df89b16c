#pragma once
// The Qt5 workbench window: a VTK viewport on the organ, probes driven by the
// real-time haptic loop (mouse probes the window feeds from picking, and
// probes bound to device plugins from the Devices menu), live readouts from
// the loop and a force plot, the material panel, organ files by menu, drag
// and drop and recent files, settings kept between runs. Sessions: Record /
// Stop with the trainee's name (a session file per recording), a session
// browser and in-app replay with a timeline (docs/RECORDING.md, "In the
// workbench"). Errors appear in the window; the scene stays as it was.

#include "app/gui/exam.h"
#include "app/gui/mode.h"
#include "app/gui/view_tools.h"
#include "app/gui/workbench.h"

#include <QElapsedTimer>
#include <QMainWindow>
#include <QMessageBox>
#include <QString>
#include <QStringList>
#include <QTimer>

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <vector>

class QAction;
class QDateTime;
class QGroupBox;
class QLineEdit;
class QMimeData;
class QComboBox;
class QDockWidget;
class QDoubleSpinBox;
class QLabel;
class QListWidget;
class QMenu;
class QPushButton;
class QVTKOpenGLNativeWidget;
class vtkRenderer;

namespace palpa::render {
class EllipsoidView;
class ProbeView;
class SurfaceView;
}  // namespace palpa::render

namespace palpa::app {

class DiagnosticsPanel;
class ExamPanel;
class PrepAction;
class AuthoringPanel;
class AuthoringTools;
class ForcePlot;
class MaterialPanel;
class ProbePanel;
class ProbeTool;
class ReadoutsPanel;
class ReplayPanel;
class ScenarioDocument;
class SessionBrowser;

/// Call before creating the QApplication: VTK's surface format with
/// multisampling off, and the organisation name QSettings files go under.
void configure_application_defaults();

class MainWindow : public QMainWindow {
  Q_OBJECT
 public:
  /// Opens on the bundled default organ.
  explicit MainWindow(QWidget* parent = nullptr);
  ~MainWindow() override;

  /// Opens an organ mesh (unit from the Organ panel). On failure the error
  /// is shown in the window, the scene is unchanged and false is returned.
  bool open_mesh(const QString& path);
  /// Opens a scenario file (docs/SCENARIO.md) and runs it: its organ, tissue
  /// map, lesions (only shown ones drawn), pulses and breathing; its task in
  /// the Task dock; the title names it. On failure the error (naming the
  /// file) is shown, the scene and loop are unchanged and false is returned.
  bool open_scenario(const QString& path);
  /// open_scenario for a .json file, else open_mesh (File > Open, drops,
  /// recent files, `palpa FILE`).
  bool open_file(const QString& path);
  /// Whether File > Open and drops take this file (a scenario or a mesh, by suffix).
  static bool can_open(const QString& path);
  /// File > Open's filters: every format can_open() takes.
  static QString open_dialog_filter();
  static bool is_scenario_file(const QString& path);
  /// The first local file of a drag that can be opened (empty: none), and
  /// the drop handler: opens it; false when there is none or it fails.
  static QString droppable_file(const QMimeData* data);
  bool drop_file(const QMimeData* data);
  /// Undoes a material edit on a scenario (its tissue map again).
  void restore_tissue_map();
  /// The Task dock's text (empty without a scenario).
  QString task_text() const;
  /// Lesions drawn now (shown ones; every one with View > Reveal lesions).
  std::size_t lesions_drawn() const;
  /// Opens the bundled default organ.
  void open_default_organ();
  /// File > Prepare organ... (prep_action.h).
  PrepAction* prep_action() const { return prep_action_; }
  /// The organ shown as a scenario's organ reference: the running
  /// scenario's, else the bare organ's file ("default": the bundled one),
  /// unit and preparation (set when it was prepared).
  scenario::OrganRef organ_ref() const;
  /// Runs a prepared organ made from organ_ref() with ref.prep: on a running
  /// scenario, an undoable edit of its organ.prep through the authoring
  /// document (the scenario is resolved again; its mesh comes from prep's
  /// cache); on a bare organ, the organ installed as a new one. Returns the
  /// error (nothing changed), empty on success.
  QString install_prepared_organ(mesh::Organ organ, const scenario::OrganRef& ref);
  /// Writes the viewport to a PNG; on failure shows the error.
  bool save_screenshot(const QString& path);
  /// Surface to rest, every probe lifted.
  void reset();
  /// Adds a probe (and selects it); removes the selected one.
  void add_probe();
  void remove_selected_probe();
  /// Adds a probe bound to device plugin `plugin` created with `options`
  /// (plugins/README.md lists them); `scripted` trajectories are in world
  /// coordinates, other devices have their origin at the organ's centre. On
  /// failure shows "Could not add a <plugin> device: <reason>", changes
  /// nothing and returns false.
  bool add_device_probe(const QString& plugin, const QString& options);
  /// Asks for a device and its options (Devices menu).
  void add_device_dialog();
  /// Re-enables force output of the selected probe (clears a latched fault).
  void reenable_selected();

  // Sessions.
  /// Starts recording the running loop (Session > Record) into a new file
  /// of sessions_folder() named by session_file_name() with the trainee
  /// field's name; the loop goes on (Workbench::start_recording). On
  /// failure shows the error and returns false.
  bool start_recording();
  /// Stops and finishes the recording (Session > Stop); the browser lists
  /// it. False when not recording or when the writer failed (shown).
  bool stop_recording();
  bool recording() const { return workbench_.recording(); }
  /// The status bar's recording text ("Recording 12.3 s, 0 dropped
  /// records"; empty when not recording).
  QString recording_text() const;
  /// Where recordings go (QSettings; default default_sessions_folder()).
  QString sessions_folder() const { return sessions_folder_; }
  /// Sets it (kept in QSettings) and lists it in the browser.
  void set_sessions_folder(const QString& folder);
  /// "sessions" under QStandardPaths::AppDataLocation.
  static QString default_sessions_folder();
  /// TRAINEE_WHAT_yyyyMMdd-HHmmssZ.palpa, each part reduced to letters,
  /// digits, '-' and '_' (an empty trainee is "anonymous").
  static QString session_file_name(const QString& trainee, const QString& what, const QDateTime& utc);
  /// The trainee name field (kept in QSettings).
  QString trainee() const;
  void set_trainee(const QString& name);
  SessionBrowser* session_browser() const { return browser_; }
  ReplayPanel* replay_panel() const { return replay_panel_; }
  /// Replays a session file in the window (a recording must be stopped
  /// first): the live loop stops (its devices do not drive the organ), the
  /// view shows the replayed surface and probes, the timeline appears. On
  /// failure shows the error (naming the file) and returns false; the live
  /// session stays as it was.
  bool open_replay(const QString& path);
  /// Back to the live session: its organ, probes and loop running again.
  void leave_replay();
  bool in_replay() const { return replay_view_ != nullptr; }

  // Authoring (docs/USER_GUIDE_AUTHORING.md; main_window_authoring.cpp).
  /// Authoring mode (the "Author scenario" action, objectName "authorMode"):
  /// the authoring panel, the tools on the 3D view and the x-ray view (the
  /// organ translucent, every lesion drawn, hidden ones included).
  void set_authoring(bool on);
  bool authoring() const { return authoring_; }
  /// Whether the organ is drawn translucent (authoring's x-ray view).
  bool xray() const;
  ScenarioDocument* document() const { return document_; }
  AuthoringTools* authoring_tools() const { return author_tools_; }
  AuthoringPanel* authoring_panel() const { return author_panel_; }
  /// File > New scenario: a scenario around the organ shown (its file and
  /// unit; the base tissue from the presets), run at once. Asks first when
  /// the document has unsaved changes. False (error shown) when it cannot.
  bool new_scenario();
  /// File > Save scenario / Save scenario as: atomically
  /// (scenario::save_scenario). save_document() asks for a file when the
  /// scenario has none. False (error shown) on failure or when cancelled.
  bool save_document();
  bool save_document_as(const QString& path);
  /// Asks what to do with unsaved changes before `doing` ("closing the
  /// window", "opening x.json"...): Save, Discard or Cancel. True when the
  /// caller may go on (nothing to lose, saved, or discarded).
  bool confirm_discard(const QString& doing);
  /// Replaces the question (tests): gets the question's text, returns
  /// QMessageBox::Save, Discard or Cancel.
  using SavePrompt = std::function<QMessageBox::StandardButton(const QString& question)>;
  void set_save_prompt(SavePrompt prompt) { save_prompt_ = std::move(prompt); }

  Workbench& workbench() { return workbench_; }
  QVTKOpenGLNativeWidget* viewport() const { return viewport_; }
  vtkRenderer* renderer() const;
  /// The surface drawn: the replayed one during a replay, else the live organ's.
  render::SurfaceView* surface_view() const { return replay_view_ ? replay_view_.get() : view_.get(); }
  /// The error shown in the window, empty when none.
  QString error_text() const;
  QString facts_text() const;
  QStringList recent_files() const { return recent_; }
  /// The loop's achieved tick rate and the frame rate, per second.
  double haptic_rate() const { return haptic_rate_; }
  double frame_rate() const { return frame_rate_; }
  ForcePlot* force_plot() const { return plot_; }
  /// The glyph of probe `id` in the scene (null before its first frame).
  const render::ProbeView* probe_view(int id) const;
  /// Loop warnings and the selected probe's safety state / latched fault, as shown.
  QString warnings_text() const;
  QString device_status_text() const;

  /// Reads the haptic loop's latest state, moves the changed stream entries
  /// to the GPU and draws one frame (always: tests and scripts call it).
  void advance();
  /// What the frame timer calls: advance()'s work, drawing only when
  /// something shown changed (an idle window draws nothing).
  void frame_tick();
  /// Frames this window drew (advance(), frame_tick() and scene edits).
  std::uint64_t renders() const { return renders_; }

  // Modes (mode.h): the Mode menu and the toolbar's mode box.
  WorkbenchMode mode() const { return mode_; }
  /// Explore and Author: the workbench as it is. Exam needs a scenario
  /// (else the error says so, the mode stays and false is returned): its
  /// lesions are not drawn, no readout gives one away (force arrows off and
  /// their toggle disabled, the Material and Readouts docks hidden), the
  /// Exam dock shows the countdown, the pressure gauge and the marks.
  /// Leaving Exam restores the view settings it changed.
  bool set_mode(WorkbenchMode mode);
  /// open_scenario, then Exam mode (File > Open scenario as trainee).
  bool open_scenario_as_trainee(const QString& path);
  ExamPanel* exam_panel() const { return exam_panel_; }
  /// Exam (key M, the toolbar's Mark, a device's first button): asks the
  /// size and consistency of a finding at the selected probe's contact
  /// point (its tip when not in contact) in a MarkDialog (non-modal; its OK
  /// calls add_mark). False (said in the status bar) when no exam runs or
  /// the selected probe is not placed.
  bool request_mark();
  /// Exam: adds a mark (organ frame, m; diameter m, 0: not given;
  /// consistency), listed in the Exam dock and, when recording, written as
  /// a Mark event of the session. False when no exam runs.
  bool add_mark(const Vec3& point, double diameter, const QString& consistency);
  void remove_mark(int index);
  /// Exam: the marks against the truth in the Exam dock, the lesions
  /// revealed (View > Reveal lesions enabled again).
  void finish_exam();
  /// Exam time passes (s): the countdown; the frame timer passes the loop's
  /// time between frames.
  void advance_exam_time(double seconds);

  // View.
  void reset_camera();
  void set_standard_view(StandardView view);
  DiagnosticsPanel* diagnostics() const { return diagnostics_; }
  /// The status bar's sustained-misses warning (empty: none).
  QString diagnostics_warning() const;
  /// The scenario opened last (kept in QSettings; empty: none).
  QString last_scenario() const;
  /// Opens last_scenario() (`palpa` with no FILE); false when there is none
  /// or it fails (the error shown).
  bool reopen_last_scenario();

 signals:
  void modeChanged(WorkbenchMode mode);

 signals:
  void authoringChanged(bool on);

 protected:
  bool eventFilter(QObject* watched, QEvent* event) override;
  void dragEnterEvent(QDragEnterEvent* event) override;
  void dropEvent(QDropEvent* event) override;
  void closeEvent(QCloseEvent* event) override;

 private:
  void build_ui();
  // The frame timer's advance(): draws only when something shown changed,
  // so an idle window draws nothing.
  void build_menus();
  void build_session_ui();
  // Issue 10's parts: modes and the exam, the main toolbar, View and Help
  // additions, diagnostics, tooltips (main_window_parts.cpp).
  void build_window_parts();
  void frame(bool always_draw);
  void draw();
  bool scene_changed();
  void enter_exam();
  void leave_exam();
  void restart_exam();
  void sync_mode_controls();
  void after_new_organ();
  void update_exam_frame();
  void reload_with_unit();
  void sync_session_actions();
  void update_recording_status();
  void draw_replay();
  void load_settings();
  void save_settings() const;
  void show_error(const QString& text);
  void clear_error();
  void install_organ(mesh::Organ organ);
  void install_scenario(scenario::Resolved resolved);
  // reset_document false: an edit of the authored scenario brought a new
  // mesh (its organ's preparation), the document and its history stay.
  void show_new_organ(std::unique_ptr<render::SurfaceView> view, bool reset_document = true);
  void show_task();
  void apply_frame_transform();
  void rebuild_lesion_views();
  void sync_material_panel();
  void update_scenario_note();
  void add_recent(const QString& path);
  void rebuild_recent_menu();
  void apply_material(const MaterialSettings& m);
  void refresh_probe_list();
  void sync_probe_views();
  void update_readouts();
  void pull_surface();
  // Mouse: the organ under a widget position (the probe tool's pick).
  bool pick_at(const QPoint& pos, Vec3& rest_point, Vec3& rest_normal, Vec3& drawn_point) const;
  // Authoring (main_window_authoring.cpp).
  void build_authoring_ui(QMenu* file, QAction* before, QMenu* edit);
  vtkRenderer* inclusions_renderer() const;
  void authoring_after_new_organ();
  void apply_document(const scenario::Scenario& s);
  void sync_authoring_view();
  /// Skips the organ's back faces where that cannot change the picture
  /// (closed, outward, drawn opaque): about half the software renderer's
  /// geometry work, which bounds a large organ's frame.
  void sync_face_culling();
  void update_document_title();
  QPoint project_to_viewport(const Vec3& organ_point) const;

  Workbench workbench_;
  QVTKOpenGLNativeWidget* viewport_ = nullptr;
  struct Vtk;
  std::unique_ptr<Vtk> vtk_;
  std::unique_ptr<render::SurfaceView> view_;
  std::map<int, std::unique_ptr<render::ProbeView>> probe_views_;
  std::unique_ptr<render::ProbeView> hover_view_;
  std::vector<std::unique_ptr<render::EllipsoidView>> lesion_views_;  // shown lesions only
  double frame_time_ = 0;  // s, the loop time the organ is drawn at (breathing)

  QLabel* error_banner_ = nullptr;
  QLabel* facts_ = nullptr;
  QComboBox* unit_box_ = nullptr;
  ProbePanel* probe_panel_ = nullptr;
  ReadoutsPanel* readouts_panel_ = nullptr;
  ForcePlot* plot_ = nullptr;  // the readouts panel's
  QDockWidget* task_dock_ = nullptr;
  QLabel* task_text_ = nullptr;
  MaterialPanel* material_panel_ = nullptr;
  QAction* undo_material_ = nullptr;
  QMenu* recent_menu_ = nullptr;
  QAction* hold_action_ = nullptr;
  QAction* force_arrows_action_ = nullptr;
  QAction* reveal_action_ = nullptr;
  QStringList recent_;

  // Sessions: recording, the browser, the replay.
  QLineEdit* trainee_edit_ = nullptr;
  QAction* record_action_ = nullptr;
  QAction* stop_action_ = nullptr;
  QAction* leave_replay_action_ = nullptr;
  QLabel* record_label_ = nullptr;
  QDockWidget* browser_dock_ = nullptr;
  QDockWidget* replay_dock_ = nullptr;
  SessionBrowser* browser_ = nullptr;
  ReplayPanel* replay_panel_ = nullptr;
  QString sessions_folder_;
  std::unique_ptr<render::SurfaceView> replay_view_;  // non-null: replaying
  bool replay_view_closed_outward_ = false;           // replay_view_'s mesh: closed_outward() (its facts are not kept)
  std::vector<std::unique_ptr<render::ProbeView>> replay_probe_views_;
  std::vector<std::unique_ptr<render::EllipsoidView>> replay_lesion_views_;

  // The mouse probe's gestures on the viewport.
  ProbeTool* probe_tool_ = nullptr;
  bool loading_settings_ = true;  // no saving while the window is being built

  // Whether the view must take every vertex next, and whether it is at rest.
  bool need_full_sync_ = true;  // the view needs every vertex at the next pull (new organ, loop or reset)
  bool view_at_rest_ = true;

  // Clock and rates.
  QTimer frame_timer_;
  QElapsedTimer clock_;
  double rate_window_start_ = 0;
  std::uint64_t frames_in_window_ = 0;
  double haptic_rate_ = 0, frame_rate_ = 0;
  double figures_shown_at_ = -1;  // s: the loop's figures are shown twice a second (each change repaints the window)

  // Drawing only on change.
  std::uint64_t renders_ = 0;
  bool scene_dirty_ = true;                 // a scene edit or new stream entries since the last draw
  unsigned long long props_drawn_at_ = 0;   // the props' newest redraw time at the last draw

  // Modes, the exam, diagnostics, view tools.
  WorkbenchMode mode_ = WorkbenchMode::Explore;
  struct ViewSettings {  // what Exam mode changes, restored when leaving it
    bool arrows = true, reveal = false, material = true, readouts = true;
  };
  ViewSettings before_exam_;
  ExamPanel* exam_panel_ = nullptr;
  QDockWidget* exam_dock_ = nullptr;
  QDockWidget* material_dock_ = nullptr;
  QDockWidget* readouts_dock_ = nullptr;
  QDockWidget* diagnostics_dock_ = nullptr;
  DiagnosticsPanel* diagnostics_ = nullptr;
  QLabel* diagnostics_warning_ = nullptr;
  QComboBox* mode_box_ = nullptr;
  std::map<WorkbenchMode, QAction*> mode_actions_;
  QAction* mark_action_ = nullptr;
  QAction* finish_action_ = nullptr;
  QAction* orientation_action_ = nullptr;
  std::unique_ptr<OrientationMarker> orientation_marker_;
  std::uint32_t last_buttons_ = 0;          // the selected probe's device buttons at the last frame
  int unit_index_ = 0;                      // the unit the organ file was opened with
  QString organ_path_;                      // the organ's mesh file (empty: the default organ or a scenario's)

  // Authoring.
  bool authoring_ = false;
  ScenarioDocument* document_ = nullptr;
  AuthoringTools* author_tools_ = nullptr;
  AuthoringPanel* author_panel_ = nullptr;
  QDockWidget* author_dock_ = nullptr;
  QAction* author_action_ = nullptr;
  SavePrompt save_prompt_;
  QString organ_file_ = "default";  // the organ shown: its file ("default": the bundled one) and unit
  std::optional<scenario::PrepSpec> organ_prep_;  // the bare organ's preparation (none: as loaded)
  PrepAction* prep_action_ = nullptr;
  friend class PrepAction;  // its messages go through show_error
  QString organ_unit_ = "m";  // s: the loop's figures are shown twice a second (each change repaints the window)
};

}  // namespace palpa::app
