// rasterize_forward on a Vulkan device: the same G-buffer as the CPU kernel
// (raster/rasterize.h), bit for bit: tri_id, (u, v) and depth, row 0 at the
// top. Triangle ids are decided by the CPU's expressions in double precision
// and two order-independent atomic minima (depth, then id at that depth), so
// the result does not depend on scheduling (docs/gpu.md).
//
// Depth peeling too (p.floor_id, p.floor_z; key_depth as on the CPU). Not
// here: RasterStats (the G-buffer adjoint is on the Frame).
#pragma once

#include <cstdint>

#include "raster/rasterize.h"
#include "raster/vulkan/device.h"

namespace gr::vulkan {

struct GpuRasterOptions {
  // Row 0 is the bottom row (nvdiffrast's convention): the result is the CPU
  // kernel's on clip coordinates with y negated. p.settings.y_up (the CPU
  // kernel's own option) does the same; either one turns it on.
  bool y_up = false;
  // Triangles whose pixel box has more pixels than this are scanned by a
  // workgroup each, the others by one thread each (same result; a tuning knob).
  int small_box = 64;
  // Frame::rasterize: also make rast_db, the barycentrics' screen derivatives
  // (raster::barycentric_gbuffer_forward's db), for attribute derivatives.
  bool derivatives = false;
};

// p is checked as the CPU op checks it (Frame::rasterize). key_depth (H x W,
// optional): the winning depth in double, +inf on background (the next
// peeling layer's floor_z). times->pass_ms: clear, project, depth (pass 0),
// id (pass 1), resolve.
void rasterize_forward(Device& device, const raster::RasterParams<float>& p, std::int32_t* tri_id,
                       float* uv, float* depth, const GpuRasterOptions& options = {},
                       GpuTimes* times = nullptr, double* key_depth = nullptr);

}  // namespace gr::vulkan
