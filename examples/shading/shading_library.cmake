# The shading gallery's sky/ground environment (sky_ground.cpp) as a static
# library, shared by the gradraster-shading-gallery executable
# (examples/shading/CMakeLists.txt) and the test binary (tests/CMakeLists.txt),
# so its tests run whether or not the examples are built. Included from both;
# defined once. The shading functions themselves are the library's (ops/shading.h).
if(NOT TARGET gradraster_shading_example)
  add_library(gradraster_shading_example STATIC ${CMAKE_CURRENT_LIST_DIR}/sky_ground.cpp)
  target_compile_options(gradraster_shading_example PRIVATE -Wall -Wextra)
  target_link_libraries(gradraster_shading_example PUBLIC gradraster::gradraster)
endif()
