// Everything a user needs: tensors, the tape, gradcheck, Adam and all ops.
#pragma once

#include "autodiff/gradcheck.h"
#include "autodiff/optim.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "autodiff/base/tensor.h"
#include "ops/render/antialias.h"
#include "ops/render/visibility_antialias.h"
#include "ops/render/batch.h"
#include "ops/tensor/channel.h"
#include "ops/render/cube_texture.h"
#include "ops/tensor/elementwise.h"
#include "ops/tensor/factories.h"
#include "ops/render/fragments.h"
#include "ops/render/interpolate.h"
#include "ops/tensor/linalg.h"
#include "ops/render/project.h"
#include "ops/tensor/promote.h"
#include "ops/render/depth_peel.h"
#include "ops/render/rasterize.h"
#include "ops/tensor/reduce.h"
#include "ops/render/resample.h"
#include "ops/tensor/map_rows.h"
#include "ops/mesh.h"
#include "ops/shading.h"
#include "ops/tensor/shape_ops.h"
#include "ops/render/soft_rasterize.h"
#include "ops/render/ssr.h"
#include "ops/render/texture.h"
#include "ops/render/transforms.h"
#include "ops/tensor/vector.h"

namespace gr {
// Kernel-side types that the ops' results and options carry, so an ops user
// never needs to spell gr::raster:: (Cull, Filter, Wrap and the SSR options
// are exported by their op headers).
using raster::AntialiasStats;    // AntialiasOptions::stats
using raster::EdgeTopology;      // what AntialiasTopology points to
using raster::kBackgroundDepth;  // GBuffer::depth of uncovered pixels
using raster::RasterStats;       // GBuffer::stats
using raster::SsrStats;          // the SSR results' stats
}  // namespace gr
