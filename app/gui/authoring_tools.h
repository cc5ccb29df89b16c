#pragma once
// The authoring tools on the 3D view (docs/USER_GUIDE_AUTHORING.md), as 3D
// Slicer's Markups place points: a tool is picked in the authoring panel,
// then clicks on the organ make edits of the ScenarioDocument (each one an
// undoable command).
//   Place lesion  a click on the organ places a lesion below the picked
//                 surface point (from_surface, the default depth along the
//                 inward normal, radius, modulus ratio and visibility).
//   Move          pressing on a lesion's handle (a sphere at its surface
//                 point) and dragging over the surface moves it; the
//                 release pushes one "Move lesion" (only the surface point
//                 changes). Works with every tool.
//   Draw pulse    clicks add points of a pulse path; Enter (or Finish) adds
//                 the pulse, Escape drops the points.
//   Paint         a brush: pressing and dragging paints spheres of tissue or
//                 modulus scale (regions "paint N", with a feather); in
//                 erase mode it removes painted spheres it touches. One
//                 command per stroke.
// With no tool picked, a press on a lesion handle still moves it; any other
// press goes to the window (probes, camera).
//
// apply_to_workbench() is how an edited scenario reaches the running loop.

#include "app/gui/scenario_document.h"
#include "app/gui/workbench.h"

#include <QObject>
#include <QPoint>

#include <functional>
#include <memory>
#include <vector>

class QEvent;
class vtkRenderer;

namespace palpa::render {
class EllipsoidView;
}

namespace palpa::app {

/// Runs an edited scenario on the workbench. On the organ of the running
/// scenario it is Workbench::edit_scenario: one command to the running loop
/// (probes, dent, tick count and any recording go on). A first scenario on
/// a bare organ, or one on another organ file, unit or preparation
/// (organ.prep: the mesh from prep's cache), is resolved and run
/// with Workbench::set_scenario (a new loop). Throws (nothing changed)
/// scenario::ScenarioError for a scenario that does not resolve.
void apply_to_workbench(Workbench& workbench, const scenario::Scenario& s);

/// The name of a tissue of `s` made from preset `key`, added (from the
/// preset's values, named after the key) when there is none. Throws
/// std::invalid_argument for an unknown key.
std::string ensure_preset_tissue(scenario::Scenario& s, const std::string& key);

/// What a new lesion, pulse or brush stroke gets (SI units).
struct AuthoringDefaults {
  double lesion_depth = 0.012;   ///< m, of the centre below the surface point
  double lesion_radius = 0.006;  ///< m
  double lesion_ratio = 4.0;     ///< modulus ratio
  tissue::Visibility lesion_visibility = tissue::Visibility::Hidden;
  double pulse_rate_bpm = 72;
  double pulse_amplitude = 0.0015;  ///< m
  double pulse_radius = 0.01;       ///< m
  double brush_radius = 0.008;      ///< m
  double brush_feather = 0.004;     ///< m
  bool brush_erase = false;
  std::string brush_tissue;  ///< a preset key: the brush paints this tissue; empty: brush_scale
  double brush_scale = 2.0;  ///< modulus multiplier when no tissue
};

enum class AuthoringTool { None, PlaceLesion, DrawPulse, Paint };

class AuthoringTools : public QObject {
  Q_OBJECT
 public:
  /// Picks the undeformed organ under a viewport position: the rest point
  /// and outward normal (organ frame, m); false off the organ.
  using Pick = std::function<bool(const QPoint&, Vec3& point, Vec3& normal)>;
  /// Where an organ-frame point is drawn on the viewport (logical pixels).
  using Project = std::function<QPoint(const Vec3&)>;

  AuthoringTools(ScenarioDocument* doc, Pick pick, Project project, QObject* parent = nullptr);
  ~AuthoringTools() override;

  AuthoringDefaults& defaults() { return defaults_; }
  AuthoringTool tool() const { return tool_; }
  void set_tool(AuthoringTool tool);

  /// The selected lesion (index into the scenario's lesions; -1: none).
  int selected() const { return selected_; }
  void select(int lesion);

  /// Points of the pulse path being drawn (organ frame, m).
  const std::vector<Vec3>& pulse_points() const { return pulse_points_; }
  /// Adds the pulse path drawn ("Add pulse path"); false (error shown by
  /// the document) with fewer than 2 points or when refused.
  bool finish_pulse();
  void cancel_pulse();

  /// A viewport event (mouse, keys) while authoring: true when a tool took it.
  bool handle(QEvent* event);

  /// Draws the handles (lesions, pulse points being drawn) and what the
  /// scenario holds that has no other picture (each pulse path as a dotted
  /// blue line, each painted sphere translucent: green for a modulus scale
  /// below 1, magenta for a larger scale or a tissue) into `renderer`
  /// (the window's inclusions layer), `size` m across; null removes them.
  void attach(vtkRenderer* renderer, double size);
  /// Organ frame to world (breathing) for the handles.
  void set_transform(const Eigen::Matrix4d& organ_to_world);
  /// Rebuilds the handles from the document (after every change).
  void refresh();
  std::size_t handle_count() const { return handles_.size(); }
  /// A handle's radius scale, m (the size given to attach()).
  double handle_size() const { return size_; }
  /// Dots drawn along the scenario's pulse paths.
  std::size_t pulse_path_dots() const { return pulse_dots_; }
  /// Painted spheres drawn.
  std::size_t painted_drawn() const { return painted_drawn_; }

 signals:
  void selectionChanged(int lesion);
  void toolChanged(AuthoringTool tool);
  /// The pulse points changed (count).
  void pulsePointsChanged(int count);
  /// Something drawn changed: the window should render.
  void redraw();

 private:
  Vec3 handle_point(std::size_t lesion) const;
  int lesion_at(const QPoint& pos, const Vec3* picked) const;
  void place_lesion(const Vec3& point);
  void paint_at(const Vec3& point);
  void finish_stroke();
  std::unique_ptr<render::EllipsoidView> make_view(const Vec3& centre, double radius, double r, double g, double b,
                                                   double opacity) const;
  void add_view(const Vec3& centre, double radius, double r, double g, double b, double opacity);
  void add_scene_view(const Vec3& centre, double radius, double r, double g, double b, double opacity);
  void clear_views();

  ScenarioDocument* doc_;
  Pick pick_;
  Project project_;
  AuthoringDefaults defaults_;
  AuthoringTool tool_ = AuthoringTool::None;
  int selected_ = -1;

  // Gesture state.
  enum class Gesture { None, Place, Move, Stroke } gesture_ = Gesture::None;
  QPoint press_pos_;
  Vec3 press_point_ = Vec3::Zero();
  Vec3 drag_point_ = Vec3::Zero();
  bool dragged_ = false;
  int drag_lesion_ = -1;
  std::vector<Vec3> pulse_points_;
  std::vector<Vec3> stroke_;

  vtkRenderer* renderer_ = nullptr;
  double size_ = 0.004;
  Eigen::Matrix4d transform_ = Eigen::Matrix4d::Identity();
  std::vector<std::unique_ptr<render::EllipsoidView>> handles_;
  std::vector<std::unique_ptr<render::EllipsoidView>> scene_views_;  // pulse paths, painted spheres
  std::size_t pulse_dots_ = 0, painted_drawn_ = 0;
};

}  // namespace palpa::app
