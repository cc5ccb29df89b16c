// Offscreen OpenGL contexts (OSMesa, EGL) for VTK 9.1, and the two GL symbol
// interposers they need. See offscreen.h for why each piece exists.

#include "render/offscreen.h"

// GLEW first: it must precede every other GL header.
#include <GL/glew.h>
#include <EGL/egl.h>
#include <EGL/eglext.h>
// glew.h undefines GLAPI, which osmesa.h (types and constants only here) needs.
#ifndef GLAPI
#define GLAPI extern
#endif
#include <GL/osmesa.h>
#include <dlfcn.h>

#include <vtkAutoInit.h>
VTK_MODULE_INIT(vtkRenderingOpenGL2);
#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkFloatArray.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkNew.h>
#include <vtkSmartPointer.h>
#include <vtkUnsignedCharArray.h>

#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace palpa::render {
namespace {

// Which of our contexts is current on this thread (Auto = none of ours).
// Read by the interposers below; written only by OffscreenWindow.
thread_local GlBackend t_current_backend = GlBackend::Auto;

// Live windows per backend. GLEW's function pointers are process-wide and
// come from the backend of the last window VTK initialised, so two backends
// must not be alive at once.
int g_live_windows[3] = {0, 0, 0};

using GenericProc = void (*)();

// OSMesa entry points, looked up at run time so that executables which do not
// link libOSMesa still link (they just cannot use the OSMesa backend).
struct OSMesaApi {
  OSMesaContext (*create_context_attribs)(const int*, OSMesaContext) = nullptr;
  GLboolean (*make_current)(OSMesaContext, void*, GLenum, GLsizei, GLsizei) = nullptr;
  void (*destroy_context)(OSMesaContext) = nullptr;
  OSMesaContext (*get_current_context)() = nullptr;
  GenericProc (*get_proc_address)(const char*) = nullptr;
};

const OSMesaApi* osmesa_api() {
  static const OSMesaApi api = [] {
    OSMesaApi a;
    a.create_context_attribs = reinterpret_cast<decltype(a.create_context_attribs)>(
        dlsym(RTLD_DEFAULT, "OSMesaCreateContextAttribs"));
    a.make_current = reinterpret_cast<decltype(a.make_current)>(dlsym(RTLD_DEFAULT, "OSMesaMakeCurrent"));
    a.destroy_context = reinterpret_cast<decltype(a.destroy_context)>(dlsym(RTLD_DEFAULT, "OSMesaDestroyContext"));
    a.get_current_context =
        reinterpret_cast<decltype(a.get_current_context)>(dlsym(RTLD_DEFAULT, "OSMesaGetCurrentContext"));
    a.get_proc_address = reinterpret_cast<decltype(a.get_proc_address)>(dlsym(RTLD_DEFAULT, "OSMesaGetProcAddress"));
    return a;
  }();
  const bool complete = api.create_context_attribs && api.make_current && api.destroy_context &&
                        api.get_current_context && api.get_proc_address;
  return complete ? &api : nullptr;
}

// The shared object that defines `symbol` for the whole process, or "".
std::string defining_object(const char* symbol) {
  void* p = dlsym(RTLD_DEFAULT, symbol);
  Dl_info info{};
  if (!p || !dladdr(p, &info) || !info.dli_fname) return {};
  return info.dli_fname;
}

// EGL device enumeration (EGL_EXT_device_enumeration); the first device
// that is not Mesa's software device, or nullptr.
EGLDeviceEXT find_hardware_egl_device() {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!client || !std::strstr(client, "EGL_EXT_device_enumeration")) return nullptr;
  auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  auto query_string =
      reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
  if (!query_devices || !query_string) return nullptr;
  EGLDeviceEXT devices[16];
  EGLint count = 0;
  if (!query_devices(16, devices, &count)) return nullptr;
  for (EGLint i = 0; i < count; ++i) {
    const char* ext = query_string(devices[i], EGL_EXTENSIONS);
    if (ext && std::strstr(ext, "EGL_MESA_device_software")) continue;
    return devices[i];
  }
  return nullptr;
}

std::string egl_error_text(EGLint e) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "EGL error 0x%04x", static_cast<unsigned>(e));
  return buf;
}

}  // namespace
}  // namespace palpa::render

// ---------------------------------------------------------------------------
// Interposed GL symbols (exported from the executable, see CMakeLists.txt).
extern "C" {

// GLEW for GLX: glewInit() = glewContextInit() (loads every GL entry point)
// followed by glxewInit(), which fails with no GLX display
// (GLEW_ERROR_NO_GLX_DISPLAY) or an old GLX (GLEW_ERROR_GLX_VERSION_11_ONLY).
// With our offscreen context current those two mean "GL is ready".
GLenum glewInit(void) {
  using Fn = GLenum (*)();
  static const Fn real = reinterpret_cast<Fn>(dlsym(RTLD_NEXT, "glewInit"));
  if (!real) return GLEW_ERROR_NO_GL_VERSION;
  const GLenum r = real();
  if (palpa::render::t_current_backend != palpa::render::GlBackend::Auto &&
      (r == GLEW_ERROR_NO_GLX_DISPLAY || r == GLEW_ERROR_GLX_VERSION_11_ONLY))
    return GLEW_OK;
  return r;
}

// GLEW loads GL functions through glXGetProcAddressARB. For an OSMesa
// context the GL entry points must come from OSMesa (libGL's dispatch does
// not know OSMesa contexts). Everything else, GLX names included, goes to
// libGLX: its GL stubs dispatch to whatever context is current, EGL's too,
// and its glXGetCurrentDisplay says "no display", which GLEW needs to hear.
palpa::render::GenericProc glXGetProcAddressARB(const unsigned char* name) {
  const char* n = reinterpret_cast<const char*>(name);
  if (palpa::render::t_current_backend == palpa::render::GlBackend::OSMesa && std::strncmp(n, "glX", 3) != 0) {
    if (const auto* api = palpa::render::osmesa_api()) return api->get_proc_address(n);
    return nullptr;
  }
  using Fn = palpa::render::GenericProc (*)(const unsigned char*);
  static const Fn real = reinterpret_cast<Fn>(dlsym(RTLD_NEXT, "glXGetProcAddressARB"));
  return real ? real(name) : nullptr;
}

}  // extern "C"

namespace palpa::render {

GlBackend parse_gl_backend(std::string_view name) {
  if (name == "auto") return GlBackend::Auto;
  if (name == "osmesa") return GlBackend::OSMesa;
  if (name == "egl") return GlBackend::Egl;
  throw RenderError("unknown GL backend '" + std::string(name) + "' (expected auto, osmesa or egl)");
}

std::string_view gl_backend_name(GlBackend backend) {
  switch (backend) {
    case GlBackend::Auto: return "auto";
    case GlBackend::OSMesa: return "osmesa";
    case GlBackend::Egl: return "egl";
  }
  return "auto";
}

bool osmesa_linked_first() {
  if (!osmesa_api()) return false;
  const std::string osmesa = defining_object("OSMesaGetProcAddress");
  return !osmesa.empty() && defining_object("glGetString") == osmesa;
}

bool egl_hardware_device_present() { return find_hardware_egl_device() != nullptr; }

GlBackend resolve_gl_backend(GlBackend requested, std::string* reason) {
  auto say = [&](const char* why) {
    if (reason) *reason = why;
  };
  // The environment may override Auto (never an explicit request).
  if (requested == GlBackend::Auto) {
    if (const char* env = std::getenv("PALPA_GL"); env && *env) {
      requested = parse_gl_backend(env);
      if (requested != GlBackend::Auto) {
        say("PALPA_GL");
        return requested;
      }
    }
  } else {
    say("requested");
    return requested;
  }
  if (egl_hardware_device_present()) {
    say("a hardware EGL device is present");
    return GlBackend::Egl;
  }
  if (osmesa_linked_first()) {
    say("no GPU; OSMesa is linked first in this executable");
    return GlBackend::OSMesa;
  }
  say("no GPU; this executable does not link OSMesa first, so EGL surfaceless (Mesa llvmpipe)");
  return GlBackend::Egl;
}

// ---------------------------------------------------------------------------
struct OffscreenWindow::Impl {
  GlBackend backend = GlBackend::Auto;
  int width = 0, height = 0;
  std::string renderer, version;
  vtkSmartPointer<vtkGenericOpenGLRenderWindow> window;
  vtkNew<vtkCallbackCommand> callback;
  vtkNew<vtkUnsignedCharArray> rgba;  // read_rgba(): lent the caller's buffer

  // OSMesa state: the context and the colour buffer it renders into.
  OSMesaContext osmesa = nullptr;
  std::vector<unsigned char> osmesa_buffer;

  // EGL state.
  EGLDisplay egl_display = EGL_NO_DISPLAY;
  EGLContext egl_context = EGL_NO_CONTEXT;

  void create_osmesa();
  void create_egl();
  void make_current();
  bool is_current() const;
  void destroy_context();

  // VTK asks the generic window's owner to make the context current and to
  // say whether it is; frames need nothing (VTK keeps them in its own FBO).
  static void on_event(vtkObject*, unsigned long event, void* client, void* call) {
    auto* self = static_cast<Impl*>(client);
    if (event == vtkCommand::WindowMakeCurrentEvent) {
      self->make_current();
    } else if (event == vtkCommand::WindowIsCurrentEvent) {
      *static_cast<bool*>(call) = self->is_current();
    }
  }
};

void OffscreenWindow::Impl::create_osmesa() {
  const OSMesaApi* api = osmesa_api();
  if (!api)
    throw RenderError(
        "OSMesa backend: libOSMesa is not linked into this executable (use palpa_link_osmesa_first() "
        "in CMake, or the EGL backend)");
  if (!osmesa_linked_first())
    throw RenderError("OSMesa backend: glGetString resolves to " + defining_object("glGetString") +
                      ", not libOSMesa, so VTK's direct GL calls would miss the OSMesa context; link "
                      "libOSMesa before libGL (palpa_link_osmesa_first())");
  // A core 3.2 context, RGBA colour with depth, drawing into our buffer.
  const int attribs[] = {OSMESA_FORMAT,          OSMESA_RGBA,        OSMESA_DEPTH_BITS,
                         24,                     OSMESA_STENCIL_BITS, 8,
                         OSMESA_PROFILE,         OSMESA_CORE_PROFILE, OSMESA_CONTEXT_MAJOR_VERSION,
                         3,                      OSMESA_CONTEXT_MINOR_VERSION, 2,
                         0};
  osmesa = api->create_context_attribs(attribs, nullptr);
  if (!osmesa) throw RenderError("OSMesa backend: OSMesaCreateContextAttribs failed for a core 3.2 context");
  osmesa_buffer.assign(static_cast<std::size_t>(width) * height * 4, 0);
}

void OffscreenWindow::Impl::create_egl() {
  // A hardware device if there is one, else Mesa's surfaceless platform.
  EGLDeviceEXT device = find_hardware_egl_device();
  if (device)
    egl_display = eglGetPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, device, nullptr);
  else
    egl_display = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  const char* platform = device ? "EGL device platform" : "EGL surfaceless platform";
  if (egl_display == EGL_NO_DISPLAY)
    throw RenderError(std::string("EGL backend: no display on the ") + platform + " (" +
                      egl_error_text(eglGetError()) + ")");
  EGLint major = 0, minor = 0;
  if (!eglInitialize(egl_display, &major, &minor))
    throw RenderError(std::string("EGL backend: eglInitialize failed on the ") + platform + " (" +
                      egl_error_text(eglGetError()) + ")");
  if (!eglBindAPI(EGL_OPENGL_API)) throw RenderError("EGL backend: desktop OpenGL API not available");
  // A pbuffer-capable OpenGL config if offered, else no config at all
  // (EGL_KHR_no_config_context); the context never gets a surface.
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                   EGL_RED_SIZE,     8,               EGL_GREEN_SIZE,      8,
                                   EGL_BLUE_SIZE,    8,               EGL_DEPTH_SIZE,      24,
                                   EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  if (!eglChooseConfig(egl_display, config_attribs, &config, 1, &configs) || configs < 1)
    config = EGL_NO_CONFIG_KHR;
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 2,
                                    EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                    EGL_NONE};
  egl_context = eglCreateContext(egl_display, config, EGL_NO_CONTEXT, context_attribs);
  if (egl_context == EGL_NO_CONTEXT)
    throw RenderError(std::string("EGL backend: cannot create a core 3.2 OpenGL context on the ") + platform +
                      " (" + egl_error_text(eglGetError()) + ")");
}

void OffscreenWindow::Impl::make_current() {
  if (backend == GlBackend::OSMesa) {
    osmesa_api()->make_current(osmesa, osmesa_buffer.data(), GL_UNSIGNED_BYTE, width, height);
  } else {
    eglMakeCurrent(egl_display, EGL_NO_SURFACE, EGL_NO_SURFACE, egl_context);
  }
  t_current_backend = backend;
}

bool OffscreenWindow::Impl::is_current() const {
  if (backend == GlBackend::OSMesa) return osmesa && osmesa_api()->get_current_context() == osmesa;
  return egl_context != EGL_NO_CONTEXT && eglGetCurrentContext() == egl_context;
}

void OffscreenWindow::Impl::destroy_context() {
  if (osmesa) {
    if (osmesa_api()->get_current_context() == osmesa) t_current_backend = GlBackend::Auto;
    osmesa_api()->destroy_context(osmesa);
    osmesa = nullptr;
  }
  if (egl_context != EGL_NO_CONTEXT) {
    if (eglGetCurrentContext() == egl_context) {
      eglMakeCurrent(egl_display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      t_current_backend = GlBackend::Auto;
    }
    eglDestroyContext(egl_display, egl_context);
    egl_context = EGL_NO_CONTEXT;
  }
}

OffscreenWindow::OffscreenWindow(int width, int height, GlBackend backend) : impl_(std::make_unique<Impl>()) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw RenderError("offscreen window: size " + std::to_string(width) + "x" + std::to_string(height) +
                      " is outside 1..16384");
  Impl& m = *impl_;
  m.width = width;
  m.height = height;
  m.backend = resolve_gl_backend(backend);
  const GlBackend other = m.backend == GlBackend::OSMesa ? GlBackend::Egl : GlBackend::OSMesa;
  if (g_live_windows[static_cast<int>(other)] > 0)
    throw RenderError("offscreen window (" + std::string(gl_backend_name(m.backend)) + "): an " +
                      std::string(gl_backend_name(other)) +
                      " window is still open; GLEW's GL entry points are shared by the whole process, so "
                      "use one backend at a time");

  // Create the context and make it current.
  if (m.backend == GlBackend::OSMesa)
    m.create_osmesa();
  else
    m.create_egl();
  m.make_current();

  // With EGL in an executable that links OSMesa first, the direct GL calls go
  // through Mesa's dispatch; a non-Mesa driver never fills it.
  if (m.backend == GlBackend::Egl && !glGetString(GL_VERSION)) {
    m.destroy_context();
    throw RenderError("EGL backend: direct GL calls do not reach the EGL context (" +
                      defining_object("glGetString") +
                      " answers them); this executable links OSMesa first, which only works with Mesa's "
                      "EGL; use the OSMesa backend or an executable without OSMesa (palpa render)");
  }

  // Wrap the context in VTK's generic window: no multisampling, no blit
  // to a default framebuffer (EGL has none), VTK renders into its own FBO.
  m.window = vtkSmartPointer<vtkGenericOpenGLRenderWindow>::New();
  m.callback->SetClientData(&m);
  m.callback->SetCallback(&Impl::on_event);
  m.window->AddObserver(vtkCommand::WindowMakeCurrentEvent, m.callback);
  m.window->AddObserver(vtkCommand::WindowIsCurrentEvent, m.callback);
  m.window->SetMultiSamples(0);
  m.window->SetSize(width, height);
  m.window->SetFrameBlitModeToNoBlit();
  // Nothing is shown, so no copy of VTK's render framebuffer into its display
  // framebuffer after each frame (a full-window blit: about 1 ms at 1280x720
  // in llvmpipe); the pixels and the depth are read from the render framebuffer.
  m.window->SetSwapBuffers(false);
  m.window->SetIsDirect(true);
  m.window->SetSupportsOpenGL(true);
  m.window->SetOffScreenRendering(true);
  if (!m.window->InitializeFromCurrentContext()) {
    m.window = nullptr;
    m.destroy_context();
    throw RenderError(std::string("offscreen window (") + std::string(gl_backend_name(m.backend)) +
                      "): VTK could not initialise OpenGL in the context (needs OpenGL 3.2)");
  }
  const auto* r = glGetString(GL_RENDERER);
  const auto* v = glGetString(GL_VERSION);
  m.renderer = r ? reinterpret_cast<const char*>(r) : "";
  m.version = v ? reinterpret_cast<const char*>(v) : "";
  g_live_windows[static_cast<int>(m.backend)] += 1;
}

OffscreenWindow::~OffscreenWindow() {
  g_live_windows[static_cast<int>(impl_->backend)] -= 1;
  // Release every GL resource (of every prop) while our context is current.
  if (impl_->window) {
    impl_->window->Finalize();
    impl_->window->RemoveObserver(impl_->callback);
    impl_->window = nullptr;
  }
  impl_->destroy_context();
}

GlBackend OffscreenWindow::backend() const { return impl_->backend; }
const std::string& OffscreenWindow::gl_renderer() const { return impl_->renderer; }
const std::string& OffscreenWindow::gl_version() const { return impl_->version; }
vtkRenderWindow* OffscreenWindow::window() const { return impl_->window; }
int OffscreenWindow::width() const { return impl_->width; }
int OffscreenWindow::height() const { return impl_->height; }

void OffscreenWindow::render() { impl_->window->Render(); }

Image OffscreenWindow::capture() const {
  Impl& m = *impl_;
  m.window->MakeCurrent();
  // RGBA of the back buffer (VTK's render framebuffer), bottom row first.
  vtkNew<vtkUnsignedCharArray> rgba;
  m.window->GetRGBACharPixelData(0, 0, m.width - 1, m.height - 1, 0, rgba, 0);
  Image img;
  img.width = m.width;
  img.height = m.height;
  img.rgb.resize(static_cast<std::size_t>(m.width) * m.height * 3);
  const unsigned char* src = rgba->GetPointer(0);
  for (int y = 0; y < m.height; ++y) {
    const unsigned char* row = src + static_cast<std::size_t>(m.height - 1 - y) * m.width * 4;
    for (int x = 0; x < m.width; ++x) std::memcpy(img.at(x, y), row + 4 * x, 3);
  }
  return img;
}

void OffscreenWindow::finish() {
  impl_->window->MakeCurrent();
  glFinish();
}

void OffscreenWindow::flush() {
  impl_->window->MakeCurrent();
  glFlush();
}

void OffscreenWindow::read_rgba(std::span<std::uint8_t> out) {
  Impl& m = *impl_;
  const std::size_t size = static_cast<std::size_t>(m.width) * m.height * 4;
  if (out.size() != size)
    throw std::invalid_argument("OffscreenWindow::read_rgba: " + std::to_string(out.size()) + " bytes given, " +
                                std::to_string(size) + " needed");
  m.window->MakeCurrent();
  // VTK reads straight into an array of the right size; `out` lent to it
  // (save = 1: VTK never frees it), so the pixels land there.
  m.rgba->SetNumberOfComponents(4);
  m.rgba->SetArray(out.data(), static_cast<vtkIdType>(size), 1);
  m.window->GetRGBACharPixelData(0, 0, m.width - 1, m.height - 1, 0, m.rgba, 0);
  if (m.rgba->GetPointer(0) != out.data()) std::memcpy(out.data(), m.rgba->GetPointer(0), size);
  m.rgba->SetArray(nullptr, 0, 1);
}

float OffscreenWindow::depth_at(int x, int y) const {
  impl_->window->MakeCurrent();
  return impl_->window->GetZbufferDataAtPoint(x, y);
}

}  // namespace palpa::render
