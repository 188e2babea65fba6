# The installed headers: the public entry points below and every project header
# they include, directly or not (an installed header must compile), found by
# reading their `#include "..."` lines. Nothing else is installed: the kernels'
# internal helpers (raster/detail/rasterize_scan.h, ops/mesh/row_sums.h, ...) stay in
# the source tree. tests/package/test_install.sh checks both halves.
set(GRADRASTER_PUBLIC_ENTRY_HEADERS
  ops/ops.h ops/render/book_interface.h
  raster/antialias.h raster/backend.h raster/barycentric_gbuffer.h raster/barycentric_interpolate.h
  raster/cube_texture.h raster/io/files.h raster/io/image_io.h raster/mesh.h raster/mipmap.h
  raster/io/obj_io.h raster/procedural.h raster/project.h raster/rasterize.h raster/soft_rasterize.h raster/ssr.h
  raster/temporaries.h raster/texture.h)
file(GLOB _autodiff_headers RELATIVE ${PROJECT_SOURCE_DIR} ${PROJECT_SOURCE_DIR}/autodiff/*.h
  ${PROJECT_SOURCE_DIR}/autodiff/base/*.h)
list(APPEND GRADRASTER_PUBLIC_ENTRY_HEADERS ${_autodiff_headers})
# Not installed yet, as their libraries: raster/vulkan (gradraster::vulkan) and
# autodiff/mpi (gradraster::mpi) are build-tree libraries.

# out_var: the entry headers and their project includes, transitively (paths
# relative to the source root, sorted).
function(gradraster_header_closure out_var)
  set(found "")
  set(pending ${ARGN})
  while(pending)
    list(POP_FRONT pending header)
    if(header IN_LIST found OR NOT EXISTS ${PROJECT_SOURCE_DIR}/${header})
      continue()
    endif()
    list(APPEND found ${header})
    set_property(DIRECTORY ${PROJECT_SOURCE_DIR} APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/${header})
    file(STRINGS ${PROJECT_SOURCE_DIR}/${header} includes REGEX "^[ \t]*#[ \t]*include[ \t]*\"")
    foreach(line IN LISTS includes)
      string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*\"([^\"]+)\".*" "\\1" included "${line}")
      list(APPEND pending ${included})
    endforeach()
  endwhile()
  list(SORT found)
  set(${out_var} ${found} PARENT_SCOPE)
endfunction()

gradraster_header_closure(GRADRASTER_INSTALLED_HEADERS ${GRADRASTER_PUBLIC_ENTRY_HEADERS})
