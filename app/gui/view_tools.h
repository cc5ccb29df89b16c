#pragma once
// The View menu's camera tools: standard views of the organ (the organ frame
// read as 3D Slicer's RAS: x towards the patient's right, y anterior, z
// superior) and the orientation marker (axes in a corner of the viewport,
// as in Slicer and ParaView).

#include "core/types.h"

#include <QString>

#include <array>
#include <memory>

class vtkRenderer;
class vtkRenderWindowInteractor;

namespace palpa::app {

enum class StandardView { Anterior, Posterior, Left, Right, Superior, Inferior };

/// "Anterior", ...
QString standard_view_name(StandardView v);
/// From the organ's centre towards the eye, and the view's up direction.
Vec3 standard_view_direction(StandardView v);
Vec3 standard_view_up(StandardView v);
/// Frames `bounds` (m) in `renderer` from that side.
void set_standard_view(vtkRenderer* renderer, const std::array<double, 6>& bounds, StandardView v);

/// Axes (x red, y green, z yellow, labelled R, A, S... as VTK draws X, Y, Z)
/// in the lower left corner, turning with the camera.
class OrientationMarker {
 public:
  OrientationMarker();
  ~OrientationMarker();
  OrientationMarker(const OrientationMarker&) = delete;
  OrientationMarker& operator=(const OrientationMarker&) = delete;
  /// Shows or hides it in the viewport of `interactor` (set once, then toggled).
  void set_enabled(vtkRenderWindowInteractor* interactor, bool on);
  bool enabled() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpa::app
