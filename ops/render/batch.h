// Many images in one call: nvdiffrast's instanced mode (one triangle list,
// positions per image) and range mode (one position list, a range of
// triangles per image), for rasterize, interpolate and antialias.
//
// A batched G-buffer is an ordinary GBuffer with a leading image axis:
// tri_id [B, H, W], uv [B, H, W, 2], depth [B, H, W] (db [B, H, W, 4]); its ids index the
// whole triangle list (in range mode too). Images run in parallel and each
// kernel is parallel inside, so a batch of small images keeps every core
// busy. Every image's outputs are bit-identical to a separate call's, for any
// thread count; the gradient of an input the images share (range mode's
// positions, attributes without an image axis) is the sum of the images'
// gradients in image order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autodiff/base/parallel.h"
#include "ops/render/antialias.h"
#include "ops/render/interpolate.h"
#include "ops/render/rasterize.h"

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

// Runs body(b) for every image; images in parallel, kernels parallel inside.
template <class F>
void for_each_image(std::int64_t images, F body) {
  parallel_for(0, images, 1, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t b = lo; b < hi; ++b) body(b);
  });
}

// total += part, elementwise, for a gradient the images share (range mode's
// positions, a shared attribute or texture): adding the images' parts one
// after the other in image order gives the sum separate calls would
// accumulate, for any thread count. Nothing when total is undefined.
void add_image_gradient(Tensor& total, const Tensor& part);

// What a checked batched rasterize draws: instanced (clip [B, N, 4], every
// image all triangles) or range mode (clip [N, 4] shared, image b the
// triangles first .. first + count - 1).
struct ImageBatch {
  struct Range {
    std::int64_t first, count;
  };
  bool instanced = false;
  std::vector<Range> ranges;  // one per image
};
// rasterize_batch's and rasterize_ranges's argument checks (op names the caller).
ImageBatch check_instanced(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                           const std::string& op);
ImageBatch check_ranges(const Tensor& clip, const Tensor& triangles, const Tensor& ranges,
                        const RasterizeOptions& options, const std::string& op);

// Per-pixel (depth, id) keys of a peeled layer, B*H*W each: ids in the
// kernel's numbering (local to an image's range, 1-based, 0 = background) and
// the exact double depths (raster::RasterParams::floor_id / floor_z). Tensors
// (int32 and float64, [B*H*W]), so that their buffers come from the storage
// cache instead of fresh pages for every layer.
struct PeelKey {
  Tensor id, z;
};
// The batched rasterize behind rasterize_batch / rasterize_ranges, unchecked,
// with an optional peeling floor (the previous layer's key) and key output.
// The G-buffer's ids index the whole triangle list; its adjoint is the same
// for every layer (it depends on tri_id only).
GBuffer rasterize_images(const Tensor& clip, const Tensor& triangles, const ImageBatch& batch,
                         const RasterizeOptions& options, const PeelKey* floor, PeelKey* key, const char* op);

}  // namespace detail
}  // namespace gr
