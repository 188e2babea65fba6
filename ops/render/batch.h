// Many images in one call: nvdiffrast's instanced mode (one triangle list,
// positions per image) and range mode (one position list, a range of
// triangles per image), for rasterize, interpolate and antialias.
//
// A batched G-buffer is an ordinary GBuffer with a leading image axis:
// tri_id [B, H, W], uv [B, H, W, 2], depth [B, H, W] (db [B, H, W, 4]); its ids index the
// whole triangle list (in range mode too). The batch description, the loop
// over images (in parallel, each kernel parallel inside) and the image-order
// gradient sums are the raster layer's (raster/image_batch.h), which the
// Python binding shares. Every image's outputs are bit-identical to a separate call's, for any
// thread count; the gradient of an input the images share (range mode's
// positions, attributes without an image axis) is the sum of the images'
// gradients in image order.
//
// With RasterizeOptions::backend (float32), each image's G-buffer is made on
// the device (bit for bit the CPU's) and kept there, one handle per image
// (GBuffer::resident); interpolate_batch, antialias_batch and the G-buffer's
// adjoint then run image by image on that backend, in image order (values
// and gradients within issue 33's tolerances of the CPU's; docs/gpu.md).
#pragma once

#include <cstdint>
#include <string>

#include "ops/render/antialias.h"
#include "ops/render/interpolate.h"
#include "ops/render/rasterize.h"
#include "raster/depth_peel_state.h"
#include "raster/image_batch.h"

namespace gr {

// Instanced: clip [B, N, 4], triangles [M, 3] -> G-buffer [B, H, W].
GBuffer rasterize_batch(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options);

// Range mode: clip [N, 4], triangles [M, 3], ranges [B, 2] int32 (first
// triangle, count) -> G-buffer [B, H, W]; image b draws triangles
// first..first+count-1, and its tri_id holds their indices in `triangles` (+1).
GBuffer rasterize_ranges(const Tensor& clip, const Tensor& triangles, const Tensor& ranges,
                         const RasterizeOptions& options);

// attributes [N, C] (shared) or [B, N, C] (N = rows of the rasterized clip);
// gbuffer from rasterize_batch / rasterize_ranges -> [B, H, W, C]. Options as
// interpolate's (options.diff_attrs unused).
Tensor interpolate_batch(const Tensor& attributes, const GBuffer& gbuffer, const Tensor& triangles,
                         const InterpolateOptions& options = {});

// image [B, H, W, C], gbuffer [B, H, W], clip [N, 4] or [B, N, 4] -> [B, H, W, C].
// Without options.topology, each image's topology welds vertices by that
// image's clip rows, as antialias does. options.visibility: visibility_antialias
// per image.
Tensor antialias_batch(const Tensor& image, const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                       const AntialiasOptions& options = {});

// Depth peeling of batches: DepthPeeler::instanced and DepthPeeler::ranges
// (ops/render/depth_peel.h). Per-image textures: texture() with tex [B, Ht, Wt, C]
// (ops/render/texture.h).

namespace detail {

// rasterize_batch's and rasterize_ranges's argument checks (op names the
// caller): the tensors' shapes and dtypes here, their values and the ranges
// by the raster layer's checks (raster/mesh_checks.h, raster/image_batch.h).
raster::ImageBatch check_instanced(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                                   const std::string& op);
raster::ImageBatch check_ranges(const Tensor& clip, const Tensor& triangles, const Tensor& ranges,
                                const RasterizeOptions& options, const std::string& op);

// The batched rasterize behind rasterize_batch / rasterize_ranges, unchecked;
// with a peel state, one layer of DepthPeeler (raster/depth_peel_state.h:
// each image behind its previous layer's key, which is then advanced).
// The G-buffer's ids index the whole triangle list; its adjoint is the same
// for every layer (it depends on tri_id only).
GBuffer rasterize_images(const Tensor& clip, const Tensor& triangles, const raster::ImageBatch& batch,
                         const RasterizeOptions& options, raster::DepthPeelState* peel, const char* op);

}  // namespace detail
}  // namespace gr
