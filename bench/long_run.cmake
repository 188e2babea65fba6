# long_run: 1000 steps of the fit example with RSS and NaN checks (issue 7); a
# plain program. It links the fit example's core library, which
# fit_library.cmake defines once whichever of tests/ and bench/ includes it first.
include(${PROJECT_SOURCE_DIR}/examples/fit/fit_library.cmake)
add_executable(long_run ${CMAKE_CURRENT_LIST_DIR}/long_run.cpp)
target_link_libraries(long_run PRIVATE gradraster_fit)
