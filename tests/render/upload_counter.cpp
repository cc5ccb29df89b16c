// GLEW pointer wrapping for upload accounting.

#include "upload_counter.h"

#include <GL/glew.h>

#include <stdexcept>

namespace palpa::render::test {
namespace {

// The counter's state; one counter at a time, rendering thread only.
UploadCounts g_counts;
PFNGLBUFFERDATAPROC g_real_buffer_data = nullptr;
PFNGLBUFFERSUBDATAPROC g_real_buffer_sub_data = nullptr;
bool g_installed = false;

void count(GLenum target, GLsizeiptr size) {
  const auto bytes = static_cast<std::uint64_t>(size > 0 ? size : 0);
  switch (target) {
    case GL_ARRAY_BUFFER: g_counts.vertex_bytes += bytes; break;
    case GL_ELEMENT_ARRAY_BUFFER: g_counts.index_bytes += bytes; break;
    case GL_TEXTURE_BUFFER: g_counts.texture_buffer_bytes += bytes; break;
    default: g_counts.other_bytes += bytes; break;
  }
}

// glBufferData with no data only allocates; it is not an upload.
void GLAPIENTRY counting_buffer_data(GLenum target, GLsizeiptr size, const void* data, GLenum usage) {
  if (data) count(target, size);
  g_counts.buffer_data_calls += 1;
  g_real_buffer_data(target, size, data, usage);
}

void GLAPIENTRY counting_buffer_sub_data(GLenum target, GLintptr offset, GLsizeiptr size, const void* data) {
  count(target, size);
  g_counts.buffer_sub_data_calls += 1;
  g_real_buffer_sub_data(target, offset, size, data);
}

}  // namespace

GlUploadCounter::GlUploadCounter() {
  if (g_installed) throw std::logic_error("GlUploadCounter: another counter is already installed");
  if (!__glewBufferData || !__glewBufferSubData)
    throw std::logic_error("GlUploadCounter: GLEW is not initialised (create it after the first render)");
  g_real_buffer_data = __glewBufferData;
  g_real_buffer_sub_data = __glewBufferSubData;
  __glewBufferData = &counting_buffer_data;
  __glewBufferSubData = &counting_buffer_sub_data;
  g_counts = {};
  g_installed = true;
}

GlUploadCounter::~GlUploadCounter() {
  // Restore only if nobody (a later glewInit) replaced our wrappers.
  if (__glewBufferData == &counting_buffer_data) __glewBufferData = g_real_buffer_data;
  if (__glewBufferSubData == &counting_buffer_sub_data) __glewBufferSubData = g_real_buffer_sub_data;
  g_installed = false;
}

UploadCounts GlUploadCounter::counts() const { return g_counts; }
void GlUploadCounter::reset() { g_counts = {}; }

}  // namespace palpa::render::test
