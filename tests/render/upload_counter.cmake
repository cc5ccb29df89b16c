# palpa_test_upload_counter: the GL upload counter (upload_counter.h), a test
# aid shared by the render tests and palpa-render-bench. Kept out of the
# render module: production code never counts through it. Included by
# tests/render/CMakeLists.txt and bench/render.cmake, defined once.
include_guard(GLOBAL)
find_package(GLEW REQUIRED)
add_library(palpa_test_upload_counter STATIC ${CMAKE_CURRENT_LIST_DIR}/upload_counter.cpp)
target_include_directories(palpa_test_upload_counter PUBLIC ${CMAKE_CURRENT_LIST_DIR})
# It wraps GLEW's function pointers, so it links the GLEW that VTK uses.
target_link_libraries(palpa_test_upload_counter PRIVATE GLEW::GLEW palpa_warnings)
