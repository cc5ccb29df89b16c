// The mouse probe on the 3D view (moved out of main_window.cpp).

#include "app/gui/probe_tool.h"

#include <QEvent>
#include <QMouseEvent>
#include <QWheelEvent>

namespace palpa::app {

ProbeTool::ProbeTool(Workbench& workbench, Pick pick, Suspended suspended, QObject* parent)
    : QObject(parent), workbench_(workbench), pick_at_(std::move(pick)), in_replay_(std::move(suspended)) {}

bool ProbeTool::handle(QEvent* event) {
  switch (event->type()) {
    case QEvent::MouseButtonPress: return mouse_press(static_cast<QMouseEvent*>(event));
    case QEvent::MouseMove: return mouse_move(static_cast<QMouseEvent*>(event));
    case QEvent::MouseButtonRelease: return mouse_release(static_cast<QMouseEvent*>(event));
    case QEvent::Wheel: return wheel(static_cast<QWheelEvent*>(event));
    case QEvent::Leave: emit hover(false, Vec3::Zero(), Vec3::Zero()); return false;
    default: return false;
  }
}

bool ProbeTool::mouse_press(QMouseEvent* e) {
  if (e->button() != Qt::LeftButton || !workbench_.has_organ() || in_replay_()) return false;
  Vec3 rest, normal, drawn;
  if (!pick_at_(e->pos(), rest, normal, drawn)) return false;  // off the organ: VTK rotates
  const int id = mouse_probe_for(rest);
  if (id == 0) return true;
  workbench_.select_probe(id);
  emit probeSelected(id);
  workbench_.place(id, rest, normal, 0.0);
  indenting_ = true;
  press_pos_ = e->pos();
  press_depth_ = 0;
  emit hover(false, Vec3::Zero(), Vec3::Zero());
  return true;
}

// Pressing near a placed mouse probe takes that probe; else the selected one
// when the mouse drives it, else the first mouse probe, else a new one.
int ProbeTool::mouse_probe_for(const Vec3& rest) {
  int id = 0;
  if (const Probe* s = workbench_.selected_probe(); s && s->host_fed) id = s->id;
  const double near = 0.1 * workbench_.material().radius;
  for (const Probe& p : workbench_.probes()) {
    if (!p.host_fed) continue;
    if (id == 0 || (p.placed && (p.anchor - rest).norm() < near)) id = p.id;
  }
  if (id != 0) return id;
  try {
    id = workbench_.add_probe();
  } catch (const std::exception& e) {
    emit failed(QString("Could not add a probe: %1").arg(e.what()));
    return 0;
  }
  emit probeAdded(id);
  return id;
}

bool ProbeTool::mouse_move(QMouseEvent* e) {
  if (indenting_) {
    Probe* p = workbench_.selected_probe();
    if (!p || !p->host_fed) return true;
    if (e->modifiers() & Qt::ShiftModifier) {
      // Slide: follow the surface under the cursor at the same depth.
      Vec3 rest, normal, drawn;
      if (pick_at_(e->pos(), rest, normal, drawn)) workbench_.place(p->id, rest, normal, p->depth);
      press_pos_ = e->pos();
      press_depth_ = p->depth;
    } else {
      // Depth by dragging down.
      const double drag = (e->pos().y() - press_pos_.y()) * kDepthPerPixel;
      workbench_.set_depth(p->id, press_depth_ + drag);
    }
    return true;
  }
  if (e->buttons() != Qt::NoButton || in_replay_()) return false;  // VTK is rotating or zooming
  // Hover: show where the probe would touch.
  Vec3 rest, normal, drawn;
  if (pick_at_(e->pos(), rest, normal, drawn)) emit hover(true, drawn, normal);
  else emit hover(false, Vec3::Zero(), Vec3::Zero());
  return false;
}

bool ProbeTool::mouse_release(QMouseEvent* e) {
  if (!indenting_ || e->button() != Qt::LeftButton) return false;
  indenting_ = false;
  if (!hold_)
    if (Probe* p = workbench_.selected_probe()) workbench_.set_depth(p->id, 0.0);
  return true;
}

bool ProbeTool::wheel(QWheelEvent* e) {
  if (!indenting_) return false;  // VTK zooms
  Probe* p = workbench_.selected_probe();
  if (!p || !p->host_fed) return true;
  const double steps = e->angleDelta().y() / 120.0;
  press_depth_ += steps * kDepthPerWheelStep;
  workbench_.set_depth(p->id, p->depth + steps * kDepthPerWheelStep);
  return true;
}

}  // namespace palpa::app
