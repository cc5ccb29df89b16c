# Haptic loop benchmark (issue 4): 1 and 4 kHz with three scripted probes on
# a 1M-vertex organ while a headless renderer takes the surface stream, and
# 1 kHz again with the second core busy. Prints percentiles; not a test.
add_executable(palpa_loop_bench ${CMAKE_CURRENT_LIST_DIR}/loop_bench.cpp)
target_link_libraries(palpa_loop_bench PRIVATE palpa::haptics palpa::mesh palpa::devices palpa_warnings)
add_dependencies(palpa_loop_bench palpa_device_scripted)
