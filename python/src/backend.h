// Where a call of the binding runs its kernels: on the device of a
// RasterizeVulkanContext (Context::backend) for float32, image by image
// through raster::RasterBackend's virtuals, else on the CPU kernels.
// gradraster.torch decides which context a call gets (the one that made its
// rast or uv: docs/python.md, "Vulkan"); a backend that declines a call
// (returns false) leaves it to the CPU kernel. Each call the device ran is
// counted at its call site (counted: Context::device_calls).
#pragma once

#include <cstdint>
#include <memory>
#include <type_traits>
#include <vector>

#include "python/src/rasterize.h"
#include "raster/backend.h"
#include "raster/image_batch.h"
#include "raster/image_on_device.h"

namespace gr::python {

// The G-buffers one rasterize call kept on its context's device, one per
// image (raster::RasterBackend::rasterize_gbuffer; a null handle: none kept)
// with the triangles it drew (a range mode image's range: its copy numbers
// its ids from 1 in the range, so the calls reading it pass the range's
// triangles and ids made local to it, raster::image_on_device).
// gradraster.torch hands them to interpolate, antialias and the rasterize
// adjoint only while rast and what they read (rast_db, pos, tri) are the
// tensors rasterize made or read, unwritten since (_resident.py); these then
// read the device's copy (a backend that let it go uploads the host's
// arrays, as the calls without a handle do). antialias reads a range's copy
// with the whole list (its edge topology indexes it all), the device adding
// the range's first row to the copy's ids.
struct DeviceGBuffers {
  std::vector<raster::KeptImage> images;
  // Image b's copy and range (its handle may be null).
  const raster::KeptImage& image(std::int64_t b) const { return images[static_cast<std::size_t>(b)]; }
};

// What a call hands the backend for image b (raster::image_on_device): kept's
// copy (kept may be null) with the triangles and ids it drew, else tris and
// tri_id (the caller's whole list and image b's host ids, pixels of them);
// whole_list: the copy with tris, tri_id and its first row (antialias).
raster::ImageOnDevice image_on_device(const DeviceGBuffers* kept, std::int64_t b, const std::int32_t* tris,
                                      std::int64_t num_tris, const std::int32_t* tri_id, std::int64_t pixels,
                                      bool whole_list);

// `kept` (may be null) for a call over `images` images: ValueError naming
// `op` if it holds another count.
const DeviceGBuffers* check_kept(const DeviceGBuffers* kept, std::int64_t images, const char* op);

// Counts a call the context's device ran (ran: the backend did not decline
// it) in ctx.device_calls (Context.device_calls in Python); returns ran.
inline bool counted(Context& ctx, bool ran) {
  ctx.device_calls += ran ? 1 : 0;
  return ran;
}

// Before a rasterize of `images` images on a RasterizeVulkanContext whose
// pool grows (frames=None): lets its backend keep that many G-buffers.
void keep_gbuffers(const Context& ctx, std::int64_t images);

// ctx's backend for T = float (null: none, a CPU context, no context, float64).
template <class T>
const raster::RasterBackend* backend_for(const Context* ctx) {
  if constexpr (std::is_same_v<T, float>) return ctx ? ctx->backend.get() : nullptr;
  return nullptr;
}

// The int32 ids (H*W, 0 = background) of rast's id channel (H*W*4, ids
// already checked to be integers in [0, triangles]), what a backend reads.
template <class T>
void rast_ids(const T* rast, std::int64_t pixels, std::vector<std::int32_t>* ids) {
  ids->resize(static_cast<std::size_t>(pixels));
  for (std::int64_t q = 0; q < pixels; ++q) (*ids)[q] = static_cast<std::int32_t>(rast[4 * q + 3]);
}

// body(b) for every image, and after(b), which reads what image b's calls
// wrote: in parallel on the CPU; with a backend, which runs one call at a
// time and is parallel inside (its lock is never awaited inside a parallel
// region), every body in image order with the backend's calls deferred
// (raster::DeferredCalls: the device runs an image while the host prepares
// the next), then every after in image order.
template <class Body, class After>
void for_each_image_on(const raster::RasterBackend* backend, std::int64_t images, Body&& body, After&& after) {
  if (!backend)
    return raster::for_each_image(images, [&](std::int64_t b) {
      body(b);
      after(b);
    });
  raster::DeferredCalls deferred(backend);
  for (std::int64_t b = 0; b < images; ++b) body(b);
  deferred.finish();
  for (std::int64_t b = 0; b < images; ++b) after(b);
}

template <class Body>
void for_each_image_on(const raster::RasterBackend* backend, std::int64_t images, Body&& body) {
  for_each_image_on(backend, images, body, [](std::int64_t) {});
}

}  // namespace gr::python
