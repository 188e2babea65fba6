# time_error (issue 6): run time against gradient error of the dtype / antialias /
# supersampling choices on a fixed scene; a plain program, not a Google Benchmark.
#   build/bench/time_error [out.csv] [out.png]     (docs/time_error.md)
add_executable(time_error
  ${CMAKE_CURRENT_SOURCE_DIR}/time_error.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/time_error_scene.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/time_error_reference.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/time_error_plot.cpp)
target_link_libraries(time_error PRIVATE gradraster::gradraster gradraster_plot)
