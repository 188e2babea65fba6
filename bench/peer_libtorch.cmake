# peer_libtorch (issue 6): the Blinn-Phong shading graph in gradraster and in
# libtorch's C++ API, timed and memory-measured side by side. Optional: built
# only when find_package(Torch) succeeds; never fails the configure.
find_package(Torch QUIET)
if(Torch_FOUND)
  add_executable(peer_libtorch ${CMAKE_CURRENT_SOURCE_DIR}/peer_libtorch.cpp)
  target_link_libraries(peer_libtorch PRIVATE gradraster::gradraster gradraster_example_common ${TORCH_LIBRARIES})
  message(STATUS "gradraster: libtorch found (${Torch_DIR}); building bench/peer_libtorch")
else()
  message(STATUS "gradraster: libtorch not found; bench/peer_libtorch is skipped (install libtorch-dev to build it)")
endif()
