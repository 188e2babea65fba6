# time_error (issue 6, graded against the exact reference since issue 13):
# run time against gradient error of the dtype / antialias / supersampling /
# soft rasterization choices on four fixed scenes; a plain program, not a Google Benchmark.
#   build/bench/time_error [--scene NAME] [--supersampled-reference] [out.csv] [out.png]   (docs/time_error.md)
include(${CMAKE_CURRENT_LIST_DIR}/time_error_library.cmake)
add_executable(time_error
  ${CMAKE_CURRENT_SOURCE_DIR}/time_error.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/time_error_plot.cpp)
target_link_libraries(time_error PRIVATE gradraster_time_error_reference gradraster_time_error_args gradraster_plot)
# time_error_plateau: why the antialiased gradient error stalls with
# supersampling (docs/time_error.md); an experiment, prints only.
add_executable(time_error_plateau ${CMAKE_CURRENT_SOURCE_DIR}/time_error_plateau.cpp)
target_link_libraries(time_error_plateau PRIVATE gradraster_time_error_reference gradraster_example_common)
