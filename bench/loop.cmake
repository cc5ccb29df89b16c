# Haptic loop benchmark (issue 4): 1 and 4 kHz with three scripted probes on
# a 1M-vertex organ while a headless renderer takes the surface stream, and
# 1 kHz again with the second core busy. Prints percentiles; not a test.
if(NOT TARGET palpa::render)
  return()
endif()
add_executable(palpa-loop-bench ${CMAKE_CURRENT_LIST_DIR}/loop_bench.cpp)
target_link_libraries(palpa-loop-bench PRIVATE palpa::haptics palpa::mesh palpa::devices palpa::render
                      VTK::RenderingCore palpa_warnings)
palpa_link_osmesa_first(palpa-loop-bench)
add_dependencies(palpa-loop-bench palpa_device_scripted)

# The same program without OSMesa in front of libGL, for EGL on a GPU whose
# driver is not Mesa (NVIDIA): there a hardware EGL device is found and used
# (or PALPA_GL=egl), and VTK's direct GL calls must reach glvnd's libOpenGL,
# not OSMesa. Built beside palpa-loop-bench; never run in CI.
add_executable(palpa-loop-bench-gpu ${CMAKE_CURRENT_LIST_DIR}/loop_bench.cpp)
target_link_libraries(palpa-loop-bench-gpu PRIVATE palpa::haptics palpa::mesh palpa::devices palpa::render
                      VTK::RenderingCore OpenGL::OpenGL palpa_warnings)
add_dependencies(palpa-loop-bench-gpu palpa_device_scripted)
