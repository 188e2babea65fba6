# The gradraster-render tool's core as a static library, shared by the
# executable (examples/CMakeLists.txt) and the test binary
# (tests/CMakeLists.txt), so the tests drive the tool in-process whether or not
# the examples are built. Included from both; defined once.
include(${CMAKE_CURRENT_LIST_DIR}/../common/common.cmake)
if(NOT TARGET gradraster_render_tool)
  add_library(gradraster_render_tool STATIC
    ${CMAKE_CURRENT_LIST_DIR}/render_args.cpp
    ${CMAKE_CURRENT_LIST_DIR}/render_tool.cpp)
  target_compile_options(gradraster_render_tool PRIVATE -Wall -Wextra)
  target_link_libraries(gradraster_render_tool PUBLIC gradraster_example_common)
  if(TARGET gradraster_vulkan)  # --device vulkan (cmake/vulkan.cmake)
    target_link_libraries(gradraster_render_tool PRIVATE gradraster_vulkan)
  endif()
endif()
