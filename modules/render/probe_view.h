#pragma once
// How a probe is drawn: a small sphere at its tip, a shaft along the axis it
// presses along, and an arrow for the force it feels (eq. 4).

#include "core/types.h"

#include <array>
#include <memory>

class vtkRenderer;

namespace palpa::render {

class ProbeView {
 public:
  /// tip_radius and shaft_length in m.
  explicit ProbeView(double tip_radius = 1.5e-3, double shaft_length = 30e-3);
  ~ProbeView();
  ProbeView(const ProbeView&) = delete;
  ProbeView& operator=(const ProbeView&) = delete;

  /// tip: probe tip, m. axis: unit vector from the tip out of the surface
  /// (the shaft goes that way). force: on the probe, N (drawn from the tip,
  /// force_scale m per N, at most 3 shaft lengths). Colours say whether the
  /// probe touches the surface and whether it is the selected one. The same
  /// state again changes nothing (no VTK object is modified, so an idle
  /// window need not draw). Answers whether anything changed.
  bool set_state(const Vec3& tip, const Vec3& axis, const Vec3& force, bool in_contact, bool selected);
  /// The probe's own colour (its shaft), e.g. the colour of its trace in the
  /// force plot; RGB in [0, 1]. Default a light grey.
  void set_colour(const Vec3& rgb);
  Vec3 colour() const;
  /// Arrow length per newton, m/N.
  void set_force_scale(double metres_per_newton);
  void set_visible(bool visible);
  /// World bounds of what is drawn now (tip, shaft and arrow, those visible),
  /// {xmin, xmax, ymin, ymax, zmin, zmax} in m; empty (min > max) when none is.
  std::array<double, 6> bounds() const;

  void add_to(vtkRenderer* renderer);
  void remove_from(vtkRenderer* renderer);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpa::render
