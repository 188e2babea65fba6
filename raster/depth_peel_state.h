// Depth peeling, written once for both front ends (ops/render/depth_peel.h's
// DepthPeeler and the binding's gradraster.torch DepthPeeler): per pixel of
// every image of a batch, the previous layer's (depth, id) key, which the
// next layer must lie strictly behind (raster::RasterParams::floor_id /
// floor_z), and the step that rasterizes one image of a layer with it.
#pragma once

#include <cstdint>
#include <vector>

#include "raster/backend.h"
#include "raster/rasterize.h"

namespace gr::raster {

class DepthPeelState {
 public:
  // Starts the next layer of `images` images of `pixels` pixels each; sizes
  // the state on the first layer. ValueError ("DepthPeeler: layer k has ...")
  // if a later layer's images or size differ from the first's.
  void begin_layer(std::int64_t images, std::int64_t width, std::int64_t height);
  // One image of the current layer: rasterize_forward(p) with image b's key
  // of the previous layer as the floor (none on the first layer), writing
  // tri_id, uv and depth as rasterize_forward does (ids local to p's
  // triangles) and keeping image b's new key for the next layer; on
  // `backend` where it covers p (rasterize_forward_on).
  template <class T>
  void rasterize_image(RasterParams<T> p, std::int64_t b, std::int32_t* tri_id, T* uv, T* depth,
                       RasterStats* stats = nullptr, const RasterBackend* backend = nullptr);
  // Ends the layer begun by begin_layer: its keys become the next layer's floor.
  void end_layer();
  // Layers ended so far.
  int layers() const { return layers_; }

  // For a caller that runs rasterize_forward itself (one image outside a
  // batch): image b's floor of the current layer (null on the first layer),
  // the key-depth buffer to pass as key_depth, and keep_ids(b, tri_id) after.
  const std::int32_t* floor_id(std::int64_t b) const;
  const double* floor_z(std::int64_t b) const;
  double* key_z(std::int64_t b) { return z_[next()].data() + b * pixels_; }
  void keep_ids(std::int64_t b, const std::int32_t* tri_id);

 private:
  int next() const { return (layers_ + 1) % 2; }  // the buffers the current layer writes
  std::int64_t images_ = 0, pixels_ = 0;
  int layers_ = 0;
  // Two keys, swapped at each layer: the floor (layers_ % 2) and the key being written.
  std::vector<std::int32_t> id_[2];
  std::vector<double> z_[2];
};

}  // namespace gr::raster
