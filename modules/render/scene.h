#pragma once
// A renderer in an offscreen window with Palpa's look (background, light),
// and camera placement shared by the headless job, the tests and the
// benchmark.

#include "core/types.h"
#include "render/offscreen.h"
#include "render/pixel_region.h"

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
  /// Renders only the pixels in `region`: they are cleared and drawn as in a
  /// whole frame, and the rest keep what the last render left. With a held
  /// clipping range (below) the pixels drawn are those of a whole frame, bit
  /// for bit; without one the range follows the props and may differ. An
  /// empty region draws nothing. Answers false, having drawn the whole frame,
  /// when the held range had to grow (its depth mapping changed everywhere).
  bool render(const PixelRect& region);
  /// Holds the camera's clipping range for `box` ({xmin, xmax, ...}, m)
  /// instead of resetting it from the visible props at every render: a
  /// frame's pixels then do not depend on where moving props are. At a
  /// render whose visible props leave the box, it grows to take them in
  /// (with a tenth of its diagonal to spare).
  void hold_clipping_range(const std::array<double, 6>& box);
  /// Grows the held box to take in every visible prop now; true when it grew
  /// (the next render then draws every pixel: call it before choosing what
  /// to draw). False when no range is held.
  bool take_in_visible_props();
  /// The held range's box now (m); meaningful after hold_clipping_range().
  std::array<double, 6> clipping_box() const;
  /// The camera's world -> pixel mapping now (after look_at()).
  PixelProjection projection() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpa::render
