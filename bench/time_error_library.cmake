# time_error's scene, references (exact and supersampled finite differences)
# and error metric as a static library, shared by time_error,
# exact_reference_torus and the tests (tests/bench/test_time_error_reference.cpp).
include(${CMAKE_CURRENT_LIST_DIR}/exact_reference/exact_reference.cmake)
if(NOT TARGET gradraster_time_error_reference)
  add_library(gradraster_time_error_reference STATIC
    ${CMAKE_CURRENT_LIST_DIR}/time_error_scene.cpp
    ${CMAKE_CURRENT_LIST_DIR}/time_error_reference.cpp
    ${CMAKE_CURRENT_LIST_DIR}/time_error_exact.cpp
    ${CMAKE_CURRENT_LIST_DIR}/time_error_regions.cpp)
  target_link_libraries(gradraster_time_error_reference PUBLIC gradraster_exact_reference)
endif()
# time_error's command line (parsing, --help, its outputs checked up front),
# shared by time_error and tests/bench/test_time_error_args.cpp.
include(${CMAKE_CURRENT_LIST_DIR}/../examples/common/common.cmake)
if(NOT TARGET gradraster_time_error_args)
  add_library(gradraster_time_error_args STATIC ${CMAKE_CURRENT_LIST_DIR}/time_error_args.cpp)
  target_link_libraries(gradraster_time_error_args PUBLIC gradraster_time_error_reference gradraster_example_common)
endif()
