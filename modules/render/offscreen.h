#pragma once
// Rendering with no display server. Debian 12's VTK 9.1 has only an X/GLX
// window, but it renders into any OpenGL context made current by someone
// else through vtkGenericOpenGLRenderWindow. This is the one place where
// Palpa creates such contexts:
//
//  - OSMesa (software, llvmpipe): the default where no GPU is present. Needs
//    libOSMesa linked before libGL (palpa_link_osmesa_first() in CMake), so
//    VTK's direct GL 1.1 calls reach the OSMesa context, and GLEW's
//    glXGetProcAddressARB answered by OSMesaGetProcAddress.
//  - EGL (surfaceless Mesa, or a GPU through EGL_EXT_platform_device): the
//    default where a hardware EGL device is present. Core 3.2 context, no
//    surface, VTK told not to blit to a default framebuffer.
//
// Both need a glewInit() that accepts GLEW's two GLX-only error codes (GLEW
// is built for GLX and fails in glxewInit() after having loaded every GL
// entry point). offscreen.cpp interposes glewInit and glXGetProcAddressARB
// for the whole process (exported from the executable); they behave exactly
// like the originals unless one of our offscreen contexts is current on the
// calling thread (and glXGetProcAddressARB only differs for OSMesa).
// GLEW's entry points are process-wide, so one backend at a time: creating a
// window of one backend while a window of the other is alive is refused.
// Multisampling is off: on llvmpipe it costs about 4x for no visible gain.
//
// Which executables link what: palpa-render, the render and render-job tests and
// palpa-render-bench link OSMesa first (OSMesa default; EGL works there
// with Mesa drivers only). palpa (Qt) and palpa-render-bench-gpu do not:
// there EGL serves both llvmpipe and GPUs, and OSMesa is refused clearly.

#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "render/image.h"

class vtkRenderWindow;

namespace palpa::render {

/// A rendering failure the user can act on (no context, bad option, a file
/// that cannot be written). The message names the backend or file.
class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Which offscreen OpenGL implementation to use.
enum class GlBackend : unsigned char {
  Auto = 0,    ///< EGL on a hardware device if present, else OSMesa if linked first, else EGL surfaceless
  OSMesa = 1,  ///< Mesa's off-screen software renderer
  Egl = 2,     ///< EGL with no surface (Mesa surfaceless or a GPU device)
};

/// "auto", "osmesa" or "egl" (case-sensitive). Throws RenderError:
/// "unknown GL backend 'NAME' (expected auto, osmesa or egl)".
GlBackend parse_gl_backend(std::string_view name);
std::string_view gl_backend_name(GlBackend backend);

/// True when libOSMesa is loaded and its glGetString is the one the process
/// resolves (the executable was linked with palpa_link_osmesa_first()).
bool osmesa_linked_first();

/// True when EGL offers a hardware (non-software) device.
bool egl_hardware_device_present();

/// What GlBackend::Auto resolves to in this process; `reason` (optional)
/// says why. The environment variable PALPA_GL (auto, osmesa, egl)
/// overrides Auto.
GlBackend resolve_gl_backend(GlBackend requested, std::string* reason = nullptr);

/// An OpenGL context with no window system, wrapped in a
/// vtkGenericOpenGLRenderWindow with multisampling off. Add renderers to
/// window(), then render() and capture().
class OffscreenWindow {
 public:
  /// Creates the context (width x height pixels). Throws RenderError naming
  /// the backend and what failed.
  OffscreenWindow(int width, int height, GlBackend backend = GlBackend::Auto);
  ~OffscreenWindow();
  OffscreenWindow(const OffscreenWindow&) = delete;
  OffscreenWindow& operator=(const OffscreenWindow&) = delete;

  /// The backend actually in use (never Auto).
  GlBackend backend() const;
  /// GL_RENDERER and GL_VERSION of the context.
  const std::string& gl_renderer() const;
  const std::string& gl_version() const;

  /// The VTK render window (a vtkGenericOpenGLRenderWindow).
  vtkRenderWindow* window() const;
  int width() const;
  int height() const;

  /// Renders every renderer of the window.
  void render();
  /// Reads the last rendered frame (RGB, top row first).
  Image capture() const;
  /// Waits until OpenGL has finished drawing the frame (glFinish): a
  /// software renderer draws on its own threads after render() returns, so
  /// time taken around render() alone is only its submission.
  void finish();
  /// Hands what was drawn to OpenGL to execute (glFlush) without waiting: a
  /// software renderer starts rasterising the frame on its threads while
  /// the caller goes on (for example, drawing in another window).
  void flush();
  /// Reads the last rendered frame as RGBA, bottom row first (OpenGL's
  /// order), into `out` (width x height x 4 bytes; std::invalid_argument
  /// otherwise): no allocation, no per-pixel copy.
  void read_rgba(std::span<std::uint8_t> out);
  /// Reads the depth buffer of the last frame at display pixel (x, y)
  /// (origin bottom-left), in [0, 1].
  float depth_at(int x, int y) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpa::render
