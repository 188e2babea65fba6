# The intersection example's core as a static library, shared by the
# executable and the test binary (as ssr_tool.cmake). Defined once.
include(${CMAKE_CURRENT_LIST_DIR}/../common/common.cmake)
if(NOT TARGET gradraster_intersection_example)
  add_library(gradraster_intersection_example STATIC ${CMAKE_CURRENT_LIST_DIR}/sunk_sphere.cpp
                                                     ${CMAKE_CURRENT_LIST_DIR}/intersection_args.cpp)
  target_compile_options(gradraster_intersection_example PRIVATE -Wall -Wextra)
  target_include_directories(gradraster_intersection_example PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(gradraster_intersection_example PUBLIC gradraster::gradraster gradraster_example_common)
endif()
