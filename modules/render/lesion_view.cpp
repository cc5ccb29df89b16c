// Translucent ellipsoids for shown lesions (lesion_view.h).

#include "render/lesion_view.h"

#include <vtkActor.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkSphereSource.h>
#include <vtkTransform.h>
#include <vtkTransformPolyDataFilter.h>

namespace palpa::render {

struct EllipsoidView::Impl {
  vtkNew<vtkSphereSource> sphere;
  vtkNew<vtkTransform> shape;
  vtkNew<vtkTransformPolyDataFilter> filter;
  vtkNew<vtkPolyDataMapper> mapper;
  vtkNew<vtkActor> actor;
};

EllipsoidView::EllipsoidView(const Vec3& centre, const Vec3& semi_axes) : impl_(std::make_unique<Impl>()) {
  impl_->sphere->SetRadius(1.0);
  impl_->sphere->SetThetaResolution(32);
  impl_->sphere->SetPhiResolution(24);
  impl_->shape->Translate(centre.x(), centre.y(), centre.z());
  impl_->shape->Scale(semi_axes.x(), semi_axes.y(), semi_axes.z());
  impl_->filter->SetInputConnection(impl_->sphere->GetOutputPort());
  impl_->filter->SetTransform(impl_->shape);
  impl_->mapper->SetInputConnection(impl_->filter->GetOutputPort());
  impl_->actor->SetMapper(impl_->mapper);
  set_color(0.85, 0.15, 0.15, 0.45);
}

EllipsoidView::~EllipsoidView() = default;

void EllipsoidView::set_color(double r, double g, double b, double opacity) {
  impl_->actor->GetProperty()->SetColor(r, g, b);
  impl_->actor->GetProperty()->SetOpacity(opacity);
}

void EllipsoidView::set_transform(const Eigen::Matrix4d& m) {
  vtkNew<vtkMatrix4x4> vm;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) vm->SetElement(r, c, m(r, c));
  impl_->actor->SetUserMatrix(vm);
}

vtkActor* EllipsoidView::actor() const { return impl_->actor; }

std::array<double, 6> EllipsoidView::bounds() const {
  const double* b = impl_->actor->GetBounds();
  if (!b) return {1, -1, 1, -1, 1, -1};
  return {b[0], b[1], b[2], b[3], b[4], b[5]};
}

void EllipsoidView::add_to(vtkRenderer* renderer) const { renderer->AddActor(impl_->actor); }
void EllipsoidView::remove_from(vtkRenderer* renderer) const { renderer->RemoveActor(impl_->actor); }

}  // namespace palpa::render
