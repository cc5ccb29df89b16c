// Offscreen scene and camera placement.

#include "render/scene.h"

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkObjectFactory.h>
#include <vtkOpenGLRenderer.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <algorithm>
#include <cmath>

namespace palpa::render {

void frame_camera(vtkRenderer* renderer, const std::array<double, 6>& b, const Vec3& view_dir, const Vec3& up) {
  const Vec3 c(0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]), 0.5 * (b[4] + b[5]));
  const double radius = 0.5 * Vec3(b[1] - b[0], b[3] - b[2], b[5] - b[4]).norm();
  const Vec3 d = view_dir.norm() > 0 ? Vec3(view_dir.normalized()) : Vec3::UnitZ();
  vtkCamera* cam = renderer->GetActiveCamera();
  cam->SetFocalPoint(c.data());
  // Far enough for the bounding sphere to fit the view angle, vertically and
  // horizontally (narrow viewports).
  double half = 0.5 * cam->GetViewAngle() * M_PI / 180.0;
  const int* size = renderer->GetSize();
  if (size && size[0] > 0 && size[1] > 0 && size[0] < size[1])
    half = std::atan(std::tan(half) * size[0] / static_cast<double>(size[1]));
  const double dist = std::max(radius, 1e-6) / std::sin(half);
  const Vec3 eye = c + dist * d;
  cam->SetPosition(eye.data());
  Vec3 u = up - up.dot(d) * d;
  if (u.norm() < 1e-9) u = std::abs(d.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitY();
  cam->SetViewUp(u.normalized().data());
  renderer->ResetCameraClippingRange();
}

void style_renderer(vtkRenderer* renderer) {
  renderer->SetBackground(0.10, 0.11, 0.14);
  renderer->SetBackground2(0.25, 0.27, 0.32);
  renderer->GradientBackgroundOff();
  renderer->AutomaticLightCreationOn();  // one headlight
}

namespace {

// VTK's OpenGL renderer, optionally drawing translucent props with plain
// alpha blending in prop order instead of VTK 9.1's order-independent
// translucency, whose extra full-frame passes (two float accumulation
// targets, a depth copy, a composite) cost llvmpipe about as much as the
// organ itself at 1280x720.
class BlendingRenderer : public vtkOpenGLRenderer {
 public:
  static BlendingRenderer* New();
  vtkTypeMacro(BlendingRenderer, vtkOpenGLRenderer);
  bool plain = false;
  void DeviceRenderTranslucentPolygonalGeometry(vtkFrameBufferObjectBase* fbo) override {
    if (!plain) {
      Superclass::DeviceRenderTranslucentPolygonalGeometry(fbo);
      return;
    }
    this->LastRenderingUsedDepthPeeling = 0;
    this->UpdateTranslucentPolygonalGeometry();
  }
};
vtkStandardNewMacro(BlendingRenderer);

}  // namespace

struct OffscreenScene::Impl {
  OffscreenWindow window;
  vtkSmartPointer<BlendingRenderer> renderer = vtkSmartPointer<BlendingRenderer>::New();
  Impl(int w, int h, GlBackend b) : window(w, h, b) {}
};

OffscreenScene::OffscreenScene(int width, int height, GlBackend backend)
    : impl_(std::make_unique<Impl>(width, height, backend)) {
  style_renderer(impl_->renderer);
  impl_->window.window()->AddRenderer(impl_->renderer);
}

// The window (destroyed last) releases every prop's GL resources.
OffscreenScene::~OffscreenScene() = default;

OffscreenWindow& OffscreenScene::window() { return impl_->window; }
vtkRenderer* OffscreenScene::renderer() const { return impl_->renderer; }
void OffscreenScene::add(vtkActor* actor) { impl_->renderer->AddActor(actor); }

void OffscreenScene::set_plain_blending(bool on) { impl_->renderer->plain = on; }

void OffscreenScene::look_at(const std::array<double, 6>& bounds, const Vec3& view_dir, const Vec3& up) {
  frame_camera(impl_->renderer, bounds, view_dir, up);
}

void OffscreenScene::render() {
  impl_->renderer->ResetCameraClippingRange();
  impl_->window.render();
}

Image OffscreenScene::render_image() {
  impl_->renderer->ResetCameraClippingRange();
  impl_->window.render();
  return impl_->window.capture();
}

}  // namespace palpa::render
