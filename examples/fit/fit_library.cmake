# The fit example's core (everything but main.cpp) as a static library, shared
# by the gradraster-fit executable (examples/fit/CMakeLists.txt) and the test
# binary (tests/CMakeLists.txt), so its tests run whether or not the examples
# are built. Included from both; defined once.
include(${CMAKE_CURRENT_LIST_DIR}/../common/common.cmake)
include(${CMAKE_CURRENT_LIST_DIR}/../common/plot_library.cmake)
if(NOT TARGET gradraster_fit)
  add_library(gradraster_fit STATIC
    ${CMAKE_CURRENT_LIST_DIR}/cli.cpp
    ${CMAKE_CURRENT_LIST_DIR}/concurrent_views.cpp
    ${CMAKE_CURRENT_LIST_DIR}/fit.cpp
    ${CMAKE_CURRENT_LIST_DIR}/fit_outputs.cpp
    ${CMAKE_CURRENT_LIST_DIR}/geometry.cpp
    ${CMAKE_CURRENT_LIST_DIR}/option_agreement.cpp
    ${CMAKE_CURRENT_LIST_DIR}/phase_times.cpp
    ${CMAKE_CURRENT_LIST_DIR}/plot.cpp
    ${CMAKE_CURRENT_LIST_DIR}/progress.cpp
    ${CMAKE_CURRENT_LIST_DIR}/scene.cpp
    ${CMAKE_CURRENT_LIST_DIR}/shading.cpp
    ${CMAKE_CURRENT_LIST_DIR}/snapshot.cpp
    ${CMAKE_CURRENT_LIST_DIR}/snapshot_writer.cpp)
  target_compile_options(gradraster_fit PRIVATE -Wall -Wextra)
  target_link_libraries(gradraster_fit PUBLIC gradraster_example_common PRIVATE gradraster_plot)
endif()
