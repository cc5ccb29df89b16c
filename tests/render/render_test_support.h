#pragma once
// Shared fixtures for the image tests: a sphere dented by one contact with
// the core's physics, the screen footprint of the deformed region, image
// comparison.

#include "common/test_support.h"
#include "deform/surface.h"
#include "mesh/generate.h"
#include "render/image.h"

#include <vtkRenderer.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

namespace palpa::render::test {

/// A sphere (m) with one contact pressed into its highest vertex and the
/// core's surface settled under it (linear material, Wendland field).
struct DentScene {
  std::shared_ptr<mesh::SurfaceMesh> mesh;
  std::unique_ptr<deform::DeformableSurface> surface;
  Index top = 0;
  deform::Contact contact;

  explicit DentScene(double depth = 0.005, const Vec3& center = Vec3::Zero(), double radius = 0.05,
                     std::size_t vertices = 20000, deform::ShapeKind shape = deform::ShapeKind::Wendland) {
    mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(vertices, radius, center));
    for (Index i = 1; i < mesh->vertex_count(); ++i)
      if (mesh->positions[i].z() > mesh->positions[top].z()) top = i;
    deform::Material m;
    m.model = deform::LocalModelKind::Linear;
    m.mass = 1e-3;
    m.damping = 2.0;
    m.stiffness = 200.0;
    surface = std::make_unique<deform::DeformableSurface>(
        mesh, deform::MaterialArrays::uniform(mesh->vertex_count(), m));
    contact.point = mesh->positions[top];
    contact.normal = mesh->normals[top];
    contact.vertex = top;
    contact.depth = depth;
    contact.shape = deform::ShapeFunction{shape, 0.02};
  }

  /// Presses the contact for `seconds` of simulated time (1 ms steps).
  void settle(double seconds = 0.5) {
    surface->set_contacts(std::span(&contact, 1));
    for (int s = 0; s < static_cast<int>(seconds / 1e-3); ++s) surface->step(1e-3);
  }
};

/// The CPU reference: the core's deformed surface (deformed_position and
/// deformed_normal, eq. 2 and 3 in double) as an ordinary mesh. Drawn with
/// UploadPath::CpuDisplaced and no stream, VTK's unmodified mapper shows it.
inline std::shared_ptr<mesh::SurfaceMesh> core_reference_mesh(const deform::DeformableSurface& s) {
  auto m = std::make_shared<mesh::SurfaceMesh>(s.mesh());
  for (Index i = 0; i < m->vertex_count(); ++i) {
    m->positions[i] = s.deformed_position(i);
    m->normals[i] = s.deformed_normal(i);
  }
  return m;
}

/// Pixel (column x, row y from the top) of world point p in `renderer`'s
/// viewport of a width x height window.
inline Eigen::Vector2d to_pixel(vtkRenderer* renderer, const Vec3& p, int height) {
  renderer->SetWorldPoint(p.x(), p.y(), p.z(), 1.0);
  renderer->WorldToDisplay();
  double d[3];
  renderer->GetDisplayPoint(d);
  return {d[0], height - d[1]};
}

/// Mask (1 per pixel, rows from the top) of the pixels that triangles with a
/// vertex whose stream entry is non-zero can cover, in either of two
/// states, grown by `margin` pixels: the only pixels a deformation may change.
inline std::vector<std::uint8_t> footprint(vtkRenderer* renderer, const mesh::SurfaceMesh& mesh,
                                           std::span<const float> stream, int width, int height,
                                           const std::vector<Vec3>& deformed, int margin = 2) {
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(width) * height, 0);
  auto moved = [&](Index i) {
    for (int k = 0; k < 4; ++k)
      if (stream[4 * i + k] != 0.f) return true;
    return false;
  };
  for (const auto& t : mesh.triangles) {
    if (!moved(t[0]) && !moved(t[1]) && !moved(t[2])) continue;
    double x0 = 1e30, x1 = -1e30, y0 = 1e30, y1 = -1e30;
    for (Index v : t)
      for (const Vec3& p : {mesh.positions[v], deformed[v]}) {
        const auto px = to_pixel(renderer, p, height);
        x0 = std::min(x0, px.x()), x1 = std::max(x1, px.x());
        y0 = std::min(y0, px.y()), y1 = std::max(y1, px.y());
      }
    const int xa = std::max(0, static_cast<int>(std::floor(x0)) - margin);
    const int xb = std::min(width - 1, static_cast<int>(std::ceil(x1)) + margin);
    const int ya = std::max(0, static_cast<int>(std::floor(y0)) - margin);
    const int yb = std::min(height - 1, static_cast<int>(std::ceil(y1)) + margin);
    for (int y = ya; y <= yb; ++y)
      for (int x = xa; x <= xb; ++x) mask[static_cast<std::size_t>(y) * width + x] = 1;
  }
  return mask;
}

/// Per-pixel comparison of two images of the same size, split by a mask.
struct ImageDiff {
  int max_inside = 0, max_outside = 0;          ///< largest channel difference
  long changed_inside = 0, changed_outside = 0;  ///< pixels with any difference
  double mean_grey_inside = 0;                  ///< mean |grey difference| inside the mask
  long inside = 0;                              ///< pixels in the mask
};

inline ImageDiff compare(const Image& a, const Image& b, const std::vector<std::uint8_t>& mask) {
  ImageDiff d;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const auto* p = a.at(x, y);
      const auto* q = b.at(x, y);
      int m = 0;
      for (int k = 0; k < 3; ++k) m = std::max(m, std::abs(int(p[k]) - int(q[k])));
      const bool in = mask[static_cast<std::size_t>(y) * a.width + x] != 0;
      if (in) {
        d.inside += 1;
        d.max_inside = std::max(d.max_inside, m);
        d.changed_inside += m > 0;
        d.mean_grey_inside += std::abs(a.grey(x, y) - b.grey(x, y));
      } else {
        d.max_outside = std::max(d.max_outside, m);
        d.changed_outside += m > 0;
      }
    }
  if (d.inside > 0) d.mean_grey_inside /= static_cast<double>(d.inside);
  return d;
}

/// Largest channel difference over the whole image.
inline int max_difference(const Image& a, const Image& b) {
  int m = 0;
  for (std::size_t i = 0; i < a.rgb.size(); ++i) m = std::max(m, std::abs(int(a.rgb[i]) - int(b.rgb[i])));
  return m;
}

}  // namespace palpa::render::test
