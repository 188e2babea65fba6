# The shading examples (shading.cpp) as a static library, shared by the
# gradraster-shading-gallery executable (examples/shading/CMakeLists.txt) and
# the test binary (tests/CMakeLists.txt), so their tests run whether or not the
# examples are built. Included from both; defined once.
if(NOT TARGET gradraster_shading)
  add_library(gradraster_shading STATIC ${CMAKE_CURRENT_LIST_DIR}/shading.cpp)
  target_compile_options(gradraster_shading PRIVATE -Wall -Wextra)
  target_link_libraries(gradraster_shading PUBLIC gradraster::gradraster)
endif()
