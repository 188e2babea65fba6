// The device's copy of a G-buffer that rasterize (or, image by image,
// rasterize_batch / rasterize_ranges) made on its backend
// (raster::RasterBackend::rasterize_gbuffer) and the host tensors it equals.
// The ops reading the G-buffer (interpolate, antialias, the rasterize
// adjoint) hand its handle to the backend only while the G-buffer's tensors
// are still those (the same storage, not written in place since); otherwise
// they call the backend without it, which uploads the host tensors. So
// results never depend on residency.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "autodiff/base/storage.h"
#include "ops/render/rasterize.h"
#include "ops/render/tensor_stamp.h"
#include "raster/backend.h"
#include "raster/image_on_device.h"

namespace gr {

struct ResidentGBuffer {
  // One image's copy and the triangles it drew (raster/image_on_device.h:
  // a range mode image's range, all the triangles otherwise).
  using Image = raster::KeptImage;
  std::vector<Image> images;  // one per image, in image order (one for an [H, W] G-buffer)
  // The host tensors as they were when the device's copies were made.
  detail::TensorStamp tri_id, uv, depth, db, clip, triangles;
};

namespace detail {

// The images' copies with gb's tensors as they are now (gb.db may be undefined).
std::shared_ptr<const ResidentGBuffer> keep_resident(std::vector<ResidentGBuffer::Image> images, const GBuffer& gb);
// One image that drew all of gb.triangles.
std::shared_ptr<const ResidentGBuffer> keep_resident(std::shared_ptr<const raster::DeviceGBuffer> device,
                                                     const GBuffer& gb);

// Image b's copy while gb's tensors are the ones it was made with, unwritten
// since, and the backend made one; else null.
const ResidentGBuffer::Image* resident_image(const GBuffer& gb, std::int64_t b);
// resident_image(gb, 0)'s device handle (an [H, W] G-buffer's), or null.
const raster::DeviceGBuffer* resident_of(const GBuffer& gb);

// What a batch op hands the backend for image b (raster::image_on_device):
// the device's copy and the triangles and ids it drew (a range's, ids made
// local to it) while `made` (the G-buffer as made, may be null) still matches
// it (with whole_list: the copy with all the triangles, the host's ids and the
// copy's first row, for antialias, whose topology indexes them all); else no
// copy, all the triangles and the host's ids (the backend uploads them).
// Either way the same image for the kernels.
using ImageOnDevice = raster::ImageOnDevice;
// tri_id: image b's host ids (pixels of them), indexing all of triangles.
ImageOnDevice image_on_device(const GBuffer* made, std::int64_t b, const Tensor& triangles,
                              const std::int32_t* tri_id, std::int64_t pixels, bool whole_list);

}  // namespace detail
}  // namespace gr
