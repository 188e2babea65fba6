// A Vulkan device as a raster::RasterBackend: the ops' rasterize makes its
// whole G-buffer there (tri_id, then rast and rast_db: Frame::rasterize) for
// float32 clip positions, depth peeling included, the CPU's bit for bit,
// downloads it once and keeps it on the device (rasterize_gbuffer's
// DeviceGBuffer handle); the interpolate and antialias ops reading that
// G-buffer and the rasterize adjoint run their forward and adjoint there,
// reading the device's copy while the backend keeps it (up to `frames`
// G-buffers at once, least recently used let go first) and uploading the
// G-buffer from the host otherwise (Frame::load_gbuffer), as the calls
// without a handle always do. The texture and cube_texture ops run their
// forward and adjoint there for float32 (raster/vulkan/texture.h,
// raster/vulkan/cube_texture.h); 2D textures and cube maps with a
// DeviceTexture handle stay on the device between calls (texture.h's
// KeptTexels, the device's cache), and their mip levels are built there
// (builds_mip_levels). Thread-safe: one call at a time.
#pragma once

#include <cstdint>
#include <memory>

#include "raster/backend.h"
#include "raster/vulkan/device.h"

namespace gr::vulkan {

// The G-buffers a backend keeps on the device by default: one per view of a
// fit running its views on 4 threads (each frame holds its G-buffer and the
// buffers of the calls on it; docs/gpu.md, "Memory").
constexpr int kResidentGBuffers = 4;

// frames: the G-buffers kept on the device at once (at least 1).
// deferred_calls: the batch ops' calls between begin_deferred and
// end_deferred (raster::DeferredCalls) are submitted without waiting and
// finished together (one wait per batch; the device runs an image while the
// host prepares the next); false waits for each call (the same results, bit
// for bit; for comparison).
std::shared_ptr<const raster::RasterBackend> raster_backend(std::shared_ptr<Device> device,
                                                            int frames = kResidentGBuffers,
                                                            bool deferred_calls = true);

// What a backend from raster_backend did so far, for tests and profiling.
struct ResidencyStats {
  std::int64_t gbuffers = 0;        // G-buffers made and kept on the device (rasterize_gbuffer)
  std::int64_t resident_calls = 0;  // calls that read a G-buffer kept on the device: no upload
  std::int64_t uploads = 0;         // calls that uploaded the G-buffer from the host (Frame::load_gbuffer)
  int frames = 0;                   // frames made so far for kept G-buffers (at most `frames`; uploads use one more)
  // antialias calls (forward and adjoint) that uploaded the edge topology, and its bytes: each frame keeps
  // the last one it uploaded (Frame::antialias), so the same EdgeTopology on the same frame goes up once.
  std::int64_t topology_uploads = 0;
  std::int64_t topology_bytes = 0;
  // Triangle lists uploaded by the frames' rasterize and G-buffer loads, and their bytes: each frame keeps the
  // last one (Frame::triangle_uploads), so a mesh whose triangles stay the same goes up once per frame; and the
  // whole lists antialias read on a range mode image's frame (kept likewise, apart from the range's).
  std::int64_t triangle_uploads = 0;
  std::int64_t triangle_bytes = 0;
  // antialias adjoints that read their forward's pairs, still on the device (DeviceForward), instead of
  // recomputing them (an image upload and the pair pass fewer); interpolate adjoints likewise their
  // forward's attributes (an attribute upload and the interpolate pass fewer).
  std::int64_t antialias_reused = 0;
  std::int64_t interpolate_reused = 0;
  // Device submissions made without waiting, between begin_deferred and end_deferred (raster::DeferredCalls),
  // whose outputs were written at the end.
  std::int64_t deferred_calls = 0;
};
// ValueError if `backend` is not one of raster_backend's.
ResidencyStats residency_stats(const raster::RasterBackend& backend);
// Lets `backend` (one of raster_backend's; ValueError otherwise) keep up to
// `frames` G-buffers at once from now on, if that is more than it keeps (for
// a caller whose minibatches grow: gradraster.torch's RasterizeVulkanContext).
void reserve_frames(const raster::RasterBackend& backend, int frames);

}  // namespace gr::vulkan
