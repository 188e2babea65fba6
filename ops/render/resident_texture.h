// The device's copies of the texture and cube_texture ops' textures
// (raster::RasterBackend::texture_forward / texture_backward and the cube-map
// calls with a DeviceTexture handle), found again by the host tensors they
// were made from: the op's forward, its adjoint and later calls on the same texture
// read one copy while tex (and the user's mip levels) are the same storages,
// not written in place since. A texture written in place, or another tensor,
// gets a new slot (no handle: the backend uploads), so results never depend
// on residency. At most kResidentTextureSlots slots, the least recently used
// forgotten first (the device bounds its own copies: raster/vulkan/texture.h).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "autodiff/base/tensor.h"
#include "raster/backend.h"

namespace gr::detail {

constexpr int kResidentTextureSlots = 32;

// One texture image's handle; calls on it hold `mutex` around the backend
// call (so images sharing a texture upload it once).
struct ResidentTexture {
  std::mutex mutex;
  std::shared_ptr<const raster::DeviceTexture> device;
};

// How a texture is read: a 2D texture image or a cube map (6 faces).
enum class TextureKind { Plane, Cube };

// The slot of texture image t of tex (its mip levels 1..levels-1 built from
// it, or the user's `mip`) read as `kind` on `backend`.
std::shared_ptr<ResidentTexture> resident_texture(const raster::RasterBackend* backend, const Tensor& tex,
                                                  std::int64_t t, int levels, const std::vector<Tensor>& mip,
                                                  TextureKind kind = TextureKind::Plane);

}  // namespace gr::detail
