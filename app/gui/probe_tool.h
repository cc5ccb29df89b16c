#pragma once
// The mouse probe on the 3D view: pressing on the organ places the
// selected mouse probe there (or the placed mouse probe near the press, or
// a new one), dragging down presses it deeper, the wheel while pressing
// sets the depth, Shift slides it over the surface at its depth; the
// release lifts it unless the indentation is held. Hovering shows where a
// press would touch. Presses off the organ, and every gesture during a
// replay, go on to VTK (rotate, zoom). The tool edits the Workbench's
// probes; the window draws (hover) and lists them (probeSelected).

#include "app/gui/workbench.h"

#include <QObject>
#include <QPoint>

#include <functional>

class QEvent;
class QMouseEvent;
class QWheelEvent;

namespace palpa::app {

class ProbeTool : public QObject {
  Q_OBJECT
 public:
  /// Picks the organ under a viewport position (logical pixels): the rest
  /// point and outward normal (organ frame, m) and the point as drawn
  /// (world, m); false off the organ.
  using Pick = std::function<bool(const QPoint&, Vec3& rest_point, Vec3& rest_normal, Vec3& drawn_point)>;
  /// Whether the tool is off now (a replay is shown).
  using Suspended = std::function<bool()>;

  ProbeTool(Workbench& workbench, Pick pick, Suspended suspended, QObject* parent = nullptr);

  /// A viewport event (press, move, release, wheel, leave): true when the
  /// tool took it (VTK does not get it).
  bool handle(QEvent* event);
  /// Whether a press is going on.
  bool pressing() const { return indenting_; }
  /// Ends a press without lifting the probe (a replay starts).
  void cancel() { indenting_ = false; }
  /// Probe > Hold indentation after release.
  void set_hold(bool hold) { hold_ = hold; }
  bool hold() const { return hold_; }

  /// m of indentation per pixel of downward drag, and per wheel notch while pressing.
  static constexpr double kDepthPerPixel = 5e-5;
  static constexpr double kDepthPerWheelStep = 5e-4;

 signals:
  /// Where a press would touch (drawn point and normal); shown false: nowhere.
  void hover(bool shown, const palpa::Vec3& point, const palpa::Vec3& normal);
  /// A press selected probe `id` (the window lists it as current).
  void probeSelected(int id);
  /// A press added mouse probe `id`.
  void probeAdded(int id);
  /// A press could not add a probe.
  void failed(const QString& text);

 private:
  // The selected probe if the mouse drives it, else a mouse probe to use.
  int mouse_probe_for(const Vec3& rest);
  bool mouse_press(QMouseEvent* e);
  bool mouse_move(QMouseEvent* e);
  bool mouse_release(QMouseEvent* e);
  bool wheel(QWheelEvent* e);

  Workbench& workbench_;
  Pick pick_at_;
  Suspended in_replay_;
  bool hold_ = true;
  // Gesture state: pressing with a probe, where the press started.
  bool indenting_ = false;
  QPoint press_pos_;
  double press_depth_ = 0;   // m, from the wheel while pressed
};

}  // namespace palpa::app
