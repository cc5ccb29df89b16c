// The authoring tools on the 3D view (authoring_tools.h).

#include "app/gui/authoring_tools.h"

#include "render/lesion_view.h"
#include "scenario/resolve.h"

#include <QKeyEvent>
#include <QLineF>
#include <QMouseEvent>

#include <vtkActor.h>
#include <vtkRenderer.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <stdexcept>

namespace palpa::app {

namespace {

constexpr int kClickSlop = 4;          // px: a press and release closer than this is a click
constexpr int kHandlePixels = 14;      // px: a press this close to a handle takes it
const std::string kPaintPrefix = "paint ";

std::string paint_name(int n) {
  std::string name = kPaintPrefix;
  name += std::to_string(n);
  return name;
}

double largest_axis(const tissue::Lesion& l) { return l.semi_axes.maxCoeff(); }

}  // namespace

void apply_to_workbench(Workbench& workbench, const scenario::Scenario& s) {
  const scenario::Resolved* running = workbench.scenario();
  const bool same_organ = running && running->scenario.organ.resolved == s.organ.resolved &&
                          running->scenario.organ.unit == s.organ.unit && running->scenario.organ.prep == s.organ.prep;
  if (same_organ)
    workbench.edit_scenario(s);  // a command to the running loop: probes, dent and recording go on
  else
    workbench.set_scenario(scenario::resolve(s));  // a first scenario, or another organ: a new loop
}

std::string ensure_preset_tissue(scenario::Scenario& s, const std::string& key) {
  for (std::size_t k = 0; k < s.tissues.size(); ++k)
    if (k < s.tissue_presets.size() && s.tissue_presets[k] == key) return s.tissues[k].name;
  const tissue::Preset* p = tissue::find_preset(key);
  if (!p) throw std::invalid_argument("no tissue preset '" + key + "'");
  std::string name = key;
  for (int n = 2; std::any_of(s.tissues.begin(), s.tissues.end(), [&](const tissue::Tissue& t) { return t.name == name; });
       ++n)
    name = key + " " + std::to_string(n);
  tissue::Tissue t = p->tissue;
  t.name = name;
  s.tissue_presets.resize(s.tissues.size());
  s.tissues.push_back(t);
  s.tissue_presets.push_back(key);
  return name;
}

AuthoringTools::AuthoringTools(ScenarioDocument* doc, Pick pick, Project project, QObject* parent)
    : QObject(parent), doc_(doc), pick_(std::move(pick)), project_(std::move(project)) {
  connect(doc_, &ScenarioDocument::changed, this, [this] {
    const int n = doc_->has_scenario() ? static_cast<int>(doc_->scenario().lesions.size()) : 0;
    if (selected_ >= n) select(n - 1);
    refresh();
  });
}

AuthoringTools::~AuthoringTools() { attach(nullptr, size_); }

void AuthoringTools::set_tool(AuthoringTool tool) {
  if (tool == tool_) return;
  if (tool_ == AuthoringTool::DrawPulse) cancel_pulse();
  tool_ = tool;
  gesture_ = Gesture::None;
  emit toolChanged(tool);
}

void AuthoringTools::select(int lesion) {
  if (lesion == selected_) return;
  selected_ = lesion;
  refresh();
  emit selectionChanged(lesion);
}

// ---------------------------------------------------------------------------
// Handles: a sphere at each lesion's surface point (its centre for a lesion
// given by its centre), the selected one green; the pulse points being drawn.
Vec3 AuthoringTools::handle_point(std::size_t lesion) const {
  const scenario::LesionSpec& l = doc_->scenario().lesions[lesion];
  return l.from_surface ? l.surface_point : l.lesion.centre;
}

std::unique_ptr<render::EllipsoidView> AuthoringTools::make_view(const Vec3& centre, double radius, double r, double g,
                                                                 double b, double opacity) const {
  auto v = std::make_unique<render::EllipsoidView>(centre, Vec3::Constant(radius));
  v->set_color(r, g, b, opacity);
  v->set_transform(transform_);
  v->add_to(renderer_);
  return v;
}

void AuthoringTools::add_view(const Vec3& centre, double radius, double r, double g, double b, double opacity) {
  handles_.push_back(make_view(centre, radius, r, g, b, opacity));
}

void AuthoringTools::add_scene_view(const Vec3& centre, double radius, double r, double g, double b,
                                    double opacity) {
  scene_views_.push_back(make_view(centre, radius, r, g, b, opacity));
}

void AuthoringTools::clear_views() {
  if (renderer_) {
    for (auto& h : handles_) h->remove_from(renderer_);
    for (auto& v : scene_views_) v->remove_from(renderer_);
  }
  handles_.clear();
  scene_views_.clear();
  pulse_dots_ = painted_drawn_ = 0;
}

void AuthoringTools::attach(vtkRenderer* renderer, double size) {
  clear_views();
  renderer_ = renderer;
  size_ = size;
  refresh();
}

void AuthoringTools::set_transform(const Eigen::Matrix4d& organ_to_world) {
  transform_ = organ_to_world;
  for (auto& h : handles_) h->set_transform(transform_);
  for (auto& v : scene_views_) v->set_transform(transform_);
}

void AuthoringTools::refresh() {
  clear_views();
  if (!renderer_) return;
  if (doc_->has_scenario()) {
    const scenario::Scenario& s = doc_->scenario();
    // Pulse paths: a dot at every point and along each segment, about a
    // handle apart.
    for (const tissue::Pulse& pulse : s.pulses)
      for (std::size_t k = 0; k < pulse.path.size(); ++k) {
        const Vec3& a = pulse.path[k];
        if (k + 1 == pulse.path.size()) {
          add_scene_view(a, 0.3 * size_, 0.1, 0.5, 1.0, 0.9);
          ++pulse_dots_;
          break;
        }
        const Vec3& b = pulse.path[k + 1];
        const int n = std::clamp(static_cast<int>(std::ceil((b - a).norm() / (0.8 * size_))), 1, 200);
        for (int i = 0; i < n; ++i) {
          add_scene_view(a + (b - a) * (static_cast<double>(i) / n), 0.3 * size_, 0.1, 0.5, 1.0, 0.9);
          ++pulse_dots_;
        }
      }
    // Painted spheres (the brush's regions): a softening scale green, a
    // stiffening scale or a tissue magenta.
    for (const tissue::Region& g : s.regions) {
      if (g.kind != tissue::RegionKind::Sphere || g.name.rfind(kPaintPrefix, 0) != 0) continue;
      const bool softer = g.tissue.empty() && g.scale < 1.0;
      if (softer) add_scene_view(g.centre, g.radius, 0.2, 0.85, 0.4, 0.18);
      else add_scene_view(g.centre, g.radius, 0.85, 0.2, 0.8, 0.18);
      ++painted_drawn_;
    }
    const auto& lesions = doc_->scenario().lesions;
    for (std::size_t k = 0; k < lesions.size(); ++k) {
      Vec3 p = handle_point(k);
      if (gesture_ == Gesture::Move && static_cast<int>(k) == drag_lesion_ && dragged_) {
        p = lesions[k].from_surface ? drag_point_ : Vec3(p + (drag_point_ - press_point_));
      }
      if (static_cast<int>(k) == selected_) add_view(p, 0.6 * size_, 0.2, 0.9, 0.3, 0.9);
      else add_view(p, 0.5 * size_, 1.0, 0.85, 0.1, 0.9);
    }
  }
  for (const Vec3& p : pulse_points_) add_view(p, 0.35 * size_, 0.1, 0.7, 1.0, 0.9);
  for (const Vec3& p : stroke_) add_view(p, defaults_.brush_radius, 0.6, 0.2, 0.9, 0.25);
  emit redraw();
}

// ---------------------------------------------------------------------------
// Gestures.
int AuthoringTools::lesion_at(const QPoint& pos, const Vec3* picked) const {
  if (!doc_->has_scenario()) return -1;
  const auto& lesions = doc_->scenario().lesions;
  int best = -1;
  double best_d = 0;
  for (std::size_t k = 0; k < lesions.size(); ++k) {
    const Vec3 h = handle_point(k);
    // Near its handle on the screen, or the picked surface point over the lesion.
    const double pixels = QLineF(pos, project_(h)).length();
    double d = pixels <= kHandlePixels ? pixels : -1;
    if (d < 0 && picked && (*picked - h).norm() <= std::max(largest_axis(lesions[k].lesion), size_))
      d = kHandlePixels + (*picked - h).norm();
    if (d >= 0 && (best < 0 || d < best_d)) {
      best = static_cast<int>(k);
      best_d = d;
    }
  }
  return best;
}

bool AuthoringTools::handle(QEvent* event) {
  switch (event->type()) {
    case QEvent::MouseButtonPress: {
      auto* e = static_cast<QMouseEvent*>(event);
      if (e->button() != Qt::LeftButton || !doc_->has_scenario()) return false;
      Vec3 point, normal;
      const bool on_organ = pick_(e->pos(), point, normal);
      const int hit = lesion_at(e->pos(), on_organ ? &point : nullptr);
      press_pos_ = e->pos();
      dragged_ = false;
      if (hit >= 0 && tool_ != AuthoringTool::DrawPulse && tool_ != AuthoringTool::Paint) {
        select(hit);
        gesture_ = Gesture::Move;
        drag_lesion_ = hit;
        press_point_ = on_organ ? point : handle_point(static_cast<std::size_t>(hit));
        drag_point_ = press_point_;
        return true;
      }
      if (!on_organ || tool_ == AuthoringTool::None) return false;  // the window: probes, camera
      press_point_ = point;
      switch (tool_) {
        case AuthoringTool::PlaceLesion: gesture_ = Gesture::Place; break;
        case AuthoringTool::DrawPulse:
          pulse_points_.push_back(point);
          emit pulsePointsChanged(static_cast<int>(pulse_points_.size()));
          refresh();
          break;
        case AuthoringTool::Paint:
          gesture_ = Gesture::Stroke;
          stroke_.clear();
          paint_at(point);
          break;
        case AuthoringTool::None: break;
      }
      return true;
    }
    case QEvent::MouseMove: {
      auto* e = static_cast<QMouseEvent*>(event);
      if (gesture_ == Gesture::None) return false;
      if ((e->pos() - press_pos_).manhattanLength() >= kClickSlop) dragged_ = true;
      Vec3 point, normal;
      if (gesture_ == Gesture::Move && dragged_ && pick_(e->pos(), point, normal)) {
        drag_point_ = point;
        refresh();
      } else if (gesture_ == Gesture::Stroke && pick_(e->pos(), point, normal)) {
        paint_at(point);
      }
      return true;
    }
    case QEvent::MouseButtonRelease: {
      auto* e = static_cast<QMouseEvent*>(event);
      if (e->button() != Qt::LeftButton || gesture_ == Gesture::None) return false;
      const Gesture g = gesture_;
      gesture_ = Gesture::None;
      if (g == Gesture::Place) {
        place_lesion(press_point_);
      } else if (g == Gesture::Move) {
        if (!dragged_ || drag_point_ == press_point_) {
          refresh();
          return true;
        }
        const int k = drag_lesion_;
        const Vec3 to = drag_point_, from = press_point_;
        dragged_ = false;
        const QString error = doc_->edit("Move lesion", [&](scenario::Scenario& s) {
          scenario::LesionSpec& l = s.lesions.at(static_cast<std::size_t>(k));
          if (l.from_surface) l.surface_point = to;
          else l.lesion.centre += to - from;
        });
        if (!error.isEmpty()) refresh();  // back where it was
      } else if (g == Gesture::Stroke) {
        finish_stroke();
      }
      return true;
    }
    case QEvent::KeyPress: {
      auto* e = static_cast<QKeyEvent*>(event);
      if (tool_ != AuthoringTool::DrawPulse) return false;
      if (e->key() == Qt::Key_Return || e->key() == Qt::Key_Enter) {
        finish_pulse();
        return true;
      }
      if (e->key() == Qt::Key_Escape) {
        cancel_pulse();
        return true;
      }
      return false;
    }
    default: return false;
  }
}

void AuthoringTools::place_lesion(const Vec3& point) {
  std::set<std::string> names;
  for (const auto& l : doc_->scenario().lesions) names.insert(l.lesion.name);
  std::string name;
  for (int n = 1; name.empty() || names.count(name); ++n) {
    // Not "L" + std::to_string(n): gcc 12 flags that with a false -Wrestrict.
    char text[16];
    std::snprintf(text, sizeof text, "L%d", n);
    name = text;
  }
  scenario::LesionSpec l;
  l.from_surface = true;
  l.surface_point = point;
  l.depth = defaults_.lesion_depth;
  l.lesion.name = name;
  l.lesion.semi_axes = Vec3::Constant(defaults_.lesion_radius);
  l.lesion.modulus_ratio = defaults_.lesion_ratio;
  l.lesion.visibility = defaults_.lesion_visibility;
  const QString error = doc_->edit(QString("Place lesion '%1'").arg(QString::fromStdString(name)),
                                   [&](scenario::Scenario& s) { s.lesions.push_back(l); });
  if (error.isEmpty()) select(static_cast<int>(doc_->scenario().lesions.size()) - 1);
}

bool AuthoringTools::finish_pulse() {
  if (pulse_points_.size() < 2) {
    emit doc_->error(QString("A pulse path needs at least 2 points on the organ (it has %1): click on the surface "
                             "to add points, then Enter")
                         .arg(pulse_points_.size()));
    return false;
  }
  const std::vector<Vec3> path = pulse_points_;
  const QString error = doc_->edit("Add pulse path", [&](scenario::Scenario& s) {
    tissue::Pulse p;
    std::set<std::string> names;
    for (const auto& q : s.pulses) names.insert(q.name);
    for (int n = 1; p.name.empty() || names.count(p.name); ++n) p.name = "pulse " + std::to_string(n);
    p.path = path;
    p.radius = defaults_.pulse_radius;
    p.rate_bpm = defaults_.pulse_rate_bpm;
    p.amplitude = defaults_.pulse_amplitude;
    s.pulses.push_back(p);
  });
  if (!error.isEmpty()) return false;
  cancel_pulse();
  return true;
}

void AuthoringTools::cancel_pulse() {
  if (pulse_points_.empty()) return;
  pulse_points_.clear();
  emit pulsePointsChanged(0);
  refresh();
}

// A stroke: spheres at least half a brush radius apart.
void AuthoringTools::paint_at(const Vec3& point) {
  if (!stroke_.empty() && (stroke_.back() - point).norm() < 0.5 * defaults_.brush_radius) return;
  stroke_.push_back(point);
  refresh();
}

void AuthoringTools::finish_stroke() {
  const std::vector<Vec3> stroke = std::move(stroke_);
  stroke_.clear();
  if (stroke.empty()) return refresh();
  const AuthoringDefaults d = defaults_;
  if (d.brush_erase) {
    doc_->edit("Erase painted tissue", [&](scenario::Scenario& s) {
      std::erase_if(s.regions, [&](const tissue::Region& g) {
        if (g.kind != tissue::RegionKind::Sphere || g.name.rfind(kPaintPrefix, 0) != 0) return false;
        return std::any_of(stroke.begin(), stroke.end(),
                           [&](const Vec3& p) { return (g.centre - p).norm() <= d.brush_radius + 0.5 * g.radius; });
      });
    });
  } else {
    doc_->edit("Paint tissue", [&](scenario::Scenario& s) {
      const std::string tissue = d.brush_tissue.empty() ? std::string() : ensure_preset_tissue(s, d.brush_tissue);
      std::set<std::string> names;
      for (const auto& g : s.regions) names.insert(g.name);
      int n = 1;
      for (const Vec3& p : stroke) {
        tissue::Region g;
        while (names.count(paint_name(n))) ++n;
        g.name = paint_name(n);
        names.insert(g.name);
        g.kind = tissue::RegionKind::Sphere;
        g.centre = p;
        g.radius = d.brush_radius;
        g.feather = d.brush_feather;
        g.tissue = tissue;
        g.scale = tissue.empty() ? d.brush_scale : 1.0;
        s.regions.push_back(g);
      }
    });
  }
  refresh();
}

}  // namespace palpa::app
