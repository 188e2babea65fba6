# peer_llvmpipe: our rasterizer vs Mesa llvmpipe (through OSMesa) on the same
# clip-space vertices (issue 6). A plain program, built only when OSMesa's
# pkg-config file is found (Debian: libosmesa6-dev); never part of the tests.
find_package(PkgConfig QUIET)
if(PKG_CONFIG_FOUND)
  pkg_check_modules(OSMESA QUIET IMPORTED_TARGET osmesa)
endif()
if(OSMESA_FOUND)
  add_executable(peer_llvmpipe
    ${CMAKE_CURRENT_SOURCE_DIR}/peer_llvmpipe.cpp
    ${CMAKE_CURRENT_SOURCE_DIR}/peer_llvmpipe_gl.cpp
    ${CMAKE_CURRENT_SOURCE_DIR}/peer_llvmpipe_scene.cpp
    ${CMAKE_CURRENT_SOURCE_DIR}/mesh_framing.cpp
    ${CMAKE_CURRENT_SOURCE_DIR}/peer_llvmpipe_compare.cpp)
  target_compile_definitions(peer_llvmpipe PRIVATE GL_GLEXT_PROTOTYPES)
  target_link_libraries(peer_llvmpipe PRIVATE gradraster::gradraster gradraster_example_common PkgConfig::OSMESA)
  message(STATUS "peer_llvmpipe: OSMesa ${OSMESA_VERSION} found, building the llvmpipe comparison")
else()
  message(STATUS "peer_llvmpipe: OSMesa not found (install libosmesa6-dev), skipping the llvmpipe comparison")
endif()
