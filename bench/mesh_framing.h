// The camera the rasterizer benchmarks and the llvmpipe comparison share.
#pragma once

#include "autodiff/base/tensor.h"
#include "raster/mesh.h"

namespace gr::bench {

// look_at + perspective (square image) from gr::examples::frame_mesh, framing the mesh's
// bounding sphere from an oblique direction; returns the clip positions
// transform_points(positions, P V) (N x 4, no gradient).
Tensor frame_mesh(const raster::Mesh& mesh);

}  // namespace gr::bench
