// The offscreen backends: both make a working context with multisampling
// off, they draw the same pixels, and the choice between them is explained.

#include "render/offscreen.h"

#include "render/scene.h"
#include "render/surface_view.h"
#include "render_test_support.h"

#include <vtkRenderWindow.h>

#include <cstdlib>

namespace palpa::render {
namespace {

// Renders the dented sphere of the image tests with one backend.
Image dented_sphere(GlBackend backend) {
  test::DentScene dent(0.006);
  dent.settle(0.3);
  OffscreenScene scene(200, 160, backend);
  SurfaceView view(dent.mesh);
  view.sync(*dent.surface);
  scene.add(view.actor());
  scene.look_at(view.bounds(), Vec3(0, -1, 1.2), Vec3::UnitZ());
  return scene.render_image();
}

TEST(Offscreen, BackendNamesParseAndUnknownOnesAreRefused) {
  EXPECT_EQ(parse_gl_backend("auto"), GlBackend::Auto);
  EXPECT_EQ(parse_gl_backend("osmesa"), GlBackend::OSMesa);
  EXPECT_EQ(parse_gl_backend("egl"), GlBackend::Egl);
  EXPECT_EQ(gl_backend_name(GlBackend::Egl), "egl");
  try {
    parse_gl_backend("glx");
    FAIL() << "no error";
  } catch (const RenderError& e) {
    EXPECT_STREQ(e.what(), "unknown GL backend 'glx' (expected auto, osmesa or egl)");
  }
}

TEST(Offscreen, OSMesaContextIsCoreWithoutMultisampling) {
  ASSERT_TRUE(osmesa_linked_first()) << "this test executable links OSMesa first (palpa_link_osmesa_first)";
  OffscreenWindow w(64, 48, GlBackend::OSMesa);
  EXPECT_EQ(w.backend(), GlBackend::OSMesa);
  EXPECT_FALSE(w.gl_renderer().empty());
  EXPECT_NE(w.gl_version().find("Core Profile"), std::string::npos) << w.gl_version();
  EXPECT_EQ(w.window()->GetMultiSamples(), 0);
  EXPECT_EQ(w.capture().width, 64);
  EXPECT_EQ(w.capture().height, 48);
}

TEST(Offscreen, EglContextIsCoreWithoutMultisampling) {
  std::unique_ptr<OffscreenWindow> w;
  try {
    w = std::make_unique<OffscreenWindow>(64, 48, GlBackend::Egl);
  } catch (const RenderError& e) {
    GTEST_SKIP() << "no EGL context on this machine: " << e.what();
  }
  EXPECT_EQ(w->backend(), GlBackend::Egl);
  EXPECT_NE(w->gl_version().find("Core Profile"), std::string::npos) << w->gl_version();
  EXPECT_EQ(w->window()->GetMultiSamples(), 0);
}

TEST(Offscreen, OSMesaAndEglDrawTheSamePixels) {
  const Image osmesa = dented_sphere(GlBackend::OSMesa);
  Image egl;
  try {
    egl = dented_sphere(GlBackend::Egl);
  } catch (const RenderError& e) {
    GTEST_SKIP() << "no EGL context on this machine: " << e.what();
  }
  if (egl_hardware_device_present()) {
    // A GPU rasterises differently from llvmpipe; stay close, not identical.
    EXPECT_LE(test::max_difference(osmesa, egl), 8);
  } else {
    EXPECT_EQ(test::max_difference(osmesa, egl), 0);
  }
}

TEST(Offscreen, AutoPrefersAGpuThenOSMesaAndPalpaGlOverrides) {
  unsetenv("PALPA_GL");
  std::string why;
  const GlBackend expected = egl_hardware_device_present() ? GlBackend::Egl : GlBackend::OSMesa;
  EXPECT_EQ(resolve_gl_backend(GlBackend::Auto, &why), expected) << why;
  EXPECT_FALSE(why.empty());
  setenv("PALPA_GL", "egl", 1);
  EXPECT_EQ(resolve_gl_backend(GlBackend::Auto, &why), GlBackend::Egl);
  EXPECT_EQ(why, "PALPA_GL");
  EXPECT_EQ(resolve_gl_backend(GlBackend::OSMesa, &why), GlBackend::OSMesa) << "explicit requests win";
  setenv("PALPA_GL", "vulkan", 1);
  EXPECT_THROW(resolve_gl_backend(GlBackend::Auto), RenderError);
  unsetenv("PALPA_GL");
}

TEST(Offscreen, TwoBackendsAtOnceAreRefused) {
  OffscreenWindow first(32, 32, GlBackend::OSMesa);
  try {
    OffscreenWindow second(32, 32, GlBackend::Egl);
    FAIL() << "no error";
  } catch (const RenderError& e) {
    EXPECT_STREQ(e.what(),
                 "offscreen window (egl): an osmesa window is still open; GLEW's GL entry points are shared by the "
                 "whole process, so use one backend at a time");
  }
  OffscreenWindow same(32, 32, GlBackend::OSMesa);  // more of the same backend are fine
  EXPECT_EQ(same.backend(), GlBackend::OSMesa);
}

TEST(Offscreen, ImpossibleSizesAreRefused) {
  try {
    OffscreenWindow w(0, 10);
    FAIL() << "no error";
  } catch (const RenderError& e) {
    EXPECT_STREQ(e.what(), "offscreen window: size 0x10 is outside 1..16384");
  }
}

}  // namespace
}  // namespace palpa::render
