# Code shared by the example tools (command-line handling, output folders, outputs
# that must not overwrite inputs) and the scenes the examples, tests and
# benchmarks share (the SSR scene, a default camera for a mesh), as a static
# library. Included by every tool's cmake file; defined once.
if(NOT TARGET gradraster_example_common)
  add_library(gradraster_example_common STATIC ${CMAKE_CURRENT_LIST_DIR}/cli_args.cpp
                                               ${CMAKE_CURRENT_LIST_DIR}/distinct_files.cpp
                                               ${CMAKE_CURRENT_LIST_DIR}/output_folder.cpp
                                               ${CMAKE_CURRENT_LIST_DIR}/mesh_framing.cpp
                                               ${CMAKE_CURRENT_LIST_DIR}/ssr_scene.cpp)
  target_compile_options(gradraster_example_common PRIVATE -Wall -Wextra)
  target_link_libraries(gradraster_example_common PUBLIC gradraster::gradraster)
endif()
