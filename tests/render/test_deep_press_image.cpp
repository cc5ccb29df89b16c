// After a deep press on a small organ the picture shows no back face (a
// surface turned inside out draws its inside: the "black hole"). The press
// runs through the haptic tick and the deformation step as a session does;
// the surface is drawn from its stream with back faces in pure red, seen
// from outside along the contact normal, and the red pixels are counted.
// Without the drawn-displacement limit the same press does show them.

#include "haptics/probe_tick.h"
#include "render/offscreen.h"
#include "render/scene.h"
#include "render/surface_view.h"
#include "render_test_support.h"

#include "mesh/io.h"

#include <Eigen/Geometry>
#include <vtkActor.h>
#include <vtkNew.h>
#include <vtkProperty.h>

#include <cstdio>
#include <cstdlib>
#include <memory>

namespace palpa::render {
namespace {

constexpr int kSize = 300;  // pixels

struct Pressed {
  std::shared_ptr<const mesh::SurfaceMesh> mesh;
  std::unique_ptr<deform::DeformableSurface> surface;
  Vec3 normal = Vec3::UnitZ();
};

// Presses vertex v in along its normal to `depth` (m) over 1 s and holds it
// 0.5 s: the workbench's material and shape (200 N/m, 25 mm Wendland),
// haptic tick at 1 kHz, a deformation step per tick.
Pressed press(std::shared_ptr<const mesh::SurfaceMesh> m, Index v, double depth, const deform::SurfaceOptions& o) {
  Pressed p;
  p.mesh = std::move(m);
  deform::Material mat;
  mat.model = deform::LocalModelKind::Linear;
  mat.stiffness = 200;
  mat.damping = 2;
  mat.mass = 1e-3;
  p.surface = std::make_unique<deform::DeformableSurface>(
      p.mesh, deform::MaterialArrays::uniform(p.mesh->vertex_count(), mat), o);
  const collision::VertexTree tree(p.mesh->positions);
  haptics::ForceParams fp;
  fp.friction = 0.2;
  fp.max_force = 8;
  const deform::ShapeFunction shape{deform::ShapeKind::Wendland, 0.025};
  const Vec3 p0 = p.mesh->positions[v];
  p.normal = p.mesh->normals[v];
  haptics::ProbeMemory memory;
  for (int k = 0; k <= 1500; ++k) {
    const double d = -0.001 + (depth + 0.001) * std::min(1.0, k / 1000.0);
    const haptics::ProbeInput in{p0 - d * p.normal, Vec3::Zero()};
    haptics::ProbeOutput out;
    haptics::haptic_tick(*p.surface, tree, std::span(&in, 1), std::span(&memory, 1), std::span(&out, 1), fp,
                         shape);
    if (k > 100) {
      EXPECT_TRUE(out.in_contact) << "tick " << k;
    }
    p.surface->set_contacts(std::span(&out.contact, out.in_contact ? 1 : 0));
    p.surface->step(1e-3);
  }
  return p;
}

// Draws the surface from its stream (as the workbench does) with back faces
// pure red, unlit, seen from outside along `normal`; counts red pixels.
long back_face_pixels(const Pressed& p, const char* png) {
  OffscreenScene scene(kSize, kSize);
  SurfaceView view(p.mesh);
  view.sync(*p.surface);
  view.set_color(0.2, 0.6, 0.9);
  vtkNew<vtkProperty> back;
  back->SetColor(1, 0, 0);
  back->SetAmbient(1);
  back->SetDiffuse(0);
  back->SetSpecular(0);
  view.actor()->SetBackfaceProperty(back);
  scene.add(view.actor());
  scene.look_at(view.bounds(), p.normal, p.normal.unitOrthogonal());
  const Image img = scene.render_image();
  // PALPA_TEST_PNG=1 keeps the pictures in the working folder.
  if (std::getenv("PALPA_TEST_PNG")) write_png(img, png);
  // Red pixels inside the picture of the organ: a pixel on the silhouette
  // (next to the background) may show the sliver of a back-facing triangle
  // just behind the outline edge that it shares with a front one; a surface
  // turned inside out shows red inside the outline.
  const std::uint8_t* bg = img.at(0, 0);
  auto background = [&](int x, int y) {
    const auto* c = img.at(x, y);
    return c[0] == bg[0] && c[1] == bg[1] && c[2] == bg[2];
  };
  long red = 0;
  for (int y = 1; y + 1 < img.height; ++y)
    for (int x = 1; x + 1 < img.width; ++x) {
      const auto* c = img.at(x, y);
      if (!(c[0] > 200 && c[1] < 40 && c[2] < 40)) continue;
      bool outline = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) outline = outline || background(x + dx, y + dy);
      red += !outline;
    }
  return red;
}

deform::SurfaceOptions unlimited() {
  deform::SurfaceOptions o;
  o.limit_drawn_displacement = false;
  return o;
}

// Presses at three vertices, 10 and 20 mm deep: no back face with the
// limit; the sum without it must show some (so the check can fail).
void expect_no_back_faces(const std::shared_ptr<const mesh::SurfaceMesh>& m, const char* what) {
  long without_total = 0;
  for (Index v : {Index(0), static_cast<Index>(m->vertex_count() / 3), static_cast<Index>(2 * m->vertex_count() / 3)}) {
    for (double depth : {0.01, 0.02}) {
      const long limited = back_face_pixels(press(m, v, depth, {}), "deep_press.png");
      const long without = back_face_pixels(press(m, v, depth, unlimited()), "deep_press_unlimited.png");
      std::printf("  %s, vertex %u, %.0f mm: back-face pixels %ld with the limit, %ld without\n", what, v,
                  1e3 * depth, limited, without);
      EXPECT_EQ(limited, 0) << what << ", vertex " << v << ", " << depth << " m";
      without_total += without;
    }
  }
  EXPECT_GT(without_total, 100) << what;
}

TEST(DeepPressImage, NoBackFaceShowsOnASmallOrgan) {
  // The default organ's shape at a fifth of its size: 42 x 28 x 18 mm.
  mesh::SurfaceMesh m = mesh::make_organ(10000);
  for (Vec3& p : m.positions) p *= 0.2;
  mesh::finalize(m);
  expect_no_back_faces(std::make_shared<const mesh::SurfaceMesh>(std::move(m)), "small organ");
}

TEST(DeepPressImage, NoBackFaceShowsOnTheSmallHeart) {
  // coeur1 (27 x 39 x 29 mm): the 10 mm mouse press turned it inside out.
  PALPA_REQUIRE_SHARED_ORGANS();
  mesh::LoadOptions lo;
  lo.unit_m = 1e-3;
  lo.keep_largest_component = true;
  expect_no_back_faces(std::make_shared<const mesh::SurfaceMesh>(
                           mesh::load_mesh(palpa::test::shared_organs_dir() / "sofa_coeur1.off", lo)),
                       "coeur1");
}

}  // namespace
}  // namespace palpa::render
