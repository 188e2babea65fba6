# gradraster_plot: the plotting canvas (plot_canvas.h) shared by the examples,
# the benches and the test binary. Included from each; defined once.
if(NOT TARGET gradraster_plot)
  add_library(gradraster_plot STATIC ${CMAKE_CURRENT_LIST_DIR}/plot_canvas.cpp)
  target_compile_options(gradraster_plot PRIVATE -Wall -Wextra)
  target_link_libraries(gradraster_plot PUBLIC gradraster::base)
endif()
