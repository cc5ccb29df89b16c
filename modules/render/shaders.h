#pragma once
// The GLSL of shaders/, compiled into the binary at build time
// (modules/render/embed_shaders.cmake generates the definitions).

namespace palpa::render::shaders {

/// Declarations inserted after //VTK::Normal::Dec: eq. (2) and (3).
extern const char* const deform_vs_dec;
/// Statements inserted at the start of the vertex shader's main().
extern const char* const deform_vs_impl;
/// Stream and N0 from texture buffers (our partial-upload path).
extern const char* const deform_fetch_texture;
/// Stream and N0 from vertex attributes (VTK's own upload path).
extern const char* const deform_fetch_attribute;

}  // namespace palpa::render::shaders
