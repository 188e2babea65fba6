// A Vulkan device as a raster::RasterBackend: the ops' rasterize runs its
// forward there for float32 clip positions, depth peeling included (the
// rest stays on the CPU), with the same G-buffer bit for bit, and its adjoint;
// the interpolate and antialias ops reading that G-buffer run their forward
// and adjoint there (through a Frame of the backend's own, into which each
// call uploads the G-buffer: Frame::load_gbuffer); the texture and
// cube_texture ops run their forward and adjoint there for float32
// (raster/vulkan/texture.h, raster/vulkan/cube_texture.h).
#pragma once

#include <memory>

#include "raster/backend.h"
#include "raster/vulkan/device.h"

namespace gr::vulkan {

std::shared_ptr<const raster::RasterBackend> raster_backend(std::shared_ptr<Device> device);

}  // namespace gr::vulkan
