// rasterize and the depth peeler in nvdiffrast's layout, over a Mesh.
#pragma once

#include <vector>

#include "python/src/common.h"

namespace gr::python {

// The state of one DepthPeeler: per image, the previous layer's (depth, id)
// key, which the next layer must lie strictly behind.
struct PeelState {
  std::vector<std::int32_t> floor_id;  // images x H x W (0 before the first layer)
  std::vector<double> floor_z;
  int layers = 0;
};

// Per-context scratch (RasterizeCpuContext), reused across calls so large
// buffers are allocated and page-faulted once.
struct Context {
  std::vector<std::int32_t> tri_id;
  std::vector<float> uv_f, depth_f, clip_f, grad_f;
  std::vector<double> uv_d, depth_d, clip_d, grad_d, key_depth;
  template <class T>
  std::vector<T>& uv();
  template <class T>
  std::vector<T>& depth();
  template <class T>
  std::vector<T>& clip();
  template <class T>
  std::vector<T>& grad();
};

// rast, db: images x H x W x 4 (db may be 0). With a peel state, each image
// draws only what lies behind the state's key, which is then advanced.
void rasterize_forward(Context& ctx, const Mesh& mesh, int height, int width, Address rast, Address db,
                       PeelState* peel, int threads);
// grad_pos (zeroed by the caller, pos's shape) += the adjoint for the
// coverage in rast; grad_db may be 0.
void rasterize_backward(Context& ctx, const Mesh& mesh, int height, int width, Address rast, Address grad_rast,
                        Address grad_db, Address grad_pos, int threads);

}  // namespace gr::python
