// Offscreen scene and camera placement.

#include "render/scene.h"

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkMatrix4x4.h>
#include <vtkObjectFactory.h>
#include <vtkOpenGLRenderer.h>
#include <vtkRenderWindow.h>
#include <vtkRect.h>
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
  bool held = false;            // hold_clipping_range() was called
  std::array<double, 6> box{};  // the held range's box, m
  Impl(int w, int h, GlBackend b) : window(w, h, b) {}

  // Sets the clipping range for this render; true when a held box had to grow.
  bool update_clipping() {
    if (!held) {
      renderer->ResetCameraClippingRange();
      return false;
    }
    const bool grew = grow_box();
    renderer->ResetCameraClippingRange(box.data());
    return grew;
  }
  bool grow_box() {
    double b[6];
    renderer->ComputeVisiblePropBounds(b);
    bool grew = false;
    if (b[0] <= b[1] && b[2] <= b[3] && b[4] <= b[5]) {
      for (int k = 0; k < 3; ++k)
        if (b[2 * k] < box[2 * k] || b[2 * k + 1] > box[2 * k + 1]) grew = true;
      if (grew) {
        for (int k = 0; k < 3; ++k) {
          box[2 * k] = std::min(box[2 * k], b[2 * k]);
          box[2 * k + 1] = std::max(box[2 * k + 1], b[2 * k + 1]);
        }
        pad_box();
      }
    }
    return grew;
  }
  void pad_box() {
    const double d = 0.1 * std::sqrt((box[1] - box[0]) * (box[1] - box[0]) + (box[3] - box[2]) * (box[3] - box[2]) +
                                     (box[5] - box[4]) * (box[5] - box[4]));
    for (int k = 0; k < 3; ++k) {
      box[2 * k] -= d;
      box[2 * k + 1] += d;
    }
  }
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
  impl_->update_clipping();
  impl_->window.render();
}

bool OffscreenScene::render(const PixelRect& region) {
  Impl& m = *impl_;
  if (m.update_clipping()) {
    m.window.render();
    return false;
  }
  const PixelRect r{std::max(region.x0, 0), std::max(region.y0, 0), std::min(region.x1, m.window.width()),
                    std::min(region.y1, m.window.height())};
  if (r.empty()) return true;
  // VTK's camera sets this scissor for its next render only (and clears
  // within it): every pass of the frame then draws inside it.
  vtkCamera* cam = m.renderer->GetActiveCamera();
  cam->SetScissorRect(vtkRecti(r.x0, r.y0, r.x1 - r.x0, r.y1 - r.y0));
  cam->SetUseScissor(true);
  m.window.render();
  cam->SetUseScissor(false);
  return true;
}

void OffscreenScene::hold_clipping_range(const std::array<double, 6>& box) {
  impl_->held = true;
  impl_->box = box;
}

bool OffscreenScene::take_in_visible_props() { return impl_->held && impl_->grow_box(); }

std::array<double, 6> OffscreenScene::clipping_box() const { return impl_->box; }

PixelProjection OffscreenScene::projection() const {
  Impl& m = *impl_;
  const int w = m.window.width(), h = m.window.height();
  vtkMatrix4x4* c = m.renderer->GetActiveCamera()->GetCompositeProjectionTransformMatrix(
      static_cast<double>(w) / std::max(h, 1), -1, 1);
  Eigen::Matrix4d mat;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) mat(i, j) = c->GetElement(i, j);
  return PixelProjection(mat, w, h);
}

Image OffscreenScene::render_image() {
  impl_->update_clipping();
  impl_->window.render();
  return impl_->window.capture();
}

}  // namespace palpa::render
