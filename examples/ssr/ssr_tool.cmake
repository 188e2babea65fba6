# The gradraster-ssr tool's core as a static library, shared by the executable
# and the test binary (as render_tool.cmake). Defined once.
include(${CMAKE_CURRENT_LIST_DIR}/../common/common.cmake)
if(NOT TARGET gradraster_ssr_tool)
  add_library(gradraster_ssr_tool STATIC ${CMAKE_CURRENT_LIST_DIR}/ssr_tool.cpp)
  target_compile_options(gradraster_ssr_tool PRIVATE -Wall -Wextra)
  target_link_libraries(gradraster_ssr_tool PUBLIC gradraster_example_common)
endif()
