// The device's copy of a G-buffer that rasterize made on its backend
// (raster::RasterBackend::rasterize_gbuffer) and the host tensors it equals.
// The ops reading the G-buffer (interpolate, antialias, the rasterize
// adjoint) hand its handle to the backend only while the G-buffer's tensors
// are still those (the same storage, not written in place since); otherwise
// they call the backend without it, which uploads the host tensors. So
// results never depend on residency.
#pragma once

#include <cstdint>
#include <memory>

#include "autodiff/base/storage.h"
#include "ops/render/rasterize.h"
#include "raster/backend.h"

namespace gr {

struct ResidentGBuffer {
  std::shared_ptr<const raster::DeviceGBuffer> device;
  // A host tensor's storage and its write count when the device's copy was
  // made (defined false: the tensor was undefined).
  struct Source {
    bool defined = false;
    std::weak_ptr<Storage> storage;
    std::uint64_t version = 0;
  };
  Source tri_id, uv, depth, db, clip, triangles;
};

namespace detail {

// device with gb's tensors as they are now (gb.db may be undefined).
std::shared_ptr<const ResidentGBuffer> keep_resident(std::shared_ptr<const raster::DeviceGBuffer> device,
                                                     const GBuffer& gb);

// gb.resident's device handle while gb's tensors are the ones it was made
// with, unwritten since; else null.
const raster::DeviceGBuffer* resident_of(const GBuffer& gb);

}  // namespace detail
}  // namespace gr
