# palpa-bench: the core benchmark (haptic tick, contact query against CGAL,
# deformation step against copy bandwidth). Not a test: it prints figures.
# CGAL and nlohmann-json are used here only. CGAL is confined to one
# translation unit (palpa_bench_cgal.cpp) because its headers compile slowly.

find_package(CGAL QUIET)
find_package(nlohmann_json 3 QUIET)
if(NOT CGAL_FOUND OR NOT nlohmann_json_FOUND)
  message(WARNING "palpa-bench not built: needs CGAL (libcgal-dev) and nlohmann_json (nlohmann-json3-dev)")
  return()
endif()

# The CGAL reference behind a small interface; CGAL's compile flags
# (e.g. -frounding-math) stay on this library.
add_library(palpa_bench_cgal STATIC ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_cgal.cpp)
target_link_libraries(palpa_bench_cgal PUBLIC palpa::mesh PRIVATE CGAL::CGAL palpa_warnings)

add_executable(palpa-bench
  ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_main.cpp
  ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_util.cpp
  ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_path.cpp
  ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_replica.cpp
  ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_meshes.cpp
  ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_tissue.cpp
  ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_hover.cpp
  ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_fallback.cpp
  ${CMAKE_CURRENT_LIST_DIR}/palpa_bench_query_loop.cpp)
target_link_libraries(palpa-bench PRIVATE palpa::haptics palpa::collision palpa::deform palpa::mesh palpa::tissue
  opencv_core opencv_imgcodecs palpa_bench_cgal nlohmann_json::nlohmann_json palpa_warnings)
# The shared organs live next to the source tree: <source>/../shared/data/organs.
target_compile_definitions(palpa-bench PRIVATE
  PALPA_BENCH_SHARED_ORGANS_DIR="${PROJECT_SOURCE_DIR}/../shared/data/organs")
