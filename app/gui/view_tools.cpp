// Standard views and the orientation marker.

#include "app/gui/view_tools.h"

#include "render/scene.h"

#include <vtkAxesActor.h>
#include <vtkNew.h>
#include <vtkOrientationMarkerWidget.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>

namespace palpa::app {

QString standard_view_name(StandardView v) {
  switch (v) {
    case StandardView::Anterior: return "Anterior";
    case StandardView::Posterior: return "Posterior";
    case StandardView::Left: return "Left";
    case StandardView::Right: return "Right";
    case StandardView::Superior: return "Superior";
    case StandardView::Inferior: return "Inferior";
  }
  return {};
}

Vec3 standard_view_direction(StandardView v) {
  switch (v) {
    case StandardView::Anterior: return Vec3::UnitY();
    case StandardView::Posterior: return -Vec3::UnitY();
    case StandardView::Left: return -Vec3::UnitX();
    case StandardView::Right: return Vec3::UnitX();
    case StandardView::Superior: return Vec3::UnitZ();
    case StandardView::Inferior: return -Vec3::UnitZ();
  }
  return Vec3::UnitY();
}

Vec3 standard_view_up(StandardView v) {
  // Looking along z, anterior is up (as Slicer's axial views).
  return v == StandardView::Superior || v == StandardView::Inferior ? Vec3::UnitY() : Vec3::UnitZ();
}

void set_standard_view(vtkRenderer* renderer, const std::array<double, 6>& bounds, StandardView v) {
  render::frame_camera(renderer, bounds, standard_view_direction(v), standard_view_up(v));
}

struct OrientationMarker::Impl {
  vtkNew<vtkAxesActor> axes;
  vtkNew<vtkOrientationMarkerWidget> widget;
  bool attached = false;
};

OrientationMarker::OrientationMarker() : impl_(std::make_unique<Impl>()) {
  impl_->axes->SetXAxisLabelText("R");
  impl_->axes->SetYAxisLabelText("A");
  impl_->axes->SetZAxisLabelText("S");
  impl_->widget->SetOrientationMarker(impl_->axes);
  impl_->widget->SetViewport(0.0, 0.0, 0.18, 0.18);
}

OrientationMarker::~OrientationMarker() {
  if (impl_->attached) impl_->widget->SetEnabled(0);
}

void OrientationMarker::set_enabled(vtkRenderWindowInteractor* interactor, bool on) {
  if (!impl_->attached) {
    if (!on || !interactor) return;
    impl_->widget->SetInteractor(interactor);
    impl_->attached = true;
  }
  impl_->widget->SetEnabled(on ? 1 : 0);
  if (on) impl_->widget->InteractiveOff();
}

bool OrientationMarker::enabled() const { return impl_->attached && impl_->widget->GetEnabled() != 0; }

}  // namespace palpa::app
