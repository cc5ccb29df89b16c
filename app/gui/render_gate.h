#pragma once
// Draws the viewport only when something in it changed, so an idle window
// costs (almost) nothing. A change is either announced (mark(): the surface
// stream brought changed entries, a new organ) or seen: the redraw time of a
// renderer of the window, of its camera and lights, or of any of its props
// (an actor's redraw time covers its property, matrix, mapper and input:
// probe glyphs moving, lesions shown, the camera turned by the mouse) is
// newer than at the last draw. Window events (expose, resize) are drawn by
// the VTK widget itself.

#include <vtkType.h>

#include <cstdint>

class vtkRenderWindow;

namespace palpa::app {

class RenderGate {
 public:
  explicit RenderGate(vtkRenderWindow* window) : window_(window) {}

  /// The next draw_if_needed() draws.
  void mark() { pending_ = true; }
  /// Draws when marked or when the scene changed since the last draw;
  /// returns whether it drew.
  bool draw_if_needed();
  /// Draws now.
  void draw();
  /// Draws made through the gate.
  std::uint64_t draws() const { return draws_; }

  /// The newest redraw time in the window's renderers.
  vtkMTimeType scene_time() const;

 private:
  vtkRenderWindow* window_;
  bool pending_ = true;
  bool settling_ = false;  // the last draw was the one after a draw that adjusted the scene
  vtkMTimeType drawn_at_ = 0;
  std::uint64_t draws_ = 0;
};

}  // namespace palpa::app
