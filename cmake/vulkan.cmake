# The Vulkan GPU path (raster/vulkan/): gradraster_vulkan, built when the
# Vulkan loader (libvulkan-dev) and glslc are found and GRADRASTER_WITH_VULKAN
# is on. The compute shaders are compiled to SPIR-V at build time and embedded
# in the library as word arrays (cmake/embed_spirv.cmake).
option(GRADRASTER_WITH_VULKAN "Build the Vulkan GPU path (raster/vulkan/) when Vulkan and glslc are found" ON)
set(GRADRASTER_HAS_VULKAN OFF)
if(GRADRASTER_WITH_VULKAN)
  find_package(Vulkan QUIET)
  find_program(GRADRASTER_GLSLC glslc)
  if(Vulkan_FOUND AND GRADRASTER_GLSLC)
    set(GRADRASTER_HAS_VULKAN ON)
  else()
    message(STATUS "gradraster: Vulkan loader or glslc not found: no GPU path (install libvulkan-dev glslc)")
  endif()
endif()

if(GRADRASTER_HAS_VULKAN)
  set(shader_dir ${CMAKE_CURRENT_SOURCE_DIR}/raster/vulkan/shaders)
  file(GLOB shader_includes CONFIGURE_DEPENDS ${shader_dir}/*.glsl)
  set(shader_names project raster_small raster_large resolve interpolate_forward interpolate_backward
    fixed_point_finish gbuffer gbuffer_backward antialias_pairs antialias_forward
    antialias_backward antialias_finish visibility_pairs texture_forward texture_backward texture_finish
    texture_mip cube_texture_forward cube_texture_backward)
  set(embedded ${CMAKE_CURRENT_BINARY_DIR}/vulkan_shaders.cpp)
  set(spv_files)
  foreach(name ${shader_names})
    set(spv ${CMAKE_CURRENT_BINARY_DIR}/shaders/${name}.spv)
    add_custom_command(OUTPUT ${spv}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${CMAKE_CURRENT_BINARY_DIR}/shaders
      COMMAND ${GRADRASTER_GLSLC} --target-env=vulkan1.2 -O -Werror -o ${spv} ${shader_dir}/${name}.comp
      DEPENDS ${shader_dir}/${name}.comp ${shader_includes}
      COMMENT "glslc ${name}.comp" VERBATIM)
    list(APPEND spv_files ${spv})
  endforeach()
  string(REPLACE ";" "," shader_list "${shader_names}")
  add_custom_command(OUTPUT ${embedded}
    COMMAND ${CMAKE_COMMAND} -DOUT=${embedded} -DNAMES=${shader_list}
      -DDIR=${CMAKE_CURRENT_BINARY_DIR}/shaders -P ${CMAKE_CURRENT_SOURCE_DIR}/cmake/embed_spirv.cmake
    DEPENDS ${spv_files} ${CMAKE_CURRENT_SOURCE_DIR}/cmake/embed_spirv.cmake
    COMMENT "embedding the SPIR-V shaders" VERBATIM)
  file(GLOB vulkan_sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/raster/vulkan/*.cpp)
  add_library(gradraster_vulkan ${vulkan_sources} ${embedded})
  target_link_libraries(gradraster_vulkan PUBLIC gradraster_raster PRIVATE Vulkan::Vulkan)
  # Vulkan structs are written {sType} with the rest zero, as the API intends.
  target_compile_options(gradraster_vulkan PRIVATE -Wall -Wextra -Wno-missing-field-initializers)
  target_compile_definitions(gradraster_vulkan INTERFACE GRADRASTER_HAS_VULKAN=1)
  add_library(gradraster::vulkan ALIAS gradraster_vulkan)
  message(STATUS "gradraster: Vulkan ${Vulkan_VERSION} and glslc found: building the GPU path (gradraster::vulkan)")
endif()
