#pragma once
// A test aid (not part of the render module): counts every buffer upload
// made through GLEW's glBufferData and glBufferSubData (VTK's and ours), by
// target, so tests and palpa-render-bench can see what a frame really sends
// to the GPU, independent of the adapter's own accounting. Library
// palpa_test_upload_counter (tests/render/upload_counter.cmake).

#include <cstdint>

namespace palpa::render::test {

/// Bytes and calls since construction or reset().
struct UploadCounts {
  std::uint64_t vertex_bytes = 0;          ///< GL_ARRAY_BUFFER (VTK's VBOs)
  std::uint64_t index_bytes = 0;           ///< GL_ELEMENT_ARRAY_BUFFER (index buffers)
  std::uint64_t texture_buffer_bytes = 0;  ///< GL_TEXTURE_BUFFER (our stream)
  std::uint64_t other_bytes = 0;
  std::uint64_t buffer_data_calls = 0;     ///< glBufferData (whole-buffer (re)allocations)
  std::uint64_t buffer_sub_data_calls = 0; ///< glBufferSubData
  std::uint64_t total_bytes() const { return vertex_bytes + index_bytes + texture_buffer_bytes + other_bytes; }
};

/// While alive, wraps GLEW's glBufferData and glBufferSubData pointers.
/// Create it with a context current and VTK's window initialised (glewInit
/// rewrites the pointers); only one at a time, on the rendering thread.
class GlUploadCounter {
 public:
  /// Throws std::logic_error when GLEW is not initialised or another counter is alive.
  GlUploadCounter();
  ~GlUploadCounter();
  GlUploadCounter(const GlUploadCounter&) = delete;
  GlUploadCounter& operator=(const GlUploadCounter&) = delete;

  UploadCounts counts() const;
  void reset();
};

}  // namespace palpa::render::test
