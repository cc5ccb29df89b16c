# The real-time haptic loop (included at the end of haptics/CMakeLists.txt):
# lock-free exchange (triple buffer, SPSC queue), device mapping and clutch,
# the safety filter, the deterministic tick core, the threaded loop with its
# statistics, and exact replay of recorded sessions.
find_package(Threads REQUIRED)
target_sources(palpa_haptics PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/device_mapping.cpp
  ${CMAKE_CURRENT_LIST_DIR}/safety.cpp
  ${CMAKE_CURRENT_LIST_DIR}/loop_stats.cpp
  ${CMAKE_CURRENT_LIST_DIR}/loop_core.cpp
  ${CMAKE_CURRENT_LIST_DIR}/session.cpp
  ${CMAKE_CURRENT_LIST_DIR}/indent.cpp
  ${CMAKE_CURRENT_LIST_DIR}/loop.cpp
  ${CMAKE_CURRENT_LIST_DIR}/loop_replay.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cpu_plan.cpp)
# Devices are a lower layer (plugin interface and loader); the loop drives them.
target_link_libraries(palpa_haptics PUBLIC palpa::devices Threads::Threads PRIVATE palpa::mesh)
