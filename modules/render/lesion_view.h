#pragma once
// Inclusions drawn inside the organ: translucent ellipsoids for lesions an
// educator shows (tissue::Visibility::Shown, or after the exam). Hidden
// lesions are never given to this view, so a picture with and without them
// is the same.

#include "core/types.h"

#include <array>
#include <memory>

class vtkActor;
class vtkRenderer;

namespace palpa::render {

class EllipsoidView {
 public:
  /// An ellipsoid at `centre` (m) with semi-axes along x, y, z (m).
  EllipsoidView(const Vec3& centre, const Vec3& semi_axes);
  ~EllipsoidView();
  EllipsoidView(const EllipsoidView&) = delete;
  EllipsoidView& operator=(const EllipsoidView&) = delete;

  /// Colour (RGB in 0..1) and opacity (0..1; default a translucent red).
  void set_color(double r, double g, double b, double opacity);
  /// Organ frame -> world, row-major 4x4 (breathing); identity by default.
  void set_transform(const Eigen::Matrix4d& organ_to_world);
  vtkActor* actor() const;
  /// World bounds of the ellipsoid as drawn, {xmin, xmax, ...}, m.
  std::array<double, 6> bounds() const;
  void add_to(vtkRenderer* renderer) const;
  void remove_from(vtkRenderer* renderer) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpa::render
