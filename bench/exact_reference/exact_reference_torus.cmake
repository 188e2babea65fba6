# exact_reference_torus: time of the exact reference on the time_error torus
# and its agreement with 16x16 supersampling (a plain program).
include(${CMAKE_CURRENT_LIST_DIR}/../time_error_library.cmake)
add_executable(exact_reference_torus ${CMAKE_CURRENT_LIST_DIR}/exact_reference_torus.cpp)
target_link_libraries(exact_reference_torus PRIVATE gradraster_time_error_reference gradraster_example_common)
