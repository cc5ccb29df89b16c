// Probe glyphs: VTK sources placed by user matrices.

#include "render/probe_view.h"

#include <Eigen/Geometry>

#include <vtkActor.h>
#include <vtkArrowSource.h>
#include <vtkBoundingBox.h>
#include <vtkCylinderSource.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkSphereSource.h>

#include <algorithm>
#include <cmath>

namespace palpa::render {
namespace {

// A matrix that maps the unit x axis to `dir` scaled by `length`, with the
// other axes scaled by `width`, and the origin to `origin`.
void place_along(vtkMatrix4x4* m, const Vec3& origin, const Vec3& dir, double length, double width) {
  const Vec3 x = dir.normalized();
  const Vec3 helper = std::abs(x.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
  const Vec3 y = helper.cross(x).normalized();
  const Vec3 z = x.cross(y);
  m->Identity();
  for (int r = 0; r < 3; ++r) {
    m->SetElement(r, 0, x[r] * length);
    m->SetElement(r, 1, y[r] * width);
    m->SetElement(r, 2, z[r] * width);
    m->SetElement(r, 3, origin[r]);
  }
}

}  // namespace

struct ProbeView::Impl {
  double tip_radius, shaft_length;
  double force_scale = 10e-3;  // m per N
  vtkSmartPointer<vtkActor> tip, shaft, arrow;
  vtkNew<vtkMatrix4x4> tip_matrix, shaft_matrix, arrow_matrix;
  // The last state drawn (set_state with the same one changes nothing).
  bool has_state = false;
  Vec3 tip_at, axis, force;
  bool in_contact = false, selected = false;
  double scale_at = 0;
};

ProbeView::ProbeView(double tip_radius, double shaft_length) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.tip_radius = tip_radius;
  m.shaft_length = shaft_length;

  // Tip: a unit sphere scaled by the matrix.
  vtkNew<vtkSphereSource> sphere;
  sphere->SetRadius(1.0);
  sphere->SetThetaResolution(24);
  sphere->SetPhiResolution(16);
  vtkNew<vtkPolyDataMapper> tip_mapper;
  tip_mapper->SetInputConnection(sphere->GetOutputPort());
  m.tip = vtkSmartPointer<vtkActor>::New();
  m.tip->SetMapper(tip_mapper);
  m.tip->SetUserMatrix(m.tip_matrix);

  // Shaft: a cylinder along x from 0 to 1 (VTK's is along y, centred).
  vtkNew<vtkCylinderSource> cylinder;
  cylinder->SetResolution(16);
  cylinder->SetRadius(0.5);
  cylinder->SetHeight(1.0);
  cylinder->SetCenter(0, 0.5, 0);
  vtkNew<vtkPolyDataMapper> shaft_mapper;
  shaft_mapper->SetInputConnection(cylinder->GetOutputPort());
  m.shaft = vtkSmartPointer<vtkActor>::New();
  m.shaft->SetMapper(shaft_mapper);
  m.shaft->SetUserMatrix(m.shaft_matrix);
  m.shaft->GetProperty()->SetColor(0.75, 0.75, 0.78);
  m.shaft->GetProperty()->SetOpacity(0.6);

  // Force arrow: VTK's arrow points along +x from 0 to 1.
  vtkNew<vtkArrowSource> arrow_source;
  arrow_source->SetTipResolution(16);
  arrow_source->SetShaftResolution(16);
  vtkNew<vtkPolyDataMapper> arrow_mapper;
  arrow_mapper->SetInputConnection(arrow_source->GetOutputPort());
  m.arrow = vtkSmartPointer<vtkActor>::New();
  m.arrow->SetMapper(arrow_mapper);
  m.arrow->SetUserMatrix(m.arrow_matrix);
  m.arrow->GetProperty()->SetColor(0.95, 0.85, 0.15);
  m.arrow->VisibilityOff();
}

ProbeView::~ProbeView() = default;

void ProbeView::set_force_scale(double metres_per_newton) { impl_->force_scale = metres_per_newton; }

void ProbeView::set_colour(const Vec3& rgb) { impl_->shaft->GetProperty()->SetColor(rgb.x(), rgb.y(), rgb.z()); }

Vec3 ProbeView::colour() const {
  const double* c = impl_->shaft->GetProperty()->GetColor();
  return {c[0], c[1], c[2]};
}

bool ProbeView::set_state(const Vec3& tip, const Vec3& axis, const Vec3& force, bool in_contact, bool selected) {
  Impl& m = *impl_;
  if (m.has_state && m.tip_at == tip && m.axis == axis && m.force == force && m.in_contact == in_contact &&
      m.selected == selected && m.scale_at == m.force_scale)
    return false;
  m.has_state = true;
  m.tip_at = tip;
  m.axis = axis;
  m.force = force;
  m.in_contact = in_contact;
  m.selected = selected;
  m.scale_at = m.force_scale;
  // The shaft rotates the x axis onto `axis`; the sphere only needs scale and position.
  const Vec3 a = axis.norm() > 0 ? Vec3(axis.normalized()) : Vec3::UnitZ();
  place_along(m.shaft_matrix, tip, a, m.shaft_length, m.tip_radius * 0.8);
  place_along(m.tip_matrix, tip, a, m.tip_radius, m.tip_radius);
  m.shaft_matrix->Modified();
  m.tip_matrix->Modified();
  // Tip colour: red in contact, blue hovering; brighter when selected.
  const double k = selected ? 1.0 : 0.6;
  if (in_contact)
    m.tip->GetProperty()->SetColor(0.95 * k, 0.2 * k, 0.15 * k);
  else
    m.tip->GetProperty()->SetColor(0.2 * k, 0.45 * k, 0.95 * k);

  // Arrow: from the tip along the force, length proportional to |F|.
  const double f = force.norm();
  if (f > 1e-9 && std::isfinite(f)) {
    const double len = std::min(f * m.force_scale, 3 * m.shaft_length);
    place_along(m.arrow_matrix, tip, force / f, len, std::max(len, 8 * m.tip_radius));
    m.arrow_matrix->Modified();
    m.arrow->SetVisibility(m.tip->GetVisibility());
  } else {
    m.arrow->VisibilityOff();
  }
  return true;
}

std::array<double, 6> ProbeView::bounds() const {
  vtkBoundingBox box;  // invalid (min > max) until a visible actor adds its bounds
  for (vtkActor* a : {impl_->tip.Get(), impl_->shaft.Get(), impl_->arrow.Get()})
    if (a->GetVisibility())
      if (const double* ab = a->GetBounds(); ab && vtkBoundingBox::IsValid(ab)) box.AddBounds(ab);
  std::array<double, 6> b;
  box.GetBounds(b.data());
  return b;
}

void ProbeView::set_visible(bool visible) {
  if (impl_->tip->GetVisibility() != static_cast<int>(visible)) impl_->has_state = false;  // the arrow follows
  impl_->tip->SetVisibility(visible);
  impl_->shaft->SetVisibility(visible);
  if (!visible) impl_->arrow->VisibilityOff();
}

void ProbeView::add_to(vtkRenderer* renderer) {
  renderer->AddActor(impl_->tip);
  renderer->AddActor(impl_->shaft);
  renderer->AddActor(impl_->arrow);
}

void ProbeView::remove_from(vtkRenderer* renderer) {
  renderer->RemoveActor(impl_->tip);
  renderer->RemoveActor(impl_->shaft);
  renderer->RemoveActor(impl_->arrow);
}

}  // namespace palpa::render
