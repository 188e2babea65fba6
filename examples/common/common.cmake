# Code shared by the example tools (command-line handling, output folders, outputs
# that must not overwrite inputs), as a static
# library. Included by every tool's cmake file; defined once.
if(NOT TARGET gradraster_example_common)
  add_library(gradraster_example_common STATIC ${CMAKE_CURRENT_LIST_DIR}/cli_args.cpp
                                               ${CMAKE_CURRENT_LIST_DIR}/distinct_files.cpp
                                               ${CMAKE_CURRENT_LIST_DIR}/output_folder.cpp)
  target_compile_options(gradraster_example_common PRIVATE -Wall -Wextra)
  target_link_libraries(gradraster_example_common PUBLIC gradraster::gradraster)
endif()
