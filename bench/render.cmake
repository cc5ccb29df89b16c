# palpa-render-bench: frame time and bytes uploaded per frame for the GPU
# deformation path against VTK's own path and a static render (issue 3).
# Not a test: it prints figures and ratios. Needs the render module, and
# counts uploads with the tests' GL upload counter (a test aid).
if(NOT TARGET palpa::render)
  return()
endif()
include(${PROJECT_SOURCE_DIR}/tests/render/upload_counter.cmake)

add_executable(palpa-render-bench ${CMAKE_CURRENT_LIST_DIR}/render_bench.cpp)
target_link_libraries(palpa-render-bench PRIVATE palpa::render palpa::haptics palpa::deform palpa::collision palpa::mesh
  palpa_test_upload_counter VTK::RenderingCore palpa_warnings)
palpa_link_osmesa_first(palpa-render-bench)

# The same program without OSMesa in front of libGL, for EGL on a GPU whose
# driver is not Mesa (NVIDIA): run it with --gl egl.
add_executable(palpa-render-bench-gpu ${CMAKE_CURRENT_LIST_DIR}/render_bench.cpp)
target_link_libraries(palpa-render-bench-gpu PRIVATE palpa::render palpa::haptics palpa::deform palpa::collision palpa::mesh
  palpa_test_upload_counter VTK::RenderingCore OpenGL::OpenGL palpa_warnings)
