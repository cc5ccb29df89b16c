#pragma once
// A renderer in an offscreen window with Palpa's look (background, light),
// and camera placement shared by the headless job, the tests and the
// benchmark.

#include "core/types.h"
#include "render/offscreen.h"

#include <array>
#include <memory>

class vtkActor;
class vtkRenderer;

namespace palpa::render {

/// Points `renderer`'s camera at the centre of `bounds` ({xmin, xmax, ...},
/// m) from direction `view_dir` (from the centre towards the eye), with the
/// whole box in view, then resets the clipping range.
void frame_camera(vtkRenderer* renderer, const std::array<double, 6>& bounds, const Vec3& view_dir, const Vec3& up);

/// Gives `renderer` Palpa's background colour and a single headlight.
void style_renderer(vtkRenderer* renderer);

/// One renderer filling an OffscreenWindow.
class OffscreenScene {
 public:
  /// Throws RenderError when no context can be made.
  OffscreenScene(int width, int height, GlBackend backend = GlBackend::Auto);
  ~OffscreenScene();

  OffscreenWindow& window();
  vtkRenderer* renderer() const;
  void add(vtkActor* actor);
  /// Draws translucent props (a probe's shaft, lesions, marks) with plain
  /// alpha blending in the order they were added, over the opaque scene,
  /// instead of VTK's order-independent translucency (off by default). A
  /// single translucent layer over opaque geometry blends the same; where
  /// translucent surfaces overlap, the later one is blended last. Software
  /// rendering is spared OIT's full-frame passes (about 15 ms CPU per
  /// 1280x720 frame on llvmpipe).
  void set_plain_blending(bool on);
  /// frame_camera() on this scene's renderer.
  void look_at(const std::array<double, 6>& bounds, const Vec3& view_dir, const Vec3& up);
  /// Renders and reads back the frame.
  Image render_image();
  /// Renders the frame (clipping range reset first, as render_image()) without
  /// reading it back: window().finish() and window().read_rgba() follow.
  void render();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpa::render
