// Internal to the Vulkan path: the SPIR-V of raster/vulkan/shaders/*.comp,
// compiled by glslc at build time and embedded (cmake/vulkan.cmake).
#pragma once

#include <cstddef>
#include <cstdint>

namespace gr::vulkan::shaders {

struct Spirv {
  const std::uint32_t* words;
  std::size_t count;
};

Spirv project();
Spirv raster_small();
Spirv raster_large();
Spirv resolve();
Spirv interpolate_forward();
Spirv interpolate_backward();
Spirv fixed_point_finish();
Spirv gbuffer();
Spirv gbuffer_backward();
Spirv antialias_pairs();
Spirv antialias_forward();
Spirv antialias_backward();
Spirv antialias_finish();
Spirv visibility_pairs();
Spirv texture_forward();
Spirv texture_backward();
Spirv texture_finish();
Spirv texture_mip();
Spirv cube_texture_forward();
Spirv cube_texture_backward();

}  // namespace gr::vulkan::shaders
