# The exact box-filtered reference renderer (issue 13 item 1;
# docs/exact_reference.md): a static library for bench programs and the tests.
if(NOT TARGET gradraster_exact_reference)
  add_library(gradraster_exact_reference STATIC
    ${CMAKE_CURRENT_LIST_DIR}/exact_reference.cpp
    ${CMAKE_CURRENT_LIST_DIR}/polygon.cpp
    ${CMAKE_CURRENT_LIST_DIR}/quadrature.cpp)
  target_include_directories(gradraster_exact_reference PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(gradraster_exact_reference PUBLIC gradraster::gradraster)
endif()
