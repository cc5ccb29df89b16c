// The offscreen backends in an executable that does not link libOSMesa
// first (as the Qt workbench): OSMesa is refused with a clear message, Auto
// falls back to EGL, and EGL renders.

#include "render/offscreen.h"
#include "render/scene.h"
#include "render/surface_view.h"
#include "common/test_support.h"
#include "mesh/generate.h"

#include <cstdlib>

namespace palpa::render {
namespace {

TEST(OffscreenWithoutOSMesa, OSMesaIsRefusedNamingTheFix) {
  ASSERT_FALSE(osmesa_linked_first());
  try {
    OffscreenWindow w(64, 64, GlBackend::OSMesa);
    FAIL() << "no error";
  } catch (const RenderError& e) {
    EXPECT_STREQ(e.what(),
                 "OSMesa backend: libOSMesa is not linked into this executable (use palpa_link_osmesa_first() in "
                 "CMake, or the EGL backend)");
  }
}

TEST(OffscreenWithoutOSMesa, AutoChoosesEgl) {
  unsetenv("PALPA_GL");
  std::string why;
  EXPECT_EQ(resolve_gl_backend(GlBackend::Auto, &why), GlBackend::Egl) << why;
}

TEST(OffscreenWithoutOSMesa, EglRendersASphere) {
  std::unique_ptr<OffscreenScene> scene;
  try {
    scene = std::make_unique<OffscreenScene>(96, 96, GlBackend::Egl);
  } catch (const RenderError& e) {
    GTEST_SKIP() << "no EGL context on this machine: " << e.what();
  }
  SurfaceView view(std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(500, 0.05)));
  scene->add(view.actor());
  scene->look_at(view.bounds(), Vec3::UnitZ(), Vec3::UnitY());
  const Image img = scene->render_image();
  // The sphere covers the centre; the corner is background.
  EXPECT_GT(img.grey(48, 48), img.grey(2, 2) + 40);
}

}  // namespace
}  // namespace palpa::render
